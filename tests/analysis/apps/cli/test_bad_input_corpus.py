"""The bad-input corpus: malformed and careless inputs to every ``rcsim`` command.

Oracle: the contract of the CLI (README "Bad input ..."; issue 8): for any user mistake,
``rcsim`` exits with code 2, prints exactly one line on stderr, ``rcsim: error: ...``, that
names the file or flag, the field and the value; shows no traceback; leaves no output (not
even a hidden temporary) and touches nothing that existed before.  A few ``ok`` cases pin
inputs that must keep working (a table or spec saved with a UTF-8 BOM).

The cases are data, one TOML file per command group in ``tests/analysis/apps/cli/corpus/`` (format
in
its README.md), so later issues extend the corpus without touching this module.  Most run
in-process through :func:`rcsim.analysis.apps.cli.main` (fast); cases marked ``run =
"subprocess"`` run the installed ``rcsim`` executable, proving the entry point behaves the same.
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from rcsim.analysis.apps.cli import main

CORPUS = Path(__file__).with_name("corpus")
FILES = CORPUS / "files"
KEYS = {
    "id",
    "argv",
    "expect",
    "files",
    "copy",
    "dirs",
    "readonly",
    "setup",
    "run",
    "ok",
    "creates",
    "why",
}
# The issue asks for at least 60 malformed inputs across every command.
MIN_REFUSALS = 60
COMMANDS = {"maneuver", "lookup", "scenario", "campaign", "study"}


#: A flag repeated (``--cases --cases:``) or a key path's head repeated (``control.control.``).
_DOUBLED = re.compile(r"(?<![\w-])(--[a-z][\w-]*)[ :]+\1(?![\w-])|(?<![\w.])([a-z_]+)\.\2\.")


def _load_cases() -> list[dict]:
    cases = []
    for path in sorted(CORPUS.glob("*.toml")):
        with path.open("rb") as fh:
            for case in tomllib.load(fh).get("case", []):
                unknown = set(case) - KEYS
                assert not unknown, f"{path.name}: case {case.get('id')}: unknown keys {unknown}"
                cases.append({**case, "source": path.name})
    return cases


CASES = _load_cases()


def test_corpus_is_well_formed_and_large_enough():
    ids = [c["id"] for c in CASES]
    assert len(ids) == len(set(ids)), "duplicate case ids"
    refusals = [c for c in CASES if not c.get("ok")]
    assert len(refusals) >= MIN_REFUSALS
    # Every refusal says what the message must name; every command group is exercised.
    assert all(c.get("expect") for c in refusals)
    assert COMMANDS <= {c["argv"][0] for c in CASES if c["argv"]}
    assert any(c.get("run") == "subprocess" for c in CASES)


@pytest.fixture(scope="session")
def finished_campaign(tmp_path_factory) -> Path:
    """A small real campaign (2 runs), made once and copied into the cases that need one."""
    root = tmp_path_factory.mktemp("campaign")
    spec = root / "tiny.toml"
    shutil.copy(FILES / "tiny_campaign.toml", spec)
    assert main(["campaign", "run", str(spec), "--out", str(root / "runs")]) == 0
    return root / "runs"


def _snapshot(root: Path) -> dict:
    """Every entry under ``root``: type, permission bits and (for files) content."""
    snap = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            path = Path(dirpath, name)
            info = path.lstat()
            rel = str(path.relative_to(root))
            if stat.S_ISDIR(info.st_mode):
                snap[rel] = ("dir", stat.S_IMODE(info.st_mode))
            else:
                snap[rel] = ("file", stat.S_IMODE(info.st_mode), path.read_bytes())
    return snap


def _prepare(case: dict, base: Path, campaign: Path | None) -> dict[str, str]:
    base.mkdir()
    subs = {"tmp": str(base), "out": str(base / "out"), "runs": str(base / "runs")}
    if case.get("setup") == "campaign":
        shutil.copytree(campaign, base / "runs")
    elif case.get("setup") is not None:
        raise AssertionError(f"unknown setup {case['setup']!r}")
    for rel in case.get("dirs", []):
        (base / rel).mkdir(parents=True)
    for rel, text in case.get("files", {}).items():
        (base / rel).parent.mkdir(parents=True, exist_ok=True)
        (base / rel).write_text(text.format(**subs), encoding="utf-8")
    for rel, name in case.get("copy", {}).items():
        (base / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(FILES / name, base / rel)
    for rel in case.get("readonly", []):
        (base / rel).chmod(0o555)
    return subs


def _rcsim_executable() -> str:
    exe = Path(sys.executable).with_name("rcsim")
    return str(exe) if exe.exists() else (shutil.which("rcsim") or "rcsim")


@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_bad_input(case, tmp_path, capsys, monkeypatch, request):
    if case.get("readonly") and os.geteuid() == 0:
        pytest.skip("root writes into read-only directories; the case needs an ordinary user")
    campaign = request.getfixturevalue("finished_campaign") if case.get("setup") else None
    base = tmp_path / "case"
    subs = _prepare(case, base, campaign)
    argv = [arg.format(**subs) for arg in case["argv"]]
    before = _snapshot(base)
    try:
        if case.get("run") == "subprocess":
            proc = subprocess.run(
                [_rcsim_executable(), *argv], cwd=base, capture_output=True, text=True, timeout=300
            )
            rc, err = proc.returncode, proc.stderr
        else:
            monkeypatch.chdir(base)  # relative paths resolve here; stray files are caught
            rc = main(argv)
            err = capsys.readouterr().err
    finally:
        for rel in case.get("readonly", []):
            (base / rel).chmod(0o755)  # let pytest clean up
    after = _snapshot(base)

    if case.get("ok"):
        assert rc == 0, err
        for rel in case.get("creates", []):
            assert (base / rel).exists(), rel
        changed = {k for k, v in before.items() if after.get(k) != v}
        assert not changed, f"touched what existed before: {sorted(changed)}"
        return
    assert "Traceback" not in err, err
    # A vehicle file's sanity warnings (rcsim/spacecraft/vehicle/sanity.py) may precede
    # the error: odd values are said even when something else is refused.
    lines = [line for line in err.strip().splitlines() if not line.startswith("rcsim: warning: ")]
    assert len(lines) == 1, f"expected one error line on stderr, got:\n{err}"
    assert lines[0].startswith("rcsim: error: "), err
    assert rc == 2, err
    # The flag or key is named once: a message that names its flag itself, rendered under the
    # flag again, read "--repeats --repeats must be at least 1"; a key path prefixed twice,
    # "control.control.cycle_s".
    doubled = _DOUBLED.search(lines[0])
    assert doubled is None, f"{doubled.group(0)!r} named twice in the error line: {lines[0]}"
    for text in case["expect"]:
        assert text.format(**subs).lower() in lines[0].lower(), (
            f"{text!r} not in the error line: {lines[0]}"
        )
    assert after == before, (
        "left output or touched inputs: "
        f"new {sorted(set(after) - set(before))}, "
        f"changed {sorted(k for k in before if after.get(k) != before[k])}"
    )
