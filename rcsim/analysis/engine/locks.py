"""One writer per output: an advisory lock per *real* output path, held from before the work.

A command that writes an output holds ``fcntl.flock`` on a hidden file beside it
(``.NAME.rcsim-lock``, so that a directory that does not exist yet can be locked), holding the
writer's pid and command; a second writer is refused with that holder, before any work.

The lock file is named after the path with every symbolic link resolved
(``os.path.realpath``): ``--out LINK`` and ``--out TARGET`` are one output and take one lock
(through a symlink a second ``campaign run --resume`` flew beside the first).  A
bind mount of an ancestor changes nothing (the lock file beside the output is one file, seen
at two paths), but a path cannot tell that a directory *itself* is mounted at a second path:
an output directory is therefore also locked by its identity (device and inode), ``flock`` on
the directory itself -- from the start when it exists, else from when its writer makes it and
writes its marker (:func:`lock_identity`) -- and a second writer reaching it by any path is
refused.

Re-entrant within a thread: a command that claimed its output before the work (below) and
then writes it through :func:`rcsim.analysis.engine.output.atomic_dir`, which locks again, holds
one lock, released when the outermost holder ends; another thread is refused as another
process is.

Claims.  The ``rcsim`` command line opens a :func:`claim_scope` around each command; inside it,
every output checked by :mod:`rcsim.analysis.engine.output` (``check_out_dir`` /
``check_out_file``) is also locked at once (:func:`claim`) and stays locked until the command
ends -- so every writing command holds its lock from before its first flight, whatever the
library function that writes last.  Outside a scope (a library caller) :func:`claim` does
nothing and the writers lock while they write, as before.

Errors name the library parameter (``out``); the CLI shows the flag.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import fcntl
import os
import threading
from pathlib import Path

from rcsim.models.errors import InputError


class OutputLocked(InputError):
    """Another process is writing the same output; ``holder`` says which."""


#: Locks this process holds: lock file (real path) -> [descriptor, depth, thread ident,
#: descriptor of the output directory locked by identity (-1: none yet)].
_held: dict[str, list[int]] = {}


class ClaimScope:
    """The command line's claims: the locks taken (an ExitStack) and the command's name,
    recorded in each lock file (``rcsim lookup refine``) when the writer names none."""

    def __init__(self, stack: contextlib.ExitStack):
        self.stack = stack
        self.command = ""
        #: The outputs claimed, in order: what a write error without a file was writing.
        self.outputs: list[Path] = []


_scope: contextvars.ContextVar[ClaimScope | None] = contextvars.ContextVar(
    "rcsim_claim_scope", default=None
)


def as_out_path(out, parameter: str = "out") -> Path:
    """``out`` as an absolute path, refused (naming ``parameter``) when it cannot be one."""
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


def real_path(path: str | os.PathLike) -> Path:
    """``path`` absolute with every symbolic link in it resolved (also for a path whose tail
    does not exist yet: the part that exists is resolved, the rest kept)."""
    return Path(os.path.realpath(os.path.abspath(os.fspath(path))))


def lock_file(path: str | os.PathLike) -> Path:
    """The lock file of output ``path``: beside its real path, ``.NAME.rcsim-lock``."""
    real = real_path(path)
    return real.with_name(f".{real.name}.rcsim-lock")


def _make_parents(path: Path) -> list[Path]:
    missing = []
    parent = path.parent
    while not parent.exists():
        missing.append(parent)
        parent = parent.parent
    made = []
    try:
        for directory in reversed(missing):
            directory.mkdir(exist_ok=True)
            made.append(directory)
    except BaseException:
        _remove_empty(made)
        raise
    return made


def _remove_empty(created: list[Path]) -> None:
    for directory in reversed(created):
        try:
            directory.rmdir()
        except OSError:
            break


def _acquire(lock: Path, path: Path, command: str, parameter: str) -> int:
    """Open and flock ``lock``; the descriptor, or :class:`OutputLocked` naming the holder."""
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
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
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()}, rcsim {command}\n".encode(), 0)
    except OSError as exc:
        # A full disk at the start: the holder's line does not fit.  Refused now, naming the
        # output (a disk's error, not a flag's), and no lock file is left behind.
        _release(lock, fd, -1)
        raise OSError(exc.errno, f"cannot lock it ({exc.strerror or exc})", str(path)) from None
    return fd


def _identity_holder(info: os.stat_result) -> str:
    """Who holds an flock on the file of ``info`` (device, inode), from ``/proc/locks``: the
    holder's lock file is beside its own path, which this process does not know."""
    wanted = f"{os.major(info.st_dev):02x}:{os.minor(info.st_dev):02x}:{info.st_ino}"
    try:
        with open("/proc/locks") as fh:
            lines = fh.read().splitlines()
    except OSError:
        return ""
    for line in lines:
        fields = line.split()
        if "FLOCK" in fields and wanted in fields:
            pid = fields[fields.index(wanted) - 1]
            try:
                with open(f"/proc/{pid}/cmdline", "rb") as fh:
                    argv = fh.read().split(b"\0")
            except OSError:
                return f"pid {pid}"
            words = [a.decode(errors="replace") for a in argv if a]
            if words and os.path.basename(words[0]).startswith("python"):
                words = words[1:]  # the interpreter: the program it runs says more
            if not words:
                return f"pid {pid}"
            # As the holder's own lock file says it: "pid 12, rcsim campaign run".
            return f"pid {pid}, {' '.join([os.path.basename(words[0]), *words[1:3]])}"
    return ""


def _lock_identity(path: Path, parameter: str) -> int:
    """flock directory ``path`` itself; its descriptor, -1 when it is no directory (yet), or
    :class:`OutputLocked` when another process holds it (through another path)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return -1  # not there (yet), or no directory: its path lock alone guards it
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        holder = _identity_holder(os.fstat(fd))
        os.close(fd)
        if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
            raise
        raise OutputLocked(
            f"{path}: is being written by another rcsim process ({holder or 'unknown'}) "
            "through another path to the same directory (a bind mount); wait for it to finish "
            "or stop it",
            parameter=parameter,
            value=str(path),
        ) from None
    return fd


def lock_identity(out: str | os.PathLike, *, parameter: str = "out") -> None:
    """Lock output directory ``out``, whose path lock this thread holds, by its identity too
    (module docstring): called once its writer has made it.  Nothing when this thread does not
    hold ``out``, or holds its identity already; :class:`OutputLocked` when another process
    reached it first through another path."""
    held = _held.get(str(lock_file(out)))
    if held is None or held[2] != threading.get_ident() or held[3] != -1:
        return
    held[3] = _lock_identity(real_path(out), parameter)


@contextlib.contextmanager
def output_lock(out: str | os.PathLike, command: str, *, parameter: str = "out"):
    """Hold the lock of output ``out`` while the block writes it (module docstring).

    Yields ``out`` absolute (as named, links not resolved).  The lock file is removed when the
    outermost holder in this process ends; missing parent directories made for it are removed
    again if the block fails.
    """
    path = as_out_path(out, parameter)
    lock = lock_file(path)
    key = str(lock)
    if key in _held and _held[key][2] != threading.get_ident():
        raise OutputLocked(
            f"{path}: is being written by another thread of this process; wait for it",
            parameter=parameter,
            value=str(path),
        )
    if key in _held:
        _held[key][1] += 1
        try:
            yield path
        finally:
            _held[key][1] -= 1
        return
    created = _make_parents(lock)
    try:
        fd = _acquire(lock, path, command, parameter)
    except BaseException:
        _remove_empty(created)
        raise
    try:
        # Beside the lock by path, the lock by identity: the directory may be mounted at a
        # second path, whose lock file is another.
        identity = _lock_identity(real_path(path), parameter)
    except BaseException:
        _release(lock, fd, -1)
        _remove_empty(created)
        raise
    _held[key] = [fd, 1, threading.get_ident(), identity]
    ok = False
    try:
        yield path
        ok = True
    finally:
        held = _held.pop(key, None)
        _release(lock, fd, held[3] if held is not None else identity)
        if not ok:
            _remove_empty(created)


def _release(lock: Path, fd: int, identity: int) -> None:
    """Remove the lock file (while still holding it: a waiting writer then opens a new one),
    then close the descriptors."""
    with contextlib.suppress(OSError):
        os.unlink(lock)
    os.close(fd)
    if identity != -1:
        os.close(identity)


def holds_lock(out: str | os.PathLike) -> bool:
    """Whether this thread holds the lock of output ``out``."""
    held = _held.get(str(lock_file(out)))
    return held is not None and held[2] == threading.get_ident()


@contextlib.contextmanager
def claim_scope():
    """Outputs claimed (:func:`claim`) inside the block stay locked until it ends; yields the
    :class:`ClaimScope` (set its ``command`` once the command is known)."""
    with contextlib.ExitStack() as stack:
        scope = ClaimScope(stack)
        token = _scope.set(scope)
        try:
            yield scope
        finally:
            # The stack unwinds with the block's exception, if any: a command that failed
            # leaves no lock file and no parent directory made for one.
            _scope.reset(token)


def claim(out: str | os.PathLike, command: str, *, parameter: str = "out") -> None:
    """Lock output ``out`` until the enclosing :func:`claim_scope` ends (nothing outside one,
    or when this process holds it already)."""
    scope = _scope.get()
    if scope is None or holds_lock(out):
        return
    if command in ("", "output") and scope.command:
        command = scope.command
    scope.stack.enter_context(output_lock(out, command, parameter=parameter))
    scope.outputs.append(as_out_path(out, parameter))
