"""Writing output directories so that a failure never leaves half-written files.

Everything goes into a hidden temporary directory beside the target, which replaces the target
only once it is complete (``os.replace`` of a directory is atomic on POSIX when the target does
not exist; an existing target is moved aside first and removed after).
"""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from models.errors import InputError


def check_out_dir(out: str | os.PathLike) -> Path:
    """Validate an ``--out`` directory before any work: parent must exist and be writable."""
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise InputError(f"--out {path}: exists and is not a directory")
    parent = path.absolute().parent
    if not parent.is_dir():
        raise InputError(f"--out {path}: parent directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"--out {path}: parent directory {parent} is not writable")
    return path


@contextlib.contextmanager
def atomic_dir(out: str | os.PathLike):
    """Yield a temporary directory that becomes ``out`` when the block succeeds.

    On an exception the temporary directory is removed and ``out`` is left as it was.
    """
    out = check_out_dir(out)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.absolute().parent))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = None
    if out.exists():
        old = out.with_name(f".{out.name}.old-{os.getpid()}")
        os.replace(out, old)
    os.replace(tmp, out)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
