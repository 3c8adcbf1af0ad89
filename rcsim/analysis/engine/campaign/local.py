"""Local execution of a campaign's chunks: in this process, or one worker process per CPU.

Why processes.  A chunk alternates between MuJoCo's batched rollout (native, GIL released)
and the control cycle's numpy work (navigation, controller, valves, the cut at switch
instants), which holds the interpreter.  Two chunks on two threads of one process take turns
at the interpreter, so the second core idles during the other chunk's Python work; two
processes do not share an interpreter (``docs/performance.md`` has the measurements).  Each
chunk is a pure function of the spec and its run ids, so results are the same in any process,
bit for bit, whatever the worker count or the order chunks finish in.

Workers are started by a fork server with the chunk machinery preloaded (no per-worker import
cost, and no fork of a process that runs MuJoCo threads), ignore SIGINT (a terminal's Ctrl-C
reaches the whole process group; it is this process that stops them) and are killed, not
waited for, when the campaign is interrupted: a chunk abandoned mid-flight is redone on
``--resume`` (chunks commit in this process only).  The fork server dies with this process
and each worker with the fork server, also after a ``kill -9``
(:mod:`rcsim.analysis.engine.pool_guard`).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
from collections.abc import Generator, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from itertools import islice
from pathlib import Path
from typing import TYPE_CHECKING

from rcsim.analysis.engine import pool_guard
from rcsim.analysis.engine.campaign.chunk import (
    Chunk,
    ChunkResult,
    crashed_chunk,
    simulate_chunk,
    warm_up,
)
from rcsim.lookup.c_library import LIBRARY_PREFIX

if TYPE_CHECKING:
    from rcsim.analysis.engine.campaign.spec import CampaignSpec

#: Modules the fork server imports once, so that every worker starts with them loaded; the
#: first arms the fork server to die with this process (rcsim.analysis.engine.pool_guard).
_PRELOAD = ["rcsim.analysis.engine.pool_guard", "rcsim.analysis.engine.campaign.chunk"]


def _worker_init() -> None:
    """Run in each worker: die with the fork server (which dies with this process), leave
    Ctrl-C to the parent, load what chunks need."""
    pool_guard.worker_started()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    warm_up()


def worker_pool(workers: int) -> ProcessPoolExecutor:
    """A pool of ``workers`` chunk processes (see the module docstring)."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(_PRELOAD)
    _start_fork_server()
    return ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_worker_init)


def _start_fork_server() -> None:
    """Start the fork server (once per process) importing rcsim from this process's tree.

    The fork server imports :data:`_PRELOAD` before it takes this process's ``sys.path``
    (CPython 3.11's ``multiprocessing.forkserver.main`` receives it and never applies it), so
    a tree put on the path at run time -- a notebook's ``sys.path.insert``, a script run from
    one checkout beside another installed -- would be this process's code while the workers
    fly the installed one, and the manifest's code version would not be what flew.  The tree
    this process imported rcsim from goes first on ``PYTHONPATH``, which the fork server's
    interpreter reads when it starts, and only for that start -- unless that tree is an
    installed one (a site-packages folder), which the fork server finds anyway and which put
    before the standard library could shadow it with a stray backport.

    The fork server, and through it every worker, dies with this process
    (:mod:`rcsim.analysis.engine.pool_guard`): a ``kill -9`` of rcsim leaves no pool behind.
    """
    import site
    from multiprocessing import forkserver

    tree = str(Path(__file__).resolve().parents[4])  # the folder holding rcsim/
    installed = {str(Path(p).resolve()) for p in site.getsitepackages()}
    installed.add(str(Path(site.getusersitepackages()).resolve()))
    env = {}
    if tree not in installed:
        before = os.environ.get("PYTHONPATH")
        env["PYTHONPATH"] = os.pathsep.join([tree] + ([before] if before else []))
    # Importing mujoco imports its GLFW rendering backend, which probes the GLFW library's
    # version in a child interpreter talking over a pipe.  The pool never renders; without
    # the probe it starts sooner, and a SIGTERM while it starts cannot orphan a probe that
    # prints a BrokenPipeError / EOFError traceback under the command's one line.
    if "MUJOCO_GL" not in os.environ:
        env["MUJOCO_GL"] = "disable"
    # The fork server dies with this process (pool_guard), unless started from a thread that
    # may end before the process does (Linux ties the request to the starting thread).
    if threading.current_thread() is threading.main_thread():
        env[pool_guard.PARENT_ENV] = str(os.getpid())
    _start_quiet_resource_tracker()
    with environment(env):
        forkserver.ensure_running()


def _start_quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker (once per process) with its stderr on
    /dev/null.  It unlinks the semaphores of a pool that was killed, not shut down (an
    interrupt), and would say so under the command's one line, after the command ended ("There
    appear to be 2 leaked semaphore objects to clean up at shutdown"); it still cleans them.
    """
    from multiprocessing import resource_tracker

    try:
        saved = os.dup(2)
    except OSError:
        resource_tracker.ensure_running()
        return
    try:
        sys.stderr.flush()
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)  # the tracker is started with this process's descriptor 2
        os.close(devnull)
        resource_tracker.ensure_running()
    finally:
        os.dup2(saved, 2)
        os.close(saved)


@contextmanager
def environment(values: dict):
    """``os.environ`` with ``values`` set inside the block, as it was after it."""
    before = {key: os.environ.get(key) for key in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for key, value in before.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


@contextmanager
def _main_script_hidden():
    """Start workers without re-running the user's script in them.

    A worker started by a fork server or by spawning re-imports the parent's ``__main__`` from
    its file, to find functions defined there.  Chunks need nothing from it, and a script or a
    notebook export written without the ``if __name__ == "__main__":`` guard would run its
    whole campaign again in every worker.  Hidden only while a worker may start (a ``-m``
    module is re-imported by name, which its own guard protects, and is left alone).
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or getattr(main, "__spec__", None) is not None:
        yield
        return
    del main.__file__
    try:
        yield
    finally:
        main.__file__ = path


def submit(pool: ProcessPoolExecutor, fn, *args) -> Future:
    """``pool.submit(fn, *args)``; a worker it starts does not re-run the user's script."""
    with _main_script_hidden():
        return pool.submit(fn, *args)


def kill_pool(pool: ProcessPoolExecutor) -> None:
    """Stop ``pool`` at once: queued chunks are dropped and running workers killed."""
    # concurrent.futures has no public way to stop a running worker before Python 3.14
    # (ProcessPoolExecutor.kill_workers); its process table is the documented-in-source way.
    manager = getattr(pool, "_executor_manager_thread", None)
    results = getattr(pool, "_result_queue", None)
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.kill()
    # A worker killed while it sent its result leaves part of a message in the result pipe, and
    # the manager thread would wait for the rest for ever (then the interpreter's exit for the
    # thread: ~25 s after Ctrl-C, and a warning of leaked semaphores).  Every worker killed,
    # this process's write end is the pipe's last: closed, the thread reads the pipe's end and
    # sees the pool broken, as it is.
    writer = getattr(results, "_writer", None)
    if writer is not None:
        writer.close()
    pool.shutdown(wait=False, cancel_futures=True)
    # Wait for the pool's manager thread to see its workers gone and close its wake-up pipe.
    # Left running, it races the interpreter's exit hook, which writes to that pipe while the
    # thread closes it (CPython 3.11 prints "OSError: Bad file descriptor" after our one line).
    if manager is not None:
        manager.join(timeout=10.0)


def local_results(
    spec: CampaignSpec,
    chunks: Iterator[Chunk],
    workers: int,
    n_chunks: int,
    cancel: threading.Event,
) -> Generator[ChunkResult, None, None]:
    """Yield the results of ``chunks`` as they finish, at most ``workers`` flying at once.

    One worker (or one chunk): in this process, with MuJoCo's own threads on every CPU (an
    interrupt stops it between two control cycles, through ``cancel``).  More: a
    :func:`worker_pool`, each chunk flown with one MuJoCo thread and one more chunk queued;
    when the consumer stops early (an interrupt), the workers are killed and the queued chunk
    dropped.
    """
    workers = max(1, min(workers, n_chunks))
    # C flight code may crash its process: it never flies in this one.
    if workers == 1 and not spec.controller.startswith(LIBRARY_PREFIX):
        nthread = os.cpu_count() or 1
        for chunk in chunks:
            yield simulate_chunk(spec, chunk, nthread=nthread, cancel=cancel)
        return
    pool = worker_pool(workers)
    pending: dict[Future, Chunk] = {}
    finished_normally = False
    # One chunk more than workers: a worker that finishes starts the queued chunk at once,
    # instead of idling while this process takes its result, commits it and submits the next
    # (~16 ms a chunk, 1.3 % of a paper-size flight; docs/performance.md).
    in_flight = workers + 1
    try:
        while True:
            for chunk in islice(chunks, in_flight - len(pending)):
                pending[submit(pool, simulate_chunk, spec, chunk, 1)] = chunk
            if not pending:
                finished_normally = True
                return
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            lost = []
            for future in done:
                chunk = pending.pop(future)
                if isinstance(future.exception(), BrokenProcessPool):
                    lost.append(chunk)
                else:
                    yield future.result()
            if lost:
                # A worker died (a crash in C flight code, or a kill): the chunks in flight in
                # the pool are lost with it.  Fly them again run by run, each crash recorded
                # with its run and cycle, then go on with a new pool.
                lost += list(pending.values())
                pending.clear()
                kill_pool(pool)
                for chunk in sorted(lost, key=lambda c: c.first):
                    yield crashed_chunk(spec, chunk)
                pool = worker_pool(workers)
    finally:
        if finished_normally:
            pool.shutdown(wait=True)
        else:
            kill_pool(pool)
