"""Output paths: nothing a user made is ever lost, and no output is ever half written.

Directories.  Everything goes into a hidden temporary directory beside the target, which
replaces the target only once it is complete (``os.replace`` of a directory is atomic on
POSIX when the target does not exist; an existing target is moved aside first and removed
after).  Each output directory holds a marker file, :data:`MARKER`, whose first line says which
command wrote it: ``written by rcsim <command>`` (e.g. ``written by rcsim maneuver``,
``written by rcsim campaign run``).  An existing directory is replaced only when

* it is empty, or
* its marker names the same command *and* the caller asked for it (``overwrite=True``).

A non-empty directory without a marker (``--out ~``) or written by another command (a
campaign given to ``rcsim maneuver --out``) is never replaced.  Markers of older rcsim
versions (``written by rcsim; ...``) name no command: only ``overwrite=True`` replaces them.

Files (:func:`check_out_file`).  An existing file is replaced only with ``overwrite=True``.

Campaign and loop directories (:data:`RESUMABLE`) are never replaced, by any command and
whatever state their marker is in: they are recognised by their marker *or* by their own state
file (``manifest.json``, ``loop.json``), and no file inside one is replaced by another
command.  Their markers are written atomically.

Locks (:func:`output_lock`).  A command that writes a directory holds an advisory lock on it
(``fcntl.flock`` on a hidden lock file beside it) for as long as it writes; a second writer is
refused with the process that holds it.

Both checks run *before* any work: they also try to create (and remove) a hidden directory in
the nearest existing ancestor of the target, so a read-only filesystem, a permission refusal
or a pseudo-filesystem (``/proc``) is reported before minutes of simulation, whoever runs it.

Errors name the library parameter (``out``), never a command-line flag; the ``rcsim`` CLI
shows them as ``--out`` (:class:`rcsim.models.errors.InputError`).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import secrets
import shutil
import tempfile
from pathlib import Path

from rcsim.models.errors import InputError

MARKER = ".rcsim-output"
_MARKER_PREFIX = "written by rcsim"
#: Commands whose directories are written in place and resumed: never replaced, and
#: recognised by their state file when the marker is missing, empty or unreadable.
RESUMABLE = {"campaign run": "manifest.json", "loop": "loop.json"}


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


def marker_text(command: str) -> str:
    """Content of :data:`MARKER` for a directory written by ``rcsim <command>``."""
    return f"{_MARKER_PREFIX} {command}\n"


def write_marker(directory: str | os.PathLike, command: str) -> None:
    """Write the marker of ``rcsim <command>`` into ``directory`` (for in-place writers).

    ``rcsim campaign run`` writes its directory in place (it is resumable), not through
    :func:`atomic_dir`; it calls this so that other commands recognise the directory.  Written
    beside and renamed over the old one: a kill mid-write never leaves an empty marker.
    """
    marker = Path(directory) / MARKER
    tmp = marker.with_name(f"{MARKER}.tmp-{secrets.token_hex(4)}")
    try:
        tmp.write_text(marker_text(command))
        os.replace(tmp, marker)
    finally:
        tmp.unlink(missing_ok=True)


def resumable_owner(path: str | os.PathLike) -> str | None:
    """The resumable command (:data:`RESUMABLE`) whose directory ``path`` is, or None.

    By the marker first; then, whatever the marker says (missing, empty, damaged), by the
    command's own state file in the directory.
    """
    path = Path(path)
    owner = directory_owner(path)
    if owner in RESUMABLE:
        return owner
    for command, state_file in RESUMABLE.items():
        if (path / state_file).is_file():
            return command
    return None


def directory_owner(path: str | os.PathLike) -> str | None:
    """The command that wrote directory ``path``, from its marker.

    Returns
    -------
    str or None
        ``None`` if there is no marker; ``""`` if the marker names no command (older rcsim,
        or unreadable); else the command, e.g. ``"campaign run"``.
    """
    marker = Path(path) / MARKER
    if not marker.is_file():
        return None
    try:
        first = marker.read_text(errors="replace").splitlines()[:1]
    except OSError:
        return ""
    line = first[0].strip() if first else ""
    if not line.startswith(_MARKER_PREFIX):
        return ""
    rest = line[len(_MARKER_PREFIX) :]
    # Older markers read "written by rcsim; this directory is replaced by the next run".
    return rest.strip() if rest.startswith(" ") else ""


def _as_path(out, parameter: str) -> Path:
    text = os.fspath(out)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not text.strip():
        raise InputError(f"must be a path, got {text!r}", parameter=parameter, value=text)
    if "\0" in text:
        raise InputError(
            f"{text!r}: a path cannot contain a NUL character", parameter=parameter, value=text
        )
    # abspath, not resolve: normalises "a/.." without following a symlink the user named.
    return Path(os.path.abspath(text))


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
    out: str | os.PathLike, command: str | None = None, *, overwrite: bool = False
) -> Path:
    """Validate an output directory before any work.

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
        Accept a directory written earlier by ``command`` (or by an older rcsim).

    Returns
    -------
    Path
        ``out``, absolute.

    Raises
    ------
    InputError
        Naming ``out``; :class:`OutputExists` when only ``overwrite`` is missing.
    """
    path = _as_path(out, "out")
    _refuse_dangling(path, "out")
    if path.exists() and not path.is_dir():
        raise InputError(f"{path}: exists and is not a directory", parameter="out", value=str(path))
    if path.is_dir() and any(path.iterdir()):
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
        if command is None:
            if owner == "campaign run":  # written in place, never by atomic_dir
                raise InputError(
                    f"{path}: is a campaign directory; choose another directory",
                    parameter="out",
                    value=str(path),
                )
        elif owner and owner != command:
            raise InputError(
                f"{path}: holds the outputs of `rcsim {owner}`, which "
                f"`rcsim {command}` does not replace; choose another directory",
                parameter="out",
                value=str(path),
            )
        elif not overwrite:
            what = (
                f"holds the outputs of an earlier `rcsim {command}`"
                if owner
                else "holds the outputs of an earlier rcsim command"
            )
            raise OutputExists(path, command, what)
    _check_creatable(path, "out")
    return path


def _describe(command: str) -> str:
    what = "campaign directory" if command == "campaign run" else "loop directory"
    return f"{what} (written by `rcsim {command}`)"


def check_out_file(
    out: str | os.PathLike,
    *,
    overwrite: bool = False,
    parameter: str = "out",
    writer: str | None = None,
) -> Path:
    """Validate an output file before any work: not a directory, replaced only on request.

    Parameters
    ----------
    out : path
        The file to write; missing parent directories are made when it is written.
    overwrite : bool
        Replace an existing file.
    parameter : str
        The caller's name for ``out``, used in errors.
    writer : str, optional
        The resumable command writing inside its own directory (the loop's refined table);
        any other writer is refused a file that exists inside a campaign or loop directory.

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
    if path.exists() and inside is not None and inside != writer:
        raise InputError(
            f"{path}: is inside a {_describe(inside)}, whose files no other command "
            "replaces; choose a path outside it",
            parameter=parameter,
            value=str(path),
        )
    if path.exists() and not overwrite:
        raise OutputExists(path, "", "exists", parameter)
    _check_creatable(path, parameter)
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


def _make_temp_dir(parent: Path, name: str) -> Path:
    """A new hidden directory in ``parent``, mode 0o777 under the umask (mkdtemp gives 0o700)."""
    while True:
        tmp = parent / f".{name}.tmp-{secrets.token_hex(4)}"
        try:
            tmp.mkdir(mode=0o777)  # the kernel applies the umask, as for any new directory
            return tmp
        except FileExistsError:
            continue


@contextlib.contextmanager
def atomic_dir(out: str | os.PathLike, command: str | None = None, *, overwrite: bool = False):
    """Yield a temporary directory that becomes ``out`` when the block succeeds.

    ``out`` is checked first (:func:`check_out_dir` with ``command`` and ``overwrite``), and
    the marker of ``rcsim <command>`` is written last.  On an exception the temporary
    directory is removed and ``out`` is left as it was.
    """
    out = check_out_dir(out, command, overwrite=overwrite)
    with output_lock(out, command or "output"):
        yield from _write_atomically(out, command)


def _write_atomically(out: Path, command: str | None):
    created = make_parents(out)
    try:
        tmp = _make_temp_dir(out.parent, out.name)
    except BaseException:
        remove_parents(created)
        raise
    try:
        yield tmp
        (tmp / MARKER).write_text(
            marker_text(command)
            if command
            else f"{_MARKER_PREFIX}; this directory is replaced by the next run\n"
        )
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        remove_parents(created)
        raise
    old = None
    if out.exists():
        old = out.with_name(f".{out.name}.old-{secrets.token_hex(4)}")
        os.replace(out, old)
    os.replace(tmp, out)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


class OutputLocked(InputError):
    """Another process is writing the same output; ``holder`` says which."""


def _lock_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.rcsim-lock")


@contextlib.contextmanager
def output_lock(out: str | os.PathLike, command: str, *, parameter: str = "out"):
    """Hold an advisory lock on output ``out`` while the block writes it.

    The lock is ``fcntl.flock`` on a hidden file beside ``out`` (``.NAME.rcsim-lock``, so a
    directory that does not exist yet can be locked), holding the writer's pid and command.  A
    second writer raises :class:`OutputLocked` naming them, before any work.  The file is
    removed when the block ends; a writer that finds the file replaced between opening and
    locking it (the holder just finished) locks the new one.
    """
    path = _as_path(out, parameter)
    lock = _lock_path(path)
    created = make_parents(lock)
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            remove_parents(created)
            raise InputError(
                f"{path}: cannot lock it ({exc.strerror or exc})",
                parameter=parameter,
                value=str(path),
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            holder = ""
            with contextlib.suppress(OSError):
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip()
            os.close(fd)
            remove_parents(created)
            if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise
            raise OutputLocked(
                f"{path}: is being written by another rcsim process ({holder or 'unknown'}); "
                "wait for it to finish or stop it",
                parameter=parameter,
                value=str(path),
            ) from None
        try:
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)  # the previous holder removed the file after we opened it: start again
    ok = False
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()}, rcsim {command}\n".encode(), 0)
        yield path
        ok = True
    finally:
        with contextlib.suppress(OSError):
            os.unlink(lock)
        os.close(fd)
        if not ok:
            remove_parents(created)
