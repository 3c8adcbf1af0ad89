"""Vehicle-file sanity warnings where a user meets them: ``rcsim vehicle check`` lists them,
a command that flies the vehicle prints them to stderr before its work (issue 31 item 7; the
warnings' figures are tested in tests/spacecraft/vehicle/test_sanity.py)."""

from __future__ import annotations

import re

from rcsim.analysis.apps.cli import main
from rcsim.spacecraft.vehicle import resolve_vehicle

EXAMPLES = resolve_vehicle("paper").parents[3] / "docs" / "examples"


def test_vehicle_check_lists_the_warnings_and_a_command_prints_them(capsys, tmp_path):
    smallsat = str(EXAMPLES / "smallsat8.toml")
    assert main(["vehicle", "check", smallsat, "--no-pairs"]) == 0
    out = capsys.readouterr().out
    assert "Warnings (physically odd but legal values):" in out
    assert main(["vehicle", "check", "paper", "--no-pairs"]) == 0
    assert "Warnings: none" in capsys.readouterr().out
    argv = ["maneuver", "--vehicle", smallsat, "--controller", "allocator"]
    argv += ["--attitude-deg", "0", "0", "1", "--duration-s", "2", "--out", str(tmp_path / "m")]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert re.search(r"rcsim: warning: .*smallsat8.toml: min_on_s = 20 ms", err)
