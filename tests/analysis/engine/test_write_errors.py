"""A write error inside an output directory names the file it was writing.

Oracle: issue 38, section 4: on a full disk ``maneuver``, ``lookup refine``, ``analyze`` and
``loop`` printed only "No space left on device": matplotlib (through Pillow) raises a bare
``OSError(28)`` and removes the PNG it had started, pyarrow puts the errno in its own message
("Error writing bytes to file. Detail: [errno 28] ...") and opens its file in native code.
The claim: the error names the file of the output being written, with the system's words for
the errno, for both kinds of writer; an error about another file (an input) is left alone.  A
full disk is simulated by writers that do what those libraries do (the real one, on a small
tmpfs, is in tests/analysis/apps/cli/test_full_disk.py).
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest

from rcsim.analysis.engine.output import atomic_dir
from rcsim.models.atomic import named_os_error

ENOSPC = os.strerror(errno.ENOSPC)
#: What pyarrow raises on a full disk.
PYARROW_ENOSPC = OSError(errno.ENOSPC, "Error writing bytes to file. Detail: [errno 28] " + ENOSPC)


def _like_pillow(path: Path) -> None:
    """Open for writing (seen by the interpreter), fail, remove the partial file, raise a
    bare ENOSPC: Pillow's ``Image.save`` on a full disk."""
    with open(path, "wb") as fh:
        fh.write(b"\x89PNG half")
    path.unlink()
    raise OSError(errno.ENOSPC, ENOSPC)


def _like_pyarrow(path: Path, scratch: Path) -> None:
    """Create the file without an ``open`` the interpreter sees (native code: here a rename
    in), leave it partial, raise pyarrow's wrapped errno."""
    part = scratch / "part"
    part.write_bytes(b"PAR1 half")
    os.replace(part, path)
    raise PYARROW_ENOSPC


@pytest.mark.parametrize("failing", ["first", "second"])
@pytest.mark.parametrize("writer", ["pillow", "pyarrow"])
def test_the_file_being_written_is_named(tmp_path, writer, failing):
    out, scratch = tmp_path / "out", tmp_path / "scratch"
    scratch.mkdir()
    names = ["a.png", "b.png"] if writer == "pillow" else ["a.parquet", "b.parquet"]
    failed = names[0] if failing == "first" else names[1]
    with pytest.raises(OSError) as err:
        with atomic_dir(out, "maneuver") as tmp:
            (tmp / "summary.json").write_text("{}")  # a file written whole before
            for name in names:
                if name != failed:
                    (tmp / name).write_bytes(b"whole")
                    continue
                if writer == "pillow":
                    _like_pillow(tmp / name)
                else:
                    _like_pyarrow(tmp / name, scratch)
    assert err.value.errno == errno.ENOSPC
    assert err.value.filename == str(out / failed)
    assert err.value.strerror == ENOSPC  # the system's words, not pyarrow's around them
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scratch"]  # nothing left


def test_a_file_in_a_sub_folder_and_a_named_temporary(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(OSError) as err:
        with atomic_dir(out, "analyze") as tmp:
            (tmp / "figures").mkdir()
            _like_pillow(tmp / "figures" / "fig1.png")
    assert err.value.filename == str(out / "figures" / "fig1.png")
    with pytest.raises(OSError) as err:
        with atomic_dir(out, "analyze") as tmp:
            raise OSError(errno.ENOSPC, ENOSPC, str(tmp / "drivers.csv"))
    assert err.value.filename == str(out / "drivers.csv")  # not the hidden temporary


def test_an_error_about_an_input_is_left_alone(tmp_path):
    missing = tmp_path / "runs.parquet"
    with pytest.raises(FileNotFoundError) as err:
        with atomic_dir(tmp_path / "out", "analyze"):
            missing.read_bytes()
    assert err.value.filename == str(missing)
    with pytest.raises(OSError) as err:  # no file, and not about where it writes
        with atomic_dir(tmp_path / "out", "analyze"):
            raise ConnectionRefusedError(errno.ECONNREFUSED, "refused")
    assert err.value.filename is None


def test_named_os_error_reads_an_errno_a_library_put_in_its_message():
    for exc in (PYARROW_ENOSPC, OSError("Error writing bytes. Detail: [errno 28] no space")):
        named = named_os_error(exc, "/x/h.parquet")
        assert (named.errno, named.strerror, named.filename) == (
            errno.ENOSPC,
            ENOSPC,
            "/x/h.parquet",
        )


def test_a_lock_that_cannot_be_written_is_refused_and_leaves_no_lock_file(tmp_path, monkeypatch):
    """A disk full at the start: the lock file was made (an empty file fits) but its holder's
    line did not, and the hidden lock file stayed behind."""
    from rcsim.analysis.engine import locks

    def full(fd, data, offset):
        raise OSError(errno.ENOSPC, ENOSPC)

    monkeypatch.setattr(locks.os, "pwrite", full)
    with pytest.raises(OSError) as err:
        with locks.output_lock(tmp_path / "sub" / "t.csv", "lookup generate"):
            pass
    assert err.value.errno == errno.ENOSPC and err.value.filename == str(tmp_path / "sub/t.csv")
    assert err.value.strerror == f"cannot lock it ({ENOSPC})"
    assert list(tmp_path.iterdir()) == []  # no lock file, no parent made for it


def test_the_command_line_names_its_outputs_when_nothing_else_can():
    """Last resort: a write error that names no file, met outside any output directory's
    temporary, names the outputs the command claimed; other errors are left as they are."""
    from rcsim.analysis.apps.cli import _name_outputs, error_line

    outputs = [Path("/d/t.csv"), Path("/d/t_settling.csv")]
    named = _name_outputs(PYARROW_ENOSPC, outputs)
    assert error_line(named) == f"writing /d/t.csv, /d/t_settling.csv: {ENOSPC}"
    refused = ConnectionRefusedError(errno.ECONNREFUSED, "refused")
    assert _name_outputs(refused, outputs) is refused
    assert _name_outputs(OSError(errno.ENOSPC, ENOSPC), []).filename is None
