"""Dask execution of a campaign: connect (or start a local cluster), stream chunk results,
and stop quietly.

Local workers are started with SIGINT ignored: a terminal's Ctrl-C reaches the whole process
group, and it is the campaign's process that stops them (cancelling their tasks and closing
the cluster with distributed's loggers silenced), so an interrupt prints one line, not a
traceback per worker.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
from collections.abc import Generator
from itertools import islice
from typing import TYPE_CHECKING

from rcsim.analysis.engine.campaign.chunk import simulate_chunk, simulate_chunk_isolated
from rcsim.lookup.c_library import LIBRARY_PREFIX
from rcsim.models.errors import InputError

if TYPE_CHECKING:
    from rcsim.analysis.engine.campaign.chunk import ChunkResult
    from rcsim.analysis.engine.campaign.spec import CampaignSpec


def dask_results(
    spec: CampaignSpec, chunks, client, in_flight: int
) -> Generator[ChunkResult, None, None]:
    """Yield ChunkResults from a Dask client, at most ``in_flight`` tasks submitted; tasks
    still queued or running when the consumer stops are cancelled."""
    from distributed import as_completed

    # C flight code may crash its process: on a worker it flies in a child of the worker.
    fly = simulate_chunk_isolated if spec.controller.startswith(LIBRARY_PREFIX) else simulate_chunk
    submit = lambda c: client.submit(fly, spec, c, 1, pure=False)  # noqa: E731
    live = {submit(c) for c in islice(chunks, in_flight)}
    pool = as_completed(list(live))
    try:
        for fut in pool:
            result = fut.result()
            live.discard(fut)
            fut.release()
            for chunk in islice(chunks, 1):
                new = submit(chunk)
                live.add(new)
                pool.add(new)
            yield result
    finally:
        if live:
            with quiet_dask(), contextlib.suppress(Exception):
                # Workers log every task cancelled under them; that is the point here.
                client.run(_quiet_worker)
                client.cancel(list(live), force=True)


def _quiet_worker() -> None:
    """Run on each Dask worker before its tasks are cancelled: silence distributed's logs."""
    logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)


#: The loggers a closing Dask cluster talks through.
_DASK_LOGGERS = ("distributed", "tornado", "asyncio")


@contextlib.contextmanager
def quiet_dask():
    """Silence distributed's (and its event loop's) loggers: closing a cluster with tasks in
    flight makes them log every cancelled task and closed stream, which is expected here."""
    loggers = [logging.getLogger(n) for n in _DASK_LOGGERS]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


@contextlib.contextmanager
def _children_ignore_sigint():
    """Processes started inside ignore SIGINT (an ignored signal stays ignored across exec,
    and Python keeps it so).  Only in the main thread, where signals can be set."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def connect(workers: int | None, scheduler: str | None):
    """A Dask client (and the cluster we started, to close), or (None, None) for local mode."""
    if workers is not None and scheduler is not None:
        raise InputError(
            "cannot be combined with a scheduler: workers starts a local cluster, "
            "scheduler uses an existing one (they are exclusive)",
            parameter="workers",
            value=workers,
        )
    if workers is None and scheduler is None:
        return None, None
    from distributed import Client, LocalCluster

    from rcsim.analysis.engine.campaign.chunk import warm_up

    if workers is not None:
        if workers < 1:
            raise InputError(f"must be >= 1, got {workers}", parameter="workers", value=workers)
        from distributed.deploy.spec import SpecCluster

        before = set(SpecCluster._instances)
        client = None
        try:
            with _children_ignore_sigint():
                cluster = LocalCluster(
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    # No dashboard, but the scheduler still serves its health routes over
                    # HTTP, on port 8787 unless told otherwise: a second campaign found it
                    # taken and warned in four lines.  Any free port here only.
                    scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                )
            client = Client(cluster)
            client.run(warm_up)
        except BaseException:
            # Interrupted while the cluster started: closed here, its workers killed, not
            # left to distributed's exit hook (which printed a 30-line traceback of a nanny
            # that never started after the one line).
            for started in set(SpecCluster._instances) - before:
                close(client, started, kill=True)
            raise
        return client, cluster
    else:
        cluster = None
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(
                f"{scheduler}: cannot connect ({exc})", parameter="scheduler", value=scheduler
            ) from None
    client.run(warm_up)
    return client, cluster


def check_workers_controller(client, spec: CampaignSpec) -> None:
    """Build the campaign's controller on every Dask worker before any run: a plug-in that
    imports here but not on a worker (another environment, a module not on its path) is
    refused with one line naming the worker, instead of failing every chunk it is sent."""
    answers = client.run(_controller_problem, spec)
    bad = {worker: why for worker, why in answers.items() if why}
    if bad:
        worker, why = next(iter(sorted(bad.items())))
        raise InputError(
            f"{spec.source}: controller {spec.controller!r} cannot be built on Dask worker "
            f"{worker} ({len(bad)} of {len(answers)} workers): {why}"
        )


def _controller_problem(spec: CampaignSpec) -> str | None:
    """Run on a worker: why the spec's controller cannot be built there, or None."""
    try:
        spec.make_controller()
    except Exception as exc:  # noqa: BLE001 - reported to the user as the worker's answer
        return " ".join(str(exc).split()) or type(exc).__name__
    return None


def close(client, cluster, *, kill: bool = False) -> None:
    """Close a Dask client and the cluster we started, quietly and without a long wait.

    ``kill`` (an interrupt): the cluster's worker processes are killed first -- a worker busy
    in a chunk does not answer the request to stop, and closing waited 4 s per worker for it,
    then logged that it killed it."""
    with quiet_dask():
        if kill and cluster is not None:
            _kill_workers(cluster)
        if client is not None:
            with contextlib.suppress(Exception):
                client.close(timeout=5)
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close(timeout=5)
        if kill and cluster is not None:
            # Closed as far as it goes: distributed's exit hook would try again, for 10 s,
            # a cluster whose workers never started.
            from distributed.deploy.spec import SpecCluster

            SpecCluster._instances.discard(cluster)
    if kill:
        # The work was interrupted and its one line is on its way: what the cluster's event
        # loop still logs while it winds down ("Received 'close-stream' ...") stays unsaid.
        for name in _DASK_LOGGERS:
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _kill_workers(cluster) -> None:
    """SIGKILL the worker processes of a local cluster (its nannies' children)."""
    import os

    for nanny in list(getattr(cluster, "workers", {}).values()):
        # A nanny restarts a worker that died unless told the cluster is closing; one spawned
        # now, as the cluster closes, fails to start and prints its traceback on stderr.
        with contextlib.suppress(Exception):
            nanny.close_gracefully(reason="rcsim-interrupted")
        pid = getattr(nanny, "pid", None)
        if isinstance(pid, int) and pid > 0:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
