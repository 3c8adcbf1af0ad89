"""Writing output directories so that a failure never leaves half-written files.

Everything goes into a hidden temporary directory beside the target, which replaces the target
only once it is complete (``os.replace`` of a directory is atomic on POSIX when the target does
not exist; an existing target is moved aside first and removed after).  Each output directory
holds a marker file; an existing non-empty directory without it was not written by rcsim and is
never replaced (``--out ~`` must not wipe a home directory).
"""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path

from rcsim.models.errors import InputError

MARKER = ".rcsim-output"


def check_out_dir(out: str | os.PathLike) -> Path:
    """Validate an ``--out`` directory before any work.

    Missing parent directories are fine (they are made when the output is written), but the
    nearest existing ancestor must be a writable directory.
    """
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise InputError(f"--out {path}: exists and is not a directory")
    if path.is_dir() and any(path.iterdir()) and not (path / MARKER).exists():
        raise InputError(
            f"--out {path}: exists and holds files rcsim did not write; choose another directory"
        )
    ancestor = path.absolute().parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(f"--out {path}: {ancestor} is not a directory")
    if not os.access(ancestor, os.W_OK):
        raise InputError(f"--out {path}: {ancestor} is not writable")
    return path


@contextlib.contextmanager
def atomic_dir(out: str | os.PathLike):
    """Yield a temporary directory that becomes ``out`` when the block succeeds.

    On an exception the temporary directory is removed and ``out`` is left as it was.
    """
    out = check_out_dir(out)
    out.absolute().parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.absolute().parent))
    try:
        yield tmp
        (tmp / MARKER).write_text("written by rcsim; this directory is replaced by the next run\n")
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
