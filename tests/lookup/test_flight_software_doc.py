"""docs/flight_software.md's commands, run as written (from the repository's root)."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pandas as pd

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "flight_software.md").read_text()


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", DOC, flags=re.S)


def test_the_maneuver_command_flies_and_records_the_plugin(tmp_path, monkeypatch):
    command = _blocks("sh")[0].replace("\\\n", " ")
    argv = shlex.split(command)[1:]  # after `rcsim`
    out = argv.index("--out") + 1
    argv[out] = str(tmp_path / "switching")
    monkeypatch.chdir(ROOT)
    assert main(argv) == 0
    summary = json.loads((tmp_path / "switching" / "summary.json").read_text())
    assert summary["controller"] == argv[argv.index("--controller") + 1]
    assert summary["plugin"]["target"].endswith("switching_line.py:make_controller")
    assert len(summary["plugin"]["source_sha256"]) == 64
    history = pd.read_parquet(tmp_path / "switching" / "history.parquet")
    assert history.filter(like="_on_s").to_numpy().sum() > 0  # it fired


def test_the_campaign_spec_snippet_loads_and_flies(tmp_path):
    snippet = _blocks("toml")[0]
    # The snippet's path is relative to the spec: the spec sits at the repository's root.
    spec_file = ROOT / f".flight_software_doc_{tmp_path.name}.toml"
    spec_file.write_text(
        "runs_per_case = 2\n[scenario]\ncases = [13]\nduration_s = 4.0\n[output]\n"
        'histories = "none"\nplots = false\n' + snippet
    )
    try:
        spec = load_spec(spec_file)
    finally:
        spec_file.unlink()
    assert spec.controller_params == {"deadband_deg_s": 0.02}
    run_campaign(spec, tmp_path / "c", local_workers=1, progress=False)
    manifest = json.loads((tmp_path / "c" / "manifest.json").read_text())
    assert manifest["spec"]["controller"]["plugin_record"]["target"].endswith(
        "switching_line.py:make_controller"
    )


def test_the_c_example_builds_and_flies_as_written(tmp_path, monkeypatch):
    """The second sh block: the build script, then the maneuver with the library."""
    import os
    import shutil
    import subprocess
    import sys

    import pytest

    if shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("no C compiler (cc) to build the C example")
    build, fly = _blocks("sh")[1].replace("\\\n", " ").strip().splitlines()
    lib = tmp_path / "libswitching_line.so"
    argv = shlex.split(build)
    argv[-1] = str(lib)
    monkeypatch.chdir(ROOT)
    subprocess.run(argv, check=True, env={**os.environ, "PYTHON": sys.executable})
    argv = shlex.split(fly)[1:]
    argv[argv.index("--controller") + 1] = f"library:{lib}"
    argv[argv.index("--out") + 1] = str(tmp_path / "switching_c")
    assert main(argv) == 0
    summary = json.loads((tmp_path / "switching_c" / "summary.json").read_text())
    assert summary["firings"] > 0 and summary["plugin"]["target"] == str(lib)


def test_refining_your_table_runs_as_written(tmp_path, monkeypatch, c_build):
    """Section 10's `rcsim lookup refine --controller library:...`, at a test's size (one case,
    10 runs of 6 s): the library declared its table, flew every candidate, and is named."""
    block = next(b for b in _blocks("sh") if "lookup refine" in b)
    argv = shlex.split(block.splitlines()[0])[1:]
    lib = c_build(ROOT / "examples" / "c_fsw" / "lookup.c", tmp_path / "liblookup.so")
    argv[argv.index("--controller") + 1] = f"library:{lib}"
    argv[argv.index("--out") + 1] = str(tmp_path / "r.csv")
    argv += ["--cases", "3", "--runs", "10", "--search-runs", "10", "--duration-s", "6"]
    monkeypatch.chdir(ROOT)
    assert main(argv) == 0
    log = pd.read_csv(tmp_path / "r_changelog.csv")
    assert log["controller"].str.startswith(f"library:{lib} (").all()
