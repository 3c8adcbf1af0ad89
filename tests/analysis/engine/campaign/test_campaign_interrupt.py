"""Stopping a campaign: Ctrl-C and SIGTERM stop it with one line and leave it
resumable (exit status 130 after Ctrl-C, 143 = 128 + SIGTERM after SIGTERM, the shell's
convention for a process a signal stopped); temporaries a killed process left are cleaned;
outputs honour the umask.  How promptly it stops is measured in benchmarks/campaign.py."""

import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.models.atomic import TEMP_GLOB, UMASK, atomic_write, mode_under_umask

# 16 runs in 8 chunks of 60 s flights (~0.3 s of computing each with the flight model): the
# first chunk commits while most are still to fly.
SPEC = """
seed = 11
runs_per_case = 8
chunk_size = 2
[scenario]
cases = [13, 22]
duration_s = 60.0
[controller]
name = "phase-plane"
[output]
histories = "{histories}"
plots = {plots}
"""
# How promptly it stops is a wall-clock figure, measured in benchmarks/campaign.py
# (``--only interrupt``), not asserted here.


def _write_spec(tmp_path, histories="none", plots="false") -> Path:
    path = tmp_path / "spec.toml"
    path.write_text(SPEC.format(histories=histories, plots=plots))
    return path


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("whole")
    run_campaign(load_spec(_write_spec(tmp)), tmp / "out", local_workers=2, progress=False)
    return pd.read_parquet(tmp / "out" / "runs.parquet")


def _interrupt(spec_path: Path, out: Path, extra: list[str], sig: int, *, group: bool):
    """Start ``rcsim campaign run`` in its own session, send ``sig`` once its first chunk has
    committed (to the whole process group, as a terminal's Ctrl-C does, if ``group``), and
    return (exit code, stderr)."""
    cli = [
        sys.executable,
        "-m",
        "rcsim",
        "campaign",
        "run",
        str(spec_path),
        "--out",
        str(out),
        "--no-progress",
        *extra,
    ]
    # A terminal's rcsim starts with Ctrl-C at its default; a test runner started in the
    # background of a non-interactive shell passes SIGINT on *ignored*, and an ignored SIGINT
    # stays ignored in Python.  Restore the default so the test sees what a user sees.
    # faulthandler: should the process crash instead of stopping, stderr says where.
    proc = subprocess.Popen(
        cli,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if any((out / "chunks").glob("runs-*.parquet")):
                break
            time.sleep(0.01)
        assert proc.poll() is None, "campaign ended before it could be interrupted"
        (os.killpg if group else os.kill)(proc.pid, sig)
        _, err = proc.communicate(timeout=60)
        return proc.returncode, err
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


@pytest.mark.parametrize(
    "extra,sig,group",
    [
        ([], signal.SIGINT, True),
        (["--workers", "2"], signal.SIGINT, True),
        ([], signal.SIGTERM, False),
    ],
    ids=["ctrl-c-local", "ctrl-c-dask-2-workers", "sigterm-local"],
)
def test_interrupt_stops_with_one_line_and_is_resumable(tmp_path, uninterrupted, extra, sig, group):
    """The chunks in flight are abandoned, not finished: some chunks committed, not all (8);
    one line and the signal's exit status; --resume gives the uninterrupted campaign."""
    spec_path = _write_spec(tmp_path)
    out = tmp_path / "out"
    code, err = _interrupt(spec_path, out, extra, sig, group=group)
    # One line: what stopped it, and the command that finishes it (issue 17).
    hint = f"; resume with: rcsim campaign run {spec_path} --out {out}"
    hint += " --workers 2 --resume\n" if extra else " --resume\n"
    committed = len(list((out / "chunks").glob("runs-*.parquet")))
    state = f"exit {code}, {committed} of 8 chunks committed, stderr: {err!r}"
    if sig == signal.SIGTERM:
        assert err == "rcsim: terminated" + hint, state
        assert code == 128 + signal.SIGTERM == 143, state
    else:
        assert err == "rcsim: interrupted" + hint, state
        assert code == 130, state
    assert not (out / "runs.parquet").exists()
    committed = len(list((out / "chunks").glob("runs-*.parquet")))
    assert 1 <= committed < 8
    report = run_campaign(load_spec(spec_path), out, resume=True, local_workers=2, progress=False)
    assert report.resumed_chunks == committed
    pd.testing.assert_frame_equal(
        pd.read_parquet(out / "runs.parquet"), uninterrupted, check_exact=True
    )


def test_resume_and_completion_remove_leftover_temporaries(tmp_path, uninterrupted):
    """Temporaries named as atomic_write names them (a process killed mid-write leaves them)
    in every folder of the campaign are gone after --resume completes it, and after a
    --resume of a complete campaign."""
    spec = load_spec(_write_spec(tmp_path))
    out = tmp_path / "out"
    report = run_campaign(spec, out, local_workers=2, progress=False)
    assert report.runs_flown == 16
    # Make it an interrupted campaign again (status running, no runs.parquet, no chunks).
    import json

    manifest = json.loads((out / "manifest.json").read_text())
    manifest["status"] = "running"
    (out / "manifest.json").write_text(json.dumps(manifest))
    (out / "runs.parquet").unlink()
    (out / "chunks").mkdir()
    planted = [
        out / "histories" / ".run-0000003.parquet.k2j4x9.tmp",
        out / "chunks" / ".runs-0000000-0000001.parquet.a8b1c2.tmp",
        out / ".manifest.json.zz91qq.tmp",
        out / ".runs.parquet.tmp",
    ]
    for path in planted:
        path.write_bytes(b"partial")
        assert path.match(TEMP_GLOB)
    (out / "histories" / "notes.txt").write_text("a user's file is not a temporary")
    run_campaign(spec, out, resume=True, local_workers=2, progress=False)
    assert not [p for p in planted if p.exists()]
    assert (out / "histories" / "notes.txt").exists()
    pd.testing.assert_frame_equal(
        pd.read_parquet(out / "runs.parquet"), uninterrupted, check_exact=True
    )
    late = out / "histories" / ".run-0000004.parquet.q1w2e3.tmp"
    late.write_bytes(b"partial")
    assert run_campaign(spec, out, resume=True, progress=False).runs_flown == 0
    assert not late.exists()


def test_mode_under_umask_and_atomic_write(tmp_path):
    """Oracle: the mode ``open`` gives a new file, 0o666 & ~umask (POSIX)."""
    probe = tmp_path / "probe"
    probe.write_text("")
    assert stat.S_IMODE(probe.stat().st_mode) == mode_under_umask(0o666) == 0o666 & ~UMASK
    written = atomic_write(tmp_path / "a.txt", lambda t: Path(t).write_text("x"))
    assert stat.S_IMODE(written.stat().st_mode) == 0o666 & ~UMASK


@pytest.mark.parametrize("umask", [0o027, 0o002], ids=["umask-027", "umask-002"])
def test_campaign_outputs_honour_the_umask(tmp_path, umask):
    """Every file of a campaign (tables, manifest, histories, plots, marker) has mode
    0o666 & ~umask and every directory 0o777 & ~umask, as ``open`` / ``mkdir`` give."""
    spec_path = _write_spec(tmp_path, histories="first", plots="true")
    out = tmp_path / "out"
    code = (
        "import os, sys; os.umask(int(sys.argv[1], 8)); "
        "from rcsim.analysis.apps.cli import main; sys.exit(main(sys.argv[2:]))"
    )
    subprocess.run(
        [
            sys.executable,
            "-c",
            code,
            oct(umask),
            "campaign",
            "run",
            str(spec_path),
            "--out",
            str(out),
            "--no-progress",
            "--runs-per-case",
            "2",
        ],
        check=True,
        capture_output=True,
    )
    modes = {p.relative_to(out): stat.S_IMODE(p.stat().st_mode) for p in out.rglob("*")}
    modes[Path(".")] = stat.S_IMODE(out.stat().st_mode)
    files = {p for p in modes if (out / p).is_file()}
    assert {"runs.parquet", "cases.csv", "envelopes.parquet", "manifest.json"} <= {
        p.name for p in files
    }
    assert any(p.parts[0] == "plots" for p in files) and any(
        p.parts[0] == "histories" for p in files
    )
    wrong = {
        str(p): oct(m) for p, m in modes.items() if m != (0o666 if p in files else 0o777) & ~umask
    }
    assert not wrong, wrong
