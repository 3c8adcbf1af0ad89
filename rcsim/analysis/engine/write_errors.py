"""Which file a failed write was writing: a full disk names the file, not nothing.

An output directory is written inside a hidden temporary directory
(:func:`rcsim.analysis.engine.output.atomic_dir`) by libraries that report a full disk without
a file name: Pillow (matplotlib's PNGs) raises a bare ``OSError(28)`` and removes the file it
had started, pyarrow (``to_parquet``) an ``OSError`` whose file is only in its message, if at
all.  :func:`watching` follows the files opened for writing inside the temporary directory
while the block writes, and :func:`written_file_error` names the one a write error belongs to:

* Python-level opens (``open``, ``os.open``: Pillow, pandas' CSV, ``Path.write_text``) are seen
  through the interpreter's ``open`` audit event (:func:`sys.addaudithook`): the last one opened
  for writing is the one being written;
* a file made by native code (pyarrow opens its files in C++, unaudited) is one that appeared
  in the directory after that last audited open: when there is one, the newest of them is.

The hook is installed once per process and returns at once unless a block is being watched.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from pathlib import Path

from rcsim.models.atomic import WRITE_ERRNOS, named_os_error, os_errno

#: Watched temporary directories (absolute, ending in a separator) -> [the last file opened
#: for writing in it, or None; the files in it at that open].
_watched: dict[str, list] = {}
_install = threading.Lock()
_installed = False


def _files_under(top: str) -> set[str]:
    found: set[str] = set()
    for dirpath, _, filenames in os.walk(top):
        found.update(os.path.join(dirpath, name) for name in filenames)
    return found


def _opened_for_writing(mode, flags) -> bool:
    if isinstance(mode, str):
        return any(c in mode for c in "wax+")
    return isinstance(flags, int) and bool(flags & (os.O_WRONLY | os.O_RDWR))


def _audit(event: str, args: tuple) -> None:
    if event != "open" or not _watched:
        return
    try:  # never in the way of the open itself
        path, mode, flags = args
        if isinstance(path, int) or not _opened_for_writing(mode, flags):
            return
        absolute = os.path.abspath(os.fsdecode(path))
        for prefix, slot in list(_watched.items()):
            if absolute.startswith(prefix):
                slot[0] = absolute
                slot[1] = _files_under(prefix)
    except Exception:
        pass


@contextlib.contextmanager
def watching(tmp: Path):
    """Follow the files opened for writing under ``tmp`` while the block runs."""
    global _installed
    with _install:
        if not _installed:
            sys.addaudithook(_audit)
            _installed = True
    prefix = os.path.join(os.path.abspath(tmp), "")
    _watched[prefix] = [None, set()]
    try:
        yield
    finally:
        _watched.pop(prefix, None)


def _being_written(tmp: Path) -> Path | None:
    """The file under ``tmp`` whose write failed (module docstring), or None."""
    prefix = os.path.join(os.path.abspath(tmp), "")
    last, known = _watched.get(prefix, [None, set()])
    appeared = _files_under(prefix) - known - {last}
    if appeared:

        def mtime(path: str) -> int:
            try:
                return os.stat(path).st_mtime_ns
            except OSError:
                return -1

        return Path(max(sorted(appeared), key=mtime))
    return Path(last) if last is not None else None


def written_file_error(exc: OSError, tmp: Path, out: Path) -> OSError:
    """``exc``, raised while writing temporary directory ``tmp`` (inside :func:`watching`), naming
    the file of ``out`` it was writing (``out/rates_jets.png: No space left on device``) instead
    of the hidden temporary or nothing.  An error about a file elsewhere (an input), or without
    a file and not about the place written (:data:`rcsim.models.atomic.WRITE_ERRNOS`), is left
    as it is; a write error whose file cannot be told names ``out``."""
    tmp = Path(os.path.abspath(tmp))
    if exc.filename is not None:
        try:
            rel = Path(os.path.abspath(os.fsdecode(exc.filename))).relative_to(tmp)
        except ValueError:
            return exc  # about another file: an input
        return named_os_error(exc, out / rel)
    if os_errno(exc) not in WRITE_ERRNOS:
        return exc
    failed = _being_written(tmp)
    return named_os_error(exc, out if failed is None else out / failed.relative_to(tmp))
