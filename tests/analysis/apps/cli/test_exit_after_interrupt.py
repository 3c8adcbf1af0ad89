"""An interrupted ``rcsim`` always ends: if the interpreter's exit hangs after the one line
(CPython's process-pool exit hook joins a killed pool's manager thread with no timeout), a
daemon timer ends the process with the same status (``rcsim.analysis.apps.cli.run``)."""

import time

import pytest

import rcsim.analysis.apps.cli as cli


@pytest.mark.parametrize("code,armed", [(143, True), (130, True), (0, False), (2, False)])
def test_only_an_interrupted_command_arms_the_exit_timer(monkeypatch, code, armed):
    ended = []
    monkeypatch.setattr(cli, "main", lambda: code)
    monkeypatch.setattr(cli, "EXIT_GRACE_S", 0.01)
    monkeypatch.setattr(cli.os, "_exit", ended.append)  # the timer's call, recorded
    with pytest.raises(SystemExit) as exc:
        cli.run()
    assert exc.value.code == code
    deadline = time.monotonic() + 5.0
    while armed and not ended and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.05)  # an unarmed run must stay silent past the (patched) grace period
    assert ended == ([code] if armed else [])
