"""``rcsim ... | head``: a reader that closes stdout ends the command quietly (issue 18 review:
``rcsim campaign run ... | head -8`` ended with "rcsim: error: Broken pipe").

Oracle: the shell convention for a process ended by SIGPIPE, status 128 + 13 = 141, and
nothing on stderr, as ``yes | head`` and other command-line tools; a broken pipe of anything
other than stdout stays an error.  The executable runs as a user runs it (a subprocess) with
stdout a pipe whose read end is closed before it starts, so every write fails (no race).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path


def rcsim_executable() -> str:
    exe = Path(sys.executable).with_name("rcsim")
    return str(exe) if exe.exists() else (shutil.which("rcsim") or "rcsim")


def _with_closed_stdout(argv: list[str]) -> subprocess.CompletedProcess:
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run(
            [rcsim_executable(), *argv], stdout=write, stderr=subprocess.PIPE, text=True,
            timeout=120,
        )  # fmt: skip
    finally:
        os.close(write)


def test_closed_stdout_ends_quietly_with_141():
    for argv in (["campaign", "example"], ["lookup", "compare"]):
        proc = _with_closed_stdout(argv)
        assert proc.returncode == 141, (argv, proc.stderr)
        assert proc.stderr == "", (argv, proc.stderr)


def test_an_error_is_still_reported_with_stdout_closed():
    proc = _with_closed_stdout(["lookup", "compare", "--table", "nosuch.csv"])
    assert proc.returncode == 2
    assert proc.stderr.startswith("rcsim: error:") and "nosuch.csv" in proc.stderr
