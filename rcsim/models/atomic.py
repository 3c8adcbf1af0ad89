"""Atomic file writes, shared by every layer that writes results or tables.

A file is written beside its destination under a hidden temporary name
(``.<name>.<random>.tmp``, :data:`TEMP_GLOB`) and renamed over it (``os.replace`` is atomic on
POSIX), so a reader -- or a campaign resumed after a kill -- never sees a partial file.  A
process killed mid-write (SIGKILL) leaves its temporary behind; whoever owns the directory
removes such leftovers with :func:`remove_temporaries`.

Permissions: ``tempfile.mkstemp`` creates its file with mode 0600 whatever the umask, so the
final file gets :func:`mode_under_umask` ``(0o666)`` -- what ``open(path, "w")`` would give --
like every other file the user's tools write.
"""

from __future__ import annotations

import errno
import os
import re
import tempfile
from collections.abc import Callable
from pathlib import Path

#: Glob of the temporaries :func:`atomic_write` creates (and of nothing else rcsim writes).
TEMP_GLOB = ".*.tmp"


def _read_umask() -> int:
    """The process umask, read without changing it when the system allows.

    ``os.umask`` can only be read by setting it, which races with other threads creating
    files; Linux reports it in ``/proc/self/status`` ("Umask:", since 4.7).  Elsewhere the
    set-and-restore happens once, here, at import, before any campaign thread exists.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


#: The umask at import (an rcsim process does not change its umask afterwards).
UMASK = _read_umask()


def mode_under_umask(mode: int = 0o666) -> int:
    """``mode`` with the process umask applied: the permissions the system gives a new file
    (``0o666``) or directory (``0o777``) created by ``open`` / ``mkdir``.

    For files and directories made by ``mkstemp`` / ``mkdtemp`` (always 0600 / 0700), which
    should look like any other output once they are in place.
    """
    return mode & ~UMASK


def atomic_write(path: str | os.PathLike, write: Callable[[str], object]) -> Path:
    """Call ``write(tmp_path)``, then rename ``tmp_path`` over ``path``.

    On any exception the temporary file is removed and ``path`` is left as it was; an
    ``OSError`` of the write names ``path`` (:func:`named_os_error`).  The final file has mode
    ``0o666`` under the umask (:func:`mode_under_umask`).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    target = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        try:
            write(tmp)
        except OSError as exc:  # a full disk: name the file asked for, not the temporary
            raise named_os_error(exc, target) from exc
        os.chmod(tmp, mode_under_umask(0o666))
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return target


#: Errors a write meets that are about where it writes, not about an input: a full disk or
#: quota, a file too large, a filesystem gone read-only or failing.
WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EIO})


def os_errno(exc: OSError) -> int | None:
    """``exc``'s errno, also when a library put it only in its message: pyarrow raises
    ``OSError("Error writing bytes to file. Detail: [errno 28] No space left on device")``."""
    if exc.errno is not None:
        return exc.errno
    found = _WRAPPED_ERRNO.search(str(exc))
    return int(found.group(1)) if found else None


_WRAPPED_ERRNO = re.compile(r"\[errno (\d+)\]", re.IGNORECASE)


def named_os_error(exc: OSError, path: str | os.PathLike) -> OSError:
    """``exc`` naming ``path`` -- the file the user asked for -- instead of no file or a hidden
    temporary, with the same errno (a full disk still reads "No space left on device", also
    when a library wrapped it in its own words)."""
    number = os_errno(exc)
    reason = exc.strerror or str(exc) or type(exc).__name__
    if number is not None and _WRAPPED_ERRNO.search(reason):
        reason = os.strerror(number)  # the system's words, not the library's around them
    if number is not None:
        return OSError(number, reason, str(path))
    error = OSError(reason)
    error.strerror, error.filename = reason, str(path)
    return error


def remove_temporaries(directory: str | os.PathLike) -> list[Path]:
    """Remove the leftover :func:`atomic_write` temporaries (:data:`TEMP_GLOB`) in ``directory``.

    Only for a directory whose writer is the caller (no write of its own in progress): a
    temporary there belongs to a writer that was killed.  Not recursive.

    Returns
    -------
    list of pathlib.Path
        The files removed.
    """
    folder = Path(directory)
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for tmp in folder.glob(TEMP_GLOB):
        if tmp.is_file() and not tmp.is_symlink():
            try:
                tmp.unlink()
            except FileNotFoundError:  # removed meanwhile: the goal is reached
                continue
            removed.append(tmp)
    return removed
