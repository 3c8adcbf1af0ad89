"""An interrupted ``rcsim`` always ends: if the interpreter's exit hangs after the one line
(CPython's process-pool exit hook joins a killed pool's manager thread with no timeout), a
daemon timer ends the process with the same status (``rcsim.analysis.apps.cli.run``)."""

import time

import pytest

import rcsim.analysis.apps.cli as cli


@pytest.mark.parametrize("code,armed", [(143, True), (130, True), (0, False), (2, False)])
def test_only_an_interrupted_command_arms_the_exit_timer(monkeypatch, code, armed):
    ended, silenced = [], []
    monkeypatch.setattr(cli, "main", lambda: code)
    monkeypatch.setattr(cli, "EXIT_GRACE_S", 0.01)
    monkeypatch.setattr(cli.os, "_exit", ended.append)  # the timer's call, recorded
    # After the one line an interrupted command's stderr goes to /dev/null (recorded here:
    # this process's descriptor 2 is pytest's).
    monkeypatch.setattr(cli, "_silence_stderr", lambda: silenced.append(True))
    with pytest.raises(SystemExit) as exc:
        cli.run()
    assert exc.value.code == code
    assert silenced == ([True] if armed else [])
    deadline = time.monotonic() + 5.0
    while armed and not ended and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.05)  # an unarmed run must stay silent past the (patched) grace period
    assert ended == ([code] if armed else [])


# Long enough (minutes on two cores) that the last signal, 4 s after the lock, always finds it
# flying: at 400 runs a loaded machine's campaign once finished first and exited 0.
SPEC = """
seed = 1
runs_per_case = 8000
[scenario]
kind = "maneuver"
attitude_deg = [0.0, 0.0, 5.0]
duration_s = 20.0
[controller]
name = "phase-plane"
[output]
histories = "none"
plots = false
"""


@pytest.mark.slow
@pytest.mark.parametrize("after_lock_s", [0.3, 1.0, 2.0, 4.0])
def test_sigterm_to_a_dask_campaign_prints_one_line(tmp_path, after_lock_s):
    """``campaign run --workers 2`` under SIGTERM printed 29 to 50 lines after its one (the
    exit hook's traceback of a nanny interrupted while it started, asyncio's "Task exception
    was never retrieved", workers' closed streams) and once took 11 s to exit (the exit hook
    closing that cluster again, for 10 s).  Sent while the cluster starts and while it flies
    (seconds after the output's lock appears): one line, exit 143."""
    import signal
    import subprocess
    import sys

    (tmp_path / "spec.toml").write_text(SPEC)
    proc = subprocess.Popen(
        [sys.executable, "-m", "rcsim", "campaign", "run", "spec.toml", "--out", "S",
         "--workers", "2"],
        cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    lock = tmp_path / ".S.rcsim-lock"
    deadline = time.monotonic() + 120
    while not lock.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(after_lock_s)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert err.splitlines() == [
        "rcsim: terminated; resume with: rcsim campaign run spec.toml --out S --workers 2 --resume"
    ], err
