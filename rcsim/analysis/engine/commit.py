"""Files that belong together are written together: all of them, or none.

Why: on a full disk ``lookup generate`` left a table without its ``_settling.csv`` (with
``--jets-off`` a table that cannot even load) and ``lookup database`` a ``db.parquet``
without its plot, and "No space left on device" named no file.

:func:`commit_files` writes every part to a hidden temporary beside its destination first
(:data:`rcsim.models.atomic.TEMP_GLOB`); only when all are written does it rename them into
place, in the order given (the part that makes the set usable last: a table after its
companion).  A write that fails -- a full disk above all -- removes every temporary and leaves
every destination as it was, and the error names the destination it was writing
(``T_settling.csv: No space left on device``), not the hidden temporary.  Renames need no
space; only a kill between two of them (microseconds) can leave a mix of old and new parts.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

from rcsim.models.atomic import mode_under_umask, named_os_error


def commit_files(parts: Sequence[tuple[str | os.PathLike, Callable[[str], object]]]) -> list[Path]:
    """Write each ``(path, write)`` part -- ``write(tmp)`` fills a temporary -- then rename them
    all into place, in order; all or nothing (module docstring).

    Returns
    -------
    list of pathlib.Path
        The destinations, in order.

    Raises
    ------
    OSError
        The first write that failed, naming its destination; nothing is left behind.
    """
    temporaries: list[tuple[str, Path]] = []
    try:
        for path, write in parts:
            target = Path(path)
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
            os.close(fd)
            temporaries.append((tmp, target))
            try:
                write(tmp)
            except OSError as exc:
                raise named_os_error(exc, target) from exc
            os.chmod(tmp, mode_under_umask(0o666))
    except BaseException:
        for tmp, _ in temporaries:
            try:
                os.unlink(tmp)
            except FileNotFoundError:
                pass
        raise
    for tmp, target in temporaries:
        os.replace(tmp, target)
    return [target for _, target in temporaries]
