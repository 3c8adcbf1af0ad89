"""Output paths: nothing a user made is ever lost, and no output is ever half written.

Directories.  Everything goes into a hidden temporary directory beside the target, which
replaces the target only once it is complete (``os.replace`` of a directory is atomic on
POSIX when the target does not exist; an existing target is moved aside first, and then only
what its record lists is removed from it).  Each output directory holds a marker file,
:data:`MARKER`, whose first line says which command wrote it (``written by rcsim maneuver``)
and whose second lists every file and folder the command wrote there
(:mod:`rcsim.analysis.engine.output_records`).  An existing directory is replaced only when

* it is empty, or
* its marker names the same command, the caller asked for it (``overwrite=True``) *and*
  everything in it is listed in its record: a directory holding anything else -- a file the
  user added, a marker without a list (an older rcsim's), a campaign's files under a marker
  that names another command -- is refused with the entry that stops it.

A non-empty directory without a marker (``--out ~``) or written by another command (a
campaign given to ``rcsim maneuver --out``) is never replaced.

Files (:func:`check_out_file`).  An existing file is replaced only with ``overwrite=True``.

Campaign and loop directories (:data:`RESUMABLE`) are never replaced, by any command and
whatever state their marker is in: they are recognised by their marker *or* by their own state
file (``manifest.json``, ``loop.json``).  Their markers are written atomically.

Places (:mod:`rcsim.analysis.engine.output_places`).  No output goes inside another command's
output directory, and none is, or holds, one of the command's own inputs; ``overwrite`` does
not lift either.

Locks (:mod:`rcsim.analysis.engine.locks`).  A command that writes an output holds an advisory
lock on its real path (symbolic links resolved) for as long as it writes -- under the command
line, from the check before the work to the end; a second writer is refused with the process
that holds it.

The checks run *before* any work: they also try to create (and remove) a hidden directory in
the nearest existing ancestor of the target, so a read-only filesystem, a permission refusal
or a pseudo-filesystem (``/proc``) is reported before minutes of simulation, whoever runs it.

Errors name the library parameter (``out``), never a command-line flag; the ``rcsim`` CLI
shows them as ``--out`` (:class:`rcsim.models.errors.InputError`).
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import sys
import tempfile
from pathlib import Path

from rcsim.analysis.engine.locks import OutputLocked, claim, holds_lock, output_lock
from rcsim.analysis.engine.locks import as_out_path as _as_path
from rcsim.analysis.engine.output_places import (
    RESUMABLE,
    refuse_nested,
    refuse_own_inputs,
    resumable_owner,
)
from rcsim.analysis.engine.output_places import marker_owner as directory_owner
from rcsim.analysis.engine.output_records import (
    MARKER,
    marker_text,
    remove_listed,
    unlisted_entry,
    write_marker,
    write_record,
)
from rcsim.analysis.engine.write_errors import watching, written_file_error
from rcsim.models.errors import InputError

__all__ = [
    "MARKER",
    "RESUMABLE",
    "OutputExists",
    "OutputLocked",
    "atomic_dir",
    "check_out_dir",
    "check_out_file",
    "directory_owner",
    "make_parents",
    "marker_text",
    "output_lock",
    "remove_parents",
    "resumable_owner",
    "write_marker",
]


class OutputExists(InputError):
    """``out`` holds outputs of the same command; only ``overwrite=True`` replaces them.

    Attributes
    ----------
    path : Path
        The existing directory or file.
    command : str
        The command that would replace it (``""`` for a file).
    what : str
        What is there, e.g. "holds the outputs of an earlier `rcsim maneuver`".
    """

    def __init__(self, path: Path, command: str, what: str, parameter: str = "out"):
        self.path = path
        self.command = command
        self.what = what
        super().__init__(
            f"{path}: {what}; pass overwrite=True to replace it, or choose another path",
            parameter=parameter,
            value=str(path),
        )


def _refuse_dangling(path: Path, parameter: str) -> None:
    """A symlink to nothing: writing through it would fail after the work, or replace it."""
    if path.is_symlink() and not path.exists():
        raise InputError(
            f"{path}: is a symbolic link to {os.readlink(path)}, which does not exist; "
            "name the target itself, or remove the link",
            parameter=parameter,
            value=str(path),
        )


def _check_creatable(path: Path, parameter: str) -> None:
    """Refuse ``path`` unless entries can be created in its nearest existing ancestor."""
    ancestor = path.parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(
            f"{path}: {ancestor} is not a directory", parameter=parameter, value=str(path)
        )
    # A real attempt, not os.access: root passes os.access everywhere, and a read-only
    # filesystem or /proc answers only to an attempt.
    try:
        probe = tempfile.mkdtemp(prefix=".rcsim-probe-", dir=ancestor)
    except OSError as exc:
        raise InputError(
            f"{path}: cannot create it in {ancestor} ({exc.strerror or exc})",
            parameter=parameter,
            value=str(path),
        ) from None
    os.rmdir(probe)


def check_out_dir(
    out: str | os.PathLike,
    command: str | None = None,
    *,
    overwrite: bool = False,
    inputs: dict | None = None,
) -> Path:
    """Validate an output directory before any work, and claim it.

    Parameters
    ----------
    out : path
        The directory to write.  Missing parents are fine (they are made when the output is
        written), but entries must be creatable in the nearest existing ancestor.
    command : str, optional
        The command that will write it (``"maneuver"``, ``"scenario run"``...).  Without it
        (callers that predate markers naming commands), any directory with a marker except a
        campaign's is accepted.
    overwrite : bool
        Accept a directory written earlier by ``command`` -- when its record lists everything
        in it (:mod:`rcsim.analysis.engine.output_records`).
    inputs : dict, optional
        The command's inputs, ``{what: path}``: ``out`` may not be one, nor hold one
        (:func:`rcsim.analysis.engine.output_places.refuse_own_inputs`).

    Returns
    -------
    Path
        ``out``, absolute.

    Raises
    ------
    InputError
        Naming ``out``; :class:`OutputExists` when only ``overwrite`` is missing.

    Inside the command line's claim scope the directory is locked from here until the command
    ends (:func:`rcsim.analysis.engine.locks.claim`).
    """
    path = _as_path(out, "out")
    _refuse_dangling(path, "out")
    if path.exists() and not path.is_dir():
        raise InputError(f"{path}: exists and is not a directory", parameter="out", value=str(path))
    refuse_nested(path, command)
    refuse_own_inputs([path], inputs or {})
    if path.is_dir() and any(path.iterdir()):
        _check_replaceable(path, command, overwrite)
    _check_creatable(path, "out")
    claim(path, command or "output")
    return path


def _check_replaceable(path: Path, command: str | None, overwrite: bool) -> None:
    """Refuse a non-empty directory ``command`` may not replace (module docstring)."""
    owner = directory_owner(path)
    resumable = resumable_owner(path)
    if resumable is not None and resumable != command:
        raise InputError(
            f"{path}: is a {_describe(resumable)}, "
            "which no other command replaces; choose another directory",
            parameter="out",
            value=str(path),
        )
    if resumable is not None:
        owner = resumable
    if owner is None:
        raise InputError(
            f"{path}: exists and holds files rcsim did not write; choose another directory",
            parameter="out",
            value=str(path),
        )
    if command is not None and owner and owner != command:
        raise InputError(
            f"{path}: holds the outputs of `rcsim {owner}`, which "
            f"`rcsim {command}` does not replace; choose another directory",
            parameter="out",
            value=str(path),
        )
    if command in RESUMABLE and overwrite:
        return  # written in place, never replaced: it refuses what it cannot resume itself
    if not overwrite:
        what = (
            f"holds the outputs of an earlier `rcsim {owner}`"
            if owner
            else "holds the outputs of an earlier rcsim command"
        )
        raise OutputExists(path, command or "", what)
    why = unlisted_entry(path)
    if why is not None:
        raise InputError(
            f"{path}: is not replaced: {why}; --overwrite removes only what rcsim recorded "
            "writing there -- move the rest away, or choose another directory",
            parameter="out",
            value=str(path),
        )


def _describe(command: str) -> str:
    what = "campaign directory" if command == "campaign run" else "loop directory"
    return f"{what} (written by `rcsim {command}`)"


def check_out_file(
    out: str | os.PathLike,
    *,
    overwrite: bool = False,
    parameter: str = "out",
    writer: str | None = None,
    inputs: dict | None = None,
) -> Path:
    """Validate an output file before any work, and claim it: not a directory, not inside
    another command's output directory, not one of ``inputs``, replaced only on request.

    Parameters
    ----------
    out : path
        The file to write; missing parent directories are made when it is written.
    overwrite : bool
        Replace an existing file.
    parameter : str
        The caller's name for ``out``, used in errors.
    writer : str, optional
        The resumable command writing inside its own directory (the loop's refined table).
    inputs : dict, optional
        ``{what: path}``: the command's inputs, which ``out`` may not be.

    Returns
    -------
    Path
        ``out``, absolute.
    """
    path = _as_path(out, parameter)
    _refuse_dangling(path, parameter)
    if path.is_dir():
        raise InputError(f"{path}: is a directory", parameter=parameter, value=str(path))
    inside = resumable_owner(path.parent) if path.parent.is_dir() else None
    if not (writer is not None and inside == writer):
        refuse_nested(path, None, parameter=parameter)
    refuse_own_inputs([path], inputs or {}, parameter=parameter)
    if path.exists() and not overwrite:
        raise OutputExists(path, "", "exists", parameter)
    _check_creatable(path, parameter)
    claim(path, writer or "output", parameter=parameter)
    return path


def make_parents(path: Path) -> list[Path]:
    """Create the missing parent directories of ``path``; return them, outermost first."""
    missing = []
    parent = path.parent
    while not parent.exists():
        missing.append(parent)
        parent = parent.parent
    missing.reverse()
    made = []
    try:
        for directory in missing:
            directory.mkdir(exist_ok=True)
            made.append(directory)
    except BaseException:
        remove_parents(made)
        raise
    return made


def remove_parents(created: list[Path]) -> None:
    """Undo :func:`make_parents` after a failure (only directories still empty)."""
    for directory in reversed(created):
        try:
            directory.rmdir()
        except OSError:
            break


def _staging_name(name: str) -> re.Pattern:
    return re.compile(rf"\.{re.escape(name)}\.tmp-[0-9a-f]{{{2 * _STAGING_BYTES}}}")


def remove_stale_staging(out: Path) -> list[Path]:
    """Remove the staging folders of ``out`` (:func:`_make_temp_dir`'s, beside it) that
    writers killed before their rename left behind (``kill -9`` of ``maneuver --overwrite``).

    Only under ``out``'s lock, which every writer of ``out`` holds while its staging folder
    exists: a folder of that name is then a dead writer's.  Only rcsim's own kind: a real
    directory (no link) of exactly that name, owned by this user.

    Returns
    -------
    list of Path
        The folders removed.
    """
    import shutil

    if not holds_lock(out):
        return []  # no proof that their writer is dead
    pattern = _staging_name(out.name)
    removed: list[Path] = []
    try:
        entries = list(os.scandir(out.parent))
    except OSError:
        return removed
    for entry in entries:
        if not pattern.fullmatch(entry.name):
            continue
        try:
            if (
                not entry.is_dir(follow_symlinks=False)
                or entry.stat(follow_symlinks=False).st_uid != os.geteuid()
            ):
                continue
        except OSError:
            continue
        shutil.rmtree(entry.path, ignore_errors=True)
        removed.append(Path(entry.path))
    return removed


#: Random bytes in a staging folder's name (``.NAME.tmp-<hex>``).
_STAGING_BYTES = 4


def _make_temp_dir(parent: Path, name: str) -> Path:
    """A new hidden directory in ``parent``, mode 0o777 under the umask (mkdtemp gives 0o700)."""
    while True:
        tmp = parent / f".{name}.tmp-{secrets.token_hex(_STAGING_BYTES)}"
        try:
            tmp.mkdir(mode=0o777)  # the kernel applies the umask, as for any new directory
            return tmp
        except FileExistsError:
            continue


@contextlib.contextmanager
def atomic_dir(out: str | os.PathLike, command: str | None = None, *, overwrite: bool = False):
    """Yield a temporary directory that becomes ``out`` when the block succeeds.

    ``out`` is checked first (:func:`check_out_dir` with ``command`` and ``overwrite``), and
    the marker of ``rcsim <command>``, listing everything the block wrote, is written last.
    On an exception the temporary directory is removed and ``out`` is left as it was.  An
    earlier ``out`` being replaced loses only what its own record lists.
    """
    out = check_out_dir(out, command, overwrite=overwrite)
    with output_lock(out, command or "output"):
        yield from _write_atomically(out, command, overwrite)


def _write_atomically(out: Path, command: str | None, overwrite: bool):
    created = make_parents(out)
    remove_stale_staging(out)
    try:
        tmp = _make_temp_dir(out.parent, out.name)
    except BaseException:
        remove_parents(created)
        raise
    try:
        # A full disk names the file it stopped (a plotting or Parquet library names none).
        with watching(tmp):
            try:
                yield tmp
                write_record(tmp, command or "")
            except OSError as exc:
                raise written_file_error(exc, tmp, out) from exc
        if out.exists() and any(out.iterdir()):
            # Checked again under the lock, just before: what got in since is not removed.
            _check_replaceable(out, command, overwrite)
    except BaseException:
        _remove_tree(tmp)
        remove_parents(created)
        raise
    old = None
    if out.exists():
        old = out.with_name(f".{out.name}.old-{secrets.token_hex(4)}")
        os.replace(out, old)
    os.replace(tmp, out)
    if old is not None:
        left = remove_listed(old)
        if left:  # never expected (checked above, under the lock), but never deleted either
            kept = out.with_name(f"{out.name}.kept-{secrets.token_hex(4)}")
            os.replace(old, kept)
            print(
                f"rcsim: warning: {kept} keeps what the earlier {out} held beyond its record "
                f"of outputs: {', '.join(left[:5])}",
                file=sys.stderr,
            )


def _remove_tree(tmp: Path) -> None:
    """Remove a temporary directory this process made (and alone wrote)."""
    import shutil

    shutil.rmtree(tmp, ignore_errors=True)
