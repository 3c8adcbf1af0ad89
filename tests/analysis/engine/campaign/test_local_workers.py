"""Local worker processes and the user's own script (rcsim/analysis/engine/campaign/local.py).

A worker started by a fork server re-imports the parent's ``__main__`` by default; a script
without the ``if __name__ == "__main__":`` guard would then fly its campaign again in every
worker (or, as Python refuses it, crash with a bootstrapping error).  The claim: such a
script runs its campaign once, with two workers, and gets the campaign a guarded run gets.
And the workers fly the code the script imported, wherever it put rcsim on its path.
"""

import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd

import rcsim

SCRIPT = textwrap.dedent("""
    # A user's script, no __main__ guard, as a notebook export would be.
    from rcsim import load_spec, parse_dict, run_campaign
    print("SCRIPT RAN", flush=True)
    spec = parse_dict({{"seed": 3, "runs_per_case": 2, "chunk_size": 1,
                        "scenario": {{"cases": [1, 2], "duration_s": 2.0}},
                        "controller": {{"name": "phase-plane"}},
                        "output": {{"histories": "none", "plots": False}}}})
    run_campaign(spec, r"{out}", local_workers=2, progress=False)
""")


def test_an_unguarded_script_runs_its_campaign_once(tmp_path):
    script = tmp_path / "user_script.py"
    script.write_text(SCRIPT.format(out=tmp_path / "out"))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("SCRIPT RAN") == 1, done.stdout
    runs = pd.read_parquet(tmp_path / "out" / "runs.parquet")
    assert sorted(runs["run_id"]) == [0, 1, 2, 3]


WHERE = textwrap.dedent("""
    import sys
    sys.path.insert(0, r"{tree}")
    from rcsim.analysis.engine.campaign.local import worker_pool

    def where():
        import rcsim.analysis.engine.campaign.chunk as chunk
        return chunk.__file__

    if __name__ == "__main__":
        import rcsim
        pool = worker_pool(2)
        print("PARENT", rcsim.__file__)
        print("WORKER", pool.submit(where).result())
        pool.shutdown()
""")


def test_workers_fly_the_tree_the_script_imported(tmp_path):
    """A script that puts another copy of rcsim first on ``sys.path`` (a second checkout, a
    notebook's ``sys.path.insert``) must have its chunks flown by that copy, the code its
    manifest names.  Python 3.11's fork server preloads the chunk module without the parent's
    path, so without the fix its workers import the installed tree.  Oracle: the
    file the worker's chunk module was loaded from lies in the copy."""
    installed = Path(rcsim.__file__).resolve().parent.parent
    copy = tmp_path / "other-checkout"
    shutil.copytree(
        installed / "rcsim", copy / "rcsim", ignore=shutil.ignore_patterns("__pycache__")
    )
    script = tmp_path / "where.py"
    script.write_text(WHERE.format(tree=copy))
    # Run from tmp_path: the fork server's own working directory comes first on its path.
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, timeout=120
    )
    assert done.returncode == 0, done.stderr
    lines = dict(line.split(" ", 1) for line in done.stdout.splitlines() if " " in line)
    assert Path(lines["PARENT"]).is_relative_to(copy), done.stdout
    assert Path(lines["WORKER"]).is_relative_to(copy), done.stdout
