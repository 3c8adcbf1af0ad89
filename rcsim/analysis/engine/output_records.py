"""The record an output directory keeps of what its command wrote there, and ``--overwrite``'s
rule: only what that record lists is ever removed.

An output directory written whole (:func:`rcsim.analysis.engine.output.atomic_dir`) holds a
marker file, :data:`MARKER`.  Its first line says which command wrote it (``written by rcsim
maneuver``); its second line, JSON, lists every file and sub-directory the command wrote there
(paths relative to the directory, ``/``-separated)::

    written by rcsim maneuver
    {"format": "rcsim-outputs/1", "files": ["history.parquet", ...], "dirs": ["plots"]}

The marker is written last, into the hidden temporary directory that is renamed into place in
one step, so the list is complete whenever the directory exists under its name.

A marker is a claim, not proof (a campaign killed before its ``manifest.json``, its
marker edited to name ``maneuver``, was deleted by ``maneuver --overwrite``).  So
``--overwrite`` replaces a directory only when every entry in it is one its record lists
(:func:`unlisted_entry`), and then removes only those entries (:func:`remove_listed`), never a
whole tree.  A marker without a list (an older rcsim's, or damaged) proves nothing: the
directory is refused.
"""

from __future__ import annotations

import json
import os
import secrets
from pathlib import Path

from rcsim.analysis.engine.locks import lock_identity
from rcsim.models.atomic import named_os_error

MARKER = ".rcsim-output"
MARKER_PREFIX = "written by rcsim"
FORMAT = "rcsim-outputs/1"


def marker_text(command: str, files=(), dirs=()) -> str:
    """Content of :data:`MARKER` for a directory written by ``rcsim <command>`` holding
    ``files`` and ``dirs`` (relative paths)."""
    record = {"format": FORMAT, "files": sorted(files), "dirs": sorted(dirs)}
    return f"{MARKER_PREFIX} {command}\n{json.dumps(record)}\n"


def listing(directory: str | os.PathLike) -> tuple[list[str], list[str]]:
    """Every file and sub-directory under ``directory`` (relative, ``/``-separated), the
    marker left out; symbolic links count as files and are not followed."""
    root = Path(directory)
    files, dirs = [], []
    for here, subdirs, names in os.walk(root):
        rel = Path(here).relative_to(root)
        for name in list(subdirs):
            if (Path(here) / name).is_symlink():
                subdirs.remove(name)
                names.append(name)
            else:
                dirs.append((rel / name).as_posix())
        for name in names:
            if rel == Path(".") and name == MARKER:
                continue
            files.append((rel / name).as_posix())
    return files, dirs


def write_record(directory: str | os.PathLike, command: str) -> None:
    """Write the marker of ``rcsim <command>`` listing what ``directory`` holds now (for a
    directory about to be renamed into place: call it last)."""
    files, dirs = listing(directory)
    (Path(directory) / MARKER).write_text(marker_text(command, files, dirs))


def write_marker(directory: str | os.PathLike, command: str) -> None:
    """Write the marker of ``rcsim <command>``, without a list, into a directory written in
    place and never replaced (a campaign's, a loop's): it names the owner for other commands.
    Written beside and renamed over the old one: a kill mid-write never leaves it empty.

    The directory exists now: a writer holding its lock by path locks it by its identity too
    first (:func:`rcsim.analysis.engine.locks.lock_identity`), so that no second writer
    reaches it through a bind mount at another path."""
    lock_identity(directory)
    marker = Path(directory) / MARKER
    tmp = marker.with_name(f"{MARKER}.tmp-{secrets.token_hex(4)}")
    try:
        tmp.write_text(f"{MARKER_PREFIX} {command}\n")
        os.replace(tmp, marker)
    except OSError as exc:  # a full disk: name the marker, not nothing
        raise named_os_error(exc, marker) from exc
    finally:
        tmp.unlink(missing_ok=True)


def read_record(directory: str | os.PathLike) -> dict | None:
    """The list of outputs in ``directory``'s marker (``files``, ``dirs``), or None when the
    marker has none (missing, an older rcsim's, damaged)."""
    try:
        lines = (Path(directory) / MARKER).read_text(errors="replace").splitlines()
    except OSError:
        return None
    if len(lines) < 2:
        return None
    try:
        record = json.loads(lines[1])
    except ValueError:
        return None
    if not (
        isinstance(record, dict)
        and record.get("format") == FORMAT
        and all(
            isinstance(record.get(k), list) and all(isinstance(x, str) for x in record[k])
            for k in ("files", "dirs")
        )
    ):
        return None
    return record


def unlisted_entry(directory: str | os.PathLike) -> str | None:
    """Why ``--overwrite`` may not replace ``directory``, or None when every entry in it is
    one its record lists (missing ones are fine: the user may have removed some)."""
    record = read_record(directory)
    if record is None:
        return (
            "its marker lists no outputs (an older rcsim's, or damaged), so nothing in it is "
            "known to be rcsim's"
        )
    files, dirs = listing(directory)
    listed_files, listed_dirs = set(record["files"]), set(record["dirs"])
    for name in files:
        if name not in listed_files:
            return f"it holds {name}, which its record of outputs does not list"
    for name in dirs:
        if name not in listed_dirs:
            return f"it holds the directory {name}/, which its record of outputs does not list"
    return None


def remove_listed(directory: str | os.PathLike) -> list[str]:
    """Remove what ``directory``'s record lists, then the marker and the directory itself.

    Only listed files and (emptied) listed directories go: anything else stays, with the
    directories holding it.  Returns what was left (relative paths; empty when the directory
    is gone).
    """
    root = Path(directory)
    record = read_record(root) or {"files": [], "dirs": []}
    for name in filter(_inside, record["files"]):
        path = root / name
        if path.is_file() or path.is_symlink():
            path.unlink(missing_ok=True)
    listed_dirs = filter(_inside, record["dirs"])
    for name in sorted(listed_dirs, key=lambda n: n.count("/"), reverse=True):
        try:
            (root / name).rmdir()
        except OSError:
            pass
    try:
        (root / MARKER).unlink(missing_ok=True)
        root.rmdir()
    except OSError:
        files, dirs = listing(root)
        return files + [d + "/" for d in dirs]
    return []


def _inside(name: str) -> bool:
    """A record's entry names a path inside its directory (an edited record could name
    ``../x`` or ``/x``: such an entry is never removed)."""
    parts = name.split("/")
    return bool(name) and not name.startswith("/") and all(p not in ("", ".", "..") for p in parts)
