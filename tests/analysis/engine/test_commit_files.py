"""Outputs whose parts belong together are committed together, and a full disk names the file.

Oracle: issue 31, "What to build" 4: on a full disk ``lookup generate`` left a table without
its ``_settling.csv`` (with ``--jets-off`` a table that cannot load) and ``lookup database`` a
``db.parquet`` without its plot; "No space left on device" named no file.  The claim: none of
the parts is left (nor a hidden temporary), what existed before is unchanged, and the one
error line names the file being written.  A full disk is simulated by a writer that writes
part of its file and then raises ``OSError(ENOSPC)``, as the system's ``write`` does.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.commit import commit_files
from rcsim.models.atomic import atomic_write
from rcsim.spacecraft.vehicle import Vehicle

ENOSPC = os.strerror(errno.ENOSPC)


def _disk_full_after_some_bytes(tmp: str) -> None:
    Path(tmp).write_text("half a file")
    raise OSError(errno.ENOSPC, ENOSPC)  # no file name: what a full disk's write() says


def _files(root: Path) -> dict:
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def test_commit_is_all_or_nothing_and_names_the_file(tmp_path):
    (tmp_path / "b.csv").write_text("old b")
    before = _files(tmp_path)
    with pytest.raises(OSError) as err:
        commit_files(
            [
                (tmp_path / "a.csv", lambda tmp: Path(tmp).write_text("new a")),
                (tmp_path / "b.csv", _disk_full_after_some_bytes),
                (tmp_path / "c.csv", lambda tmp: Path(tmp).write_text("new c")),
            ]
        )
    assert err.value.errno == errno.ENOSPC and err.value.filename == str(tmp_path / "b.csv")
    assert _files(tmp_path) == before  # a.csv not renamed in, b.csv untouched, no temporary
    written = commit_files([(tmp_path / "a.csv", lambda tmp: Path(tmp).write_text("new a"))])
    assert written == [tmp_path / "a.csv"] and (tmp_path / "a.csv").read_text() == "new a"


def test_a_single_atomic_write_names_its_file_too(tmp_path):
    with pytest.raises(OSError) as err:
        atomic_write(tmp_path / "runs.parquet", _disk_full_after_some_bytes)
    assert err.value.filename == str(tmp_path / "runs.parquet")
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def generated_jets_off_13():
    """``lookup generate --jets-off 13``'s table, generated once (26 flights)."""
    from rcsim.lookup.generation import generate_table

    return generate_table(Vehicle.load(), jets_off=(13,))


@pytest.mark.parametrize("full_at", ["settling", "table"])
def test_lookup_generate_on_a_full_disk_leaves_no_part(
    tmp_path, capsys, monkeypatch, generated_jets_off_13, full_at
):
    import pandas as pd

    import rcsim.analysis.engine.table_files as table_files
    from rcsim.models.tables import LookupTable

    monkeypatch.setattr(
        table_files.generation,
        "generate_table",
        lambda vehicle, jets_off=(), **_: generated_jets_off_13,
    )
    out = tmp_path / "T.csv"
    if full_at == "table":
        monkeypatch.setattr(
            LookupTable, "to_csv", lambda self, tmp, **kw: _disk_full_after_some_bytes(tmp)
        )
    else:
        monkeypatch.setattr(
            pd.DataFrame, "to_csv", lambda self, tmp, **kw: _disk_full_after_some_bytes(tmp)
        )
    rc = main(["lookup", "generate", "--jets-off", "13", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "Traceback" not in err
    named = out if full_at == "table" else tmp_path / "T_settling.csv"
    assert err.strip() == f"rcsim: error: {named}: {ENOSPC}"
    assert list(tmp_path.iterdir()) == []  # neither part, no temporary, no lock file


def test_lookup_database_on_a_full_disk_keeps_the_earlier_database_whole(
    tmp_path, capsys, monkeypatch
):
    import rcsim.analysis.engine.response_files as response_files

    argv = ["lookup", "database", "--vehicle", "paper", "--vehicles", "2"]
    out = tmp_path / "db.parquet"
    assert main([*argv, "--out", str(out)]) == 0
    capsys.readouterr()
    before = _files(tmp_path)
    assert sorted(before) == ["db.parquet", "db.png", "db_summary.csv"]
    monkeypatch.setattr(
        response_files, "_to_parquet", lambda frame, tmp, meta: _disk_full_after_some_bytes(tmp)
    )
    rc = main([*argv, "--seed", "2", "--out", str(out), "--overwrite"])
    err = capsys.readouterr().err
    assert rc == 2 and err.strip() == f"rcsim: error: {out}: {ENOSPC}"
    assert _files(tmp_path) == before  # the new plot and summary were not committed either
