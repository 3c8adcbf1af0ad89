"""Kill a command at a random point, then overwrite: nothing of another command is deleted.

Oracle: issue 31, "What to build" 1: "A kill at any point leaves no state in which one
command's ``--overwrite`` deletes another's results.  Test by killing each command at random
points, then overwriting."  Three representative writers, small inputs:

* ``rcsim maneuver`` -- a directory written whole (a temporary renamed into place);
* ``rcsim lookup database`` -- three files committed together;
* ``rcsim campaign run`` -- a directory written in place, chunk by chunk, and resumed.

Each is run once to the end (a subprocess: its wall time bounds the kill points), then
re-run over its own output and killed (SIGKILL) at a point drawn from a seeded generator over
that time -- in the imports, the flight, the writing or the rename.  After each kill: another
command's ``--overwrite`` on what is there is refused and changes nothing; the same command
replaces (or, for the campaign, resumes) it; and what is there is whole: a directory's record
lists everything in it, a campaign resumes to every run exactly once.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.output_records import unlisted_entry

#: Kills per command: a few representative points, not an exhaustive sweep (CI time).
KILLS = 2
SPEC = """
seed = 3
runs_per_case = 6
chunk_size = 2
[scenario]
kind = "maneuver"
attitude_deg = [0.0, 0.0, 2.0]
duration_s = 10.0
[controller]
name = "phase-plane"
[output]
histories = "all"
plots = false
"""
MANEUVER = ["maneuver", "--attitude-deg", "0", "0", "2", "--duration-s", "2"]
DATABASE = ["lookup", "database", "--vehicle", "paper", "--vehicles", "2"]


def _rcsim(argv, cwd) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "rcsim", *argv],
        cwd=cwd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def _full_run(argv, cwd) -> float:
    t0 = time.perf_counter()
    proc = _rcsim(argv, cwd)
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    return time.perf_counter() - t0


def _killed_run(argv, cwd, delay_s: float) -> None:
    proc = _rcsim(argv, cwd)
    try:
        proc.wait(timeout=delay_s)  # finished before the kill point: a valid point too
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    proc.stderr.close()


def _snapshot(root: Path) -> dict:
    return {
        str(p.relative_to(root)): (p.read_bytes() if p.is_file() else None)
        for p in sorted(root.rglob("*"))
    }


def _refused_unchanged(argv, protected: Path, capsys) -> None:
    before = _snapshot(protected)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rcsim: error: "), err
    assert _snapshot(protected) == before


@pytest.fixture
def kill_points():
    """Seeded: the same points on every run of the test (reproducible CI)."""
    rng = random.Random(31)
    return lambda total_s: [rng.uniform(0.2, 1.1) * total_s for _ in range(KILLS)]


@pytest.mark.slow
def test_maneuver_killed_then_overwritten(tmp_path, capsys, monkeypatch, kill_points):
    monkeypatch.chdir(tmp_path)
    total = _full_run([*MANEUVER, "--out", "M"], tmp_path)
    for delay in kill_points(total):
        _killed_run([*MANEUVER, "--attitude-deg", "0", "1", "0", "--out", "M", "--overwrite"],
                    tmp_path, delay)  # fmt: skip
        out = tmp_path / "M"
        if out.exists():
            assert unlisted_entry(out) is None  # the old output or the new one, whole
            # Another command's --overwrite: refused, nothing deleted.
            _refused_unchanged(["study", "noisy-sensor", "--runs", "2", "--out", "M",
                                "--overwrite"], out, capsys)  # fmt: skip
        assert main([*MANEUVER, "--out", "M", "--overwrite"]) == 0  # no stale lock, no debris
        capsys.readouterr()
        assert unlisted_entry(out) is None
        # The killed writer's staging folder is gone with it (issue 38).
        assert not list(tmp_path.glob(".M.tmp-*"))


@pytest.mark.slow
def test_lookup_database_killed_then_overwritten(tmp_path, capsys, monkeypatch, kill_points):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "D").mkdir()
    total = _full_run([*DATABASE, "--out", "D/db.parquet"], tmp_path)
    for delay in kill_points(total):
        _killed_run([*DATABASE, "--seed", "2", "--out", "D/db.parquet", "--overwrite"],
                    tmp_path, delay)  # fmt: skip
        # The folder holds no command's directory: no other command takes it over.
        _refused_unchanged([*MANEUVER, "--out", "D", "--overwrite"], tmp_path / "D", capsys)
        assert pd.read_parquet(tmp_path / "D" / "db.parquet").shape[0] > 0  # whole, never half
        assert main([*DATABASE, "--out", "D/db.parquet", "--overwrite"]) == 0
        capsys.readouterr()
        names = sorted(p.name for p in (tmp_path / "D").iterdir() if not p.name.startswith("."))
        assert names == ["db.parquet", "db.png", "db_summary.csv"]


@pytest.mark.slow
def test_campaign_killed_then_overwritten_by_others_and_resumed(
    tmp_path, capsys, monkeypatch, kill_points
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC)
    run = ["campaign", "run", "spec.toml", "--no-progress", "--out"]
    total = _full_run([*run, "whole"], tmp_path)
    for k, delay in enumerate(kill_points(total)):
        out = f"C{k}"
        _killed_run([*run, out], tmp_path, delay)
        if not (tmp_path / out).exists():
            continue  # killed before it made its directory: nothing to protect
        # Wherever it was killed, the other commands' --overwrite refuses it, deleting nothing.
        _refused_unchanged([*MANEUVER, "--out", out, "--overwrite"], tmp_path / out, capsys)
        _refused_unchanged(
            ["campaign", "replay", "whole", "1", "--out", out, "--overwrite"],
            tmp_path / out,
            capsys,
        )
        assert main([*run, out, "--resume"]) == 0  # and the campaign itself finishes it
        capsys.readouterr()
        runs = pd.read_parquet(tmp_path / out / "runs.parquet")
        assert sorted(runs["run_id"]) == list(range(6))  # every run once
        assert len(os.listdir(tmp_path / out / "histories")) == 6


def test_a_campaign_killed_before_its_manifest_starts_again(tmp_path, capsys, monkeypatch):
    # Killed between its marker (written first) and its manifest: nothing was flown, so the
    # directory is taken up again, with or without --resume; any chunk in it and it is not.
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC.replace("runs_per_case = 6", "runs_per_case = 2"))
    out = tmp_path / "C"
    (out / "chunks").mkdir(parents=True)
    (out / "histories").mkdir()
    (out / ".rcsim-output").write_text("written by rcsim campaign run\n")
    (out / ".manifest.json.x1y2.tmp").write_text("{")  # its atomic write, cut short
    assert main(["campaign", "run", "spec.toml", "--out", "C", "--no-progress"]) == 0
    capsys.readouterr()
    assert len(pd.read_parquet(out / "runs.parquet")) == 2
    other = tmp_path / "D"
    (other / "chunks").mkdir(parents=True)
    (other / "chunks" / "runs-0000000.parquet").write_text("PAR1")
    (other / ".rcsim-output").write_text("written by rcsim campaign run\n")
    _refused_unchanged(["campaign", "run", "spec.toml", "--out", "D", "--resume"], other, capsys)
