"""Local worker processes and the user's own script (analysis/engine/campaign/local.py).

A worker started by a fork server re-imports the parent's ``__main__`` by default; a script
without the ``if __name__ == "__main__":`` guard would then fly its campaign again in every
worker (or, as Python refuses it, crash with a bootstrapping error).  The claim: such a
script runs its campaign once, with two workers, and gets the campaign a guarded run gets.
"""

import subprocess
import sys
import textwrap

import pandas as pd

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
