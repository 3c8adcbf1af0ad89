"""Atomic file writes, shared by every layer that writes results or tables.

A file is written beside its destination under a hidden temporary name and renamed over it
(``os.replace`` is atomic on POSIX), so a reader -- or a campaign resumed after a kill -- never
sees a partial file.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Callable


def atomic_write(path: str | os.PathLike, write: Callable[[str], None]) -> Path:
    """Call ``write(tmp_path)``, then rename ``tmp_path`` over ``path``.

    On any exception the temporary file is removed and ``path`` is left as it was.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    target = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return target
