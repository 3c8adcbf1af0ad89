"""On a really full disk every command names the file it could not write, and leaves no lock.

Oracle: issue 38, section 4: on a full disk ``maneuver``, three ``lookup generate`` variants,
``lookup refine``, ``analyze`` and ``loop`` printed only "No space left on device", and a disk
full at the start left a stale hidden lock file (``mount -t tmpfs -o size=4k tmpfs /mnt/x;
rcsim lookup generate --out /mnt/x/t.csv``).  The claim: one error line naming a path on the
full disk with the system's reason, exit 2, and no ``.rcsim-lock`` file left.  The disk is a
small tmpfs mounted for the test (root only: skipped, with the reason, where mounting is
refused); the sizes put the end of the space at the lock, the first file and a later file of
each command (tmpfs counts whole 4 KiB pages).  The simulated full disk of each kind of
writer is tests/analysis/engine/test_write_errors.py.
"""

from __future__ import annotations

import errno
import os
import subprocess
from pathlib import Path

import pytest

from rcsim.analysis.apps.cli import main

ENOSPC = os.strerror(errno.ENOSPC)
CORPUS_FILES = Path(__file__).with_name("corpus") / "files"


@pytest.fixture
def small_disk(tmp_path):
    """``mount(size)``: a fresh tmpfs of ``size`` (e.g. ``"4k"``) at a new directory."""
    mounted: list[Path] = []

    def mount(size: str) -> Path:
        where = tmp_path / f"disk{len(mounted)}"
        where.mkdir()
        try:
            done = subprocess.run(
                ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                capture_output=True,
                text=True,
            )
        except FileNotFoundError:
            pytest.skip("no mount command")
        if done.returncode != 0:
            pytest.skip(f"mounting a tmpfs refused: {done.stderr.strip()}")
        mounted.append(where)
        return where

    yield mount
    for where in mounted:
        # Lazily when still busy (a descriptor left open on it by a failing command): the
        # mount never outlives the test.
        if subprocess.run(["umount", str(where)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(where)], check=True)


def _refused_naming_a_file(argv, disk: Path, capsys) -> str:
    rc = main(argv)
    err = capsys.readouterr().err
    lines = [line for line in err.strip().splitlines() if not line.startswith("rcsim: warning")]
    assert rc == 2 and len(lines) == 1 and "Traceback" not in err, err
    line = lines[0]
    assert line.startswith("rcsim: error: ") and ENOSPC in line, line
    # The path named is on the full disk: a file, the output or its lock; never nothing.
    assert f"{disk}/" in line.partition(ENOSPC)[0], line
    assert not list(disk.rglob("*.rcsim-lock")), sorted(disk.rglob("*"))
    return line


@pytest.mark.parametrize(
    "flags, size",
    [
        ([], "4k"),
        (["--jets-off", "13"], "4k"),
        (["--vehicle", "canted16"], "4k"),
        (["--vehicle", "canted16"], "8k"),
        ([], "8k"),
    ],
)
def test_lookup_generate(small_disk, capsys, flags, size):
    disk = small_disk(size)
    _refused_naming_a_file(["lookup", "generate", *flags, "--out", f"{disk}/t.csv"], disk, capsys)
    assert list(disk.iterdir()) == []  # no part of the table, no temporary


@pytest.mark.parametrize("size", ["4k", "32k", "64k", "96k"])
def test_maneuver(small_disk, capsys, size):
    disk = small_disk(size)
    argv = ["maneuver", "--attitude-deg", "0", "0", "5", "--duration-s", "2", "--out"]
    line = _refused_naming_a_file([*argv, f"{disk}/m"], disk, capsys)
    assert f"{disk}/m/" in line  # a file of the output, not the directory
    assert list(disk.iterdir()) == []


@pytest.fixture(scope="module")
def tiny_campaign(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("campaign")
    # The corpus's smallest campaign, with the 10 runs the driver analysis needs at least.
    spec = (CORPUS_FILES / "tiny_campaign.toml").read_text()
    (root / "tiny.toml").write_text(spec.replace("runs_per_case = 2", "runs_per_case = 12"))
    assert main(["campaign", "run", str(root / "tiny.toml"), "--out", str(root / "runs")]) == 0
    return root / "runs"


@pytest.mark.parametrize("size", ["4k", "16k"])
def test_analyze(small_disk, capsys, tiny_campaign, size):
    disk = small_disk(size)
    capsys.readouterr()
    line = _refused_naming_a_file(
        ["analyze", str(tiny_campaign), "--out", f"{disk}/d"], disk, capsys
    )
    assert f"{disk}/d/" in line
    assert list(disk.iterdir()) == []


def test_lookup_refine(small_disk, capsys):
    disk = small_disk("4k")
    argv = ["lookup", "refine", "--table", "table6", "--runs", "20", "--cases", "3"]
    _refused_naming_a_file([*argv, "--out", f"{disk}/r.csv"], disk, capsys)
    assert list(disk.iterdir()) == []


@pytest.mark.parametrize("size", ["4k", "8k"])
def test_loop(small_disk, capsys, size):
    disk = small_disk(size)
    argv = ["loop", "--runs-per-case", "2", "--search-runs-per-case", "2", "--no-plots"]
    line = _refused_naming_a_file([*argv, "--out", f"{disk}/L"], disk, capsys)
    assert f"{disk}/L/" in line  # its marker or its state file
