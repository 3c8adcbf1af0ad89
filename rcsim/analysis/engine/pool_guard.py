"""Worker processes die with the process that started them, and die quietly.

Why: after a ``kill -9`` of ``rcsim campaign run`` or ``rcsim lookup refine``, the fork
server, its workers (~400 MB) and the resource tracker lived on -- once for 17 minutes,
holding the caller's stdout open -- and a SIGTERM while the pool started printed a 15-line
worker traceback after the one line.

* :func:`die_with_parent` asks Linux to SIGKILL the calling process when its parent dies
  (``prctl(PR_SET_PDEATHSIG)``; elsewhere nothing).  A chain: the fork server dies with rcsim,
  each worker with the fork server (:func:`rcsim.analysis.engine.campaign.local.worker_pool`);
  the resource tracker ends by itself once every process holding its pipe is gone.  A parent
  that died before the request took effect is caught by comparing ``os.getppid()`` with the
  parent's pid, passed in :data:`PARENT_ENV`.  (A local Dask cluster's workers already ended
  with rcsim: none outlived a ``kill -9``.)
* Imported as the fork server's first preload module, this module arms the fork server
  (:data:`PARENT_ENV` names the rcsim process that starts it) and installs
  :func:`_quiet_orphan_hook`: a worker the fork server forked for a pool that was torn down
  while the worker started (its semaphores already gone: ``FileNotFoundError`` in
  ``SemLock._rebuild``; its pipe closed: ``EOFError``) ends silently instead of printing a
  traceback under the interrupted command's one line.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

#: Environment variable naming the pid a new pool process must die with.
PARENT_ENV = "RCSIM_POOL_PARENT_PID"
_PR_SET_PDEATHSIG = 1
#: What a pool process meets when its pool was torn down while it started.
_ORPHAN_ERRORS = (FileNotFoundError, EOFError, BrokenPipeError, ConnectionResetError)


def die_with_parent(parent_pid: int | None = None) -> bool:
    """SIGKILL this process when its parent dies (Linux); exit at once if the parent is
    already gone (``os.getppid()`` no longer ``parent_pid``).

    Returns whether the request was made (False off Linux, or without a C library).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    if parent_pid is not None and os.getppid() != parent_pid:
        os._exit(1)  # the parent died before the request: nothing to work for
    return True


def parent_from_env() -> int | None:
    """The pid in :data:`PARENT_ENV`, or None."""
    try:
        return int(os.environ[PARENT_ENV])
    except (KeyError, ValueError):
        return None


def worker_started() -> None:
    """In a pool worker: die with the process that forked it (the fork server, whose pid the
    fork server left in :data:`PARENT_ENV`, or rcsim itself)."""
    die_with_parent(parent_from_env())


def _quiet_orphan_hook(kind, value, tb) -> None:
    """``sys.excepthook`` of the fork server and its children (module docstring)."""
    if isinstance(value, _ORPHAN_ERRORS):
        return
    sys.__excepthook__(kind, value, tb)


def _arm_fork_server() -> None:
    """Run on import in the fork server (rcsim put :data:`PARENT_ENV` in its environment)."""
    parent = parent_from_env()
    if parent is None or "multiprocessing.forkserver" not in sys.modules:
        return
    die_with_parent(parent)
    os.environ[PARENT_ENV] = str(os.getpid())  # the workers' parent is this fork server
    sys.excepthook = _quiet_orphan_hook


_arm_fork_server()
