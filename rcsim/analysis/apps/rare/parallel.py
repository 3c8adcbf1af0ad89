"""The ``K`` repeats of a case's estimation, side by side on worker processes or a Dask cluster.

The repeats are independent subset simulations (:mod:`rcsim.analysis.engine.rare.repeats`): each
is a pure function of the spec, the case and its index, and writes only into its own
``repeat-<k>/`` folder, so they run in parallel on the campaign's local worker pool
(:func:`rcsim.analysis.engine.campaign.local.worker_pool`: fork server, workers that die with
this process, Ctrl-C left to it) or on the workers of a Dask cluster (``--scheduler``, the
campaign's :func:`rcsim.analysis.engine.campaign.cluster.connect`), and the result is the same
bit for bit with one worker or many. A Dask worker writes its repeat's files itself, so the
output directory must be on a filesystem the workers share (:func:`check_shared`). Inside a
level the chains of a repeat move together (one batch a step), and those steps are sequential;
repeats are what parallelises. Why processes and not threads: the control cycle's numpy work
holds the interpreter (``local``'s docstring).

Progress: a worker appends one line per finished level to its ``repeat-<k>/levels.log`` (a
record of when each level ended, kept); this process echoes new lines as they appear. A killed
or interrupted estimation leaves every repeat's state at its last finished level; ``--resume``
continues each one there.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rcsim.analysis.apps.rare.settings import RareSettings
    from rcsim.analysis.engine.campaign.spec import CampaignSpec
    from rcsim.analysis.engine.rare.series import SeriesRepeat

LOG = "levels.log"
#: Seconds between two looks at the workers' progress logs.
POLL_S = 0.5


def _log_writer(path: Path) -> Callable[[str], None]:
    def write(line: str) -> None:
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(f"{time.strftime('%Y-%m-%dT%H:%M:%S')} {line}\n")

    return write


def repeat_in_worker(
    spec: CampaignSpec, case_index: int, settings: RareSettings, k: int, case_dir: str
) -> SeriesRepeat:
    """Repeat ``k`` in a worker process: one MuJoCo thread, progress to its log."""
    from rcsim.analysis.apps.rare.repeat import estimate_repeat, repeat_dir

    where = repeat_dir(Path(case_dir), k)
    where.mkdir(parents=True, exist_ok=True)
    return estimate_repeat(
        spec, case_index, settings, k, Path(case_dir), _log_writer(where / LOG), nthread=1
    )


class _Tail:
    """New lines of the repeats' progress logs, as they are written."""

    def __init__(self, paths: list[Path]):
        self.paths = paths
        self.seen = [p.stat().st_size if p.exists() else 0 for p in paths]

    def lines(self) -> list[str]:
        new = []
        for i, path in enumerate(self.paths):
            if not path.exists() or path.stat().st_size <= self.seen[i]:
                continue
            with open(path, encoding="utf-8") as fh:
                fh.seek(self.seen[i])
                text = fh.read()
            complete = text[: text.rfind("\n") + 1]
            self.seen[i] += len(complete.encode("utf-8"))
            new += [line.split(" ", 1)[1] for line in complete.splitlines()]
        return new


def check_shared(client, case_dir: Path) -> None:
    """Refuse a Dask cluster whose workers cannot see ``case_dir`` (one line, no traceback)."""
    from rcsim.models.errors import InputError

    probe = case_dir / f".probe-{secrets.token_hex(4)}"
    probe.write_text("rcsim campaign rare: can the workers see this folder?\n")
    try:
        seen = client.submit(os.path.exists, str(probe.resolve()), pure=False).result()
    finally:
        probe.unlink()
    if not seen:
        raise InputError(
            f"{case_dir.parent.parent}: the Dask workers cannot see this directory; "
            "`campaign rare --scheduler` needs an output directory on a filesystem the workers "
            "share (or use --workers on this machine)",
            parameter="scheduler",
            value=str(case_dir.parent.parent),
        )


def run_repeats(
    spec: CampaignSpec,
    case_index: int,
    settings: RareSettings,
    case_dir: Path,
    progress: Callable[[str], None] | None,
    workers: int,
    client=None,
) -> list[SeriesRepeat]:
    """Every repeat's result (ids global), repeat ``k`` at index ``k``: on the Dask ``client``'s
    workers when given; else in this process when ``workers`` is 1 (MuJoCo's threads on every
    CPU), else on ``min(workers, repeats)`` local processes."""
    from rcsim.analysis.apps.rare.repeat import estimate_repeat, repeat_dir

    k_all = range(settings.repeats)
    workers = max(1, min(workers, settings.repeats))
    if client is None and workers == 1:
        return [estimate_repeat(spec, case_index, settings, k, case_dir, progress) for k in k_all]
    for k in k_all:
        repeat_dir(case_dir, k).mkdir(parents=True, exist_ok=True)
    tail = _Tail([repeat_dir(case_dir, k) / LOG for k in k_all])
    args = (spec, case_index, settings)
    if client is not None:
        check_shared(client, case_dir)
        where = str(case_dir.resolve())
        futures = {client.submit(repeat_in_worker, *args, k, where, pure=False): k for k in k_all}
        stop = lambda: _cancel_dask(client, list(futures))  # noqa: E731
    else:
        from rcsim.analysis.engine.campaign.local import kill_pool, submit, worker_pool

        pool = worker_pool(workers)
        futures = {submit(pool, repeat_in_worker, *args, k, str(case_dir)): k for k in k_all}
        stop = lambda: kill_pool(pool)  # noqa: E731
    finished = False
    try:
        results: dict = {}
        pending = set(futures)
        while pending:
            done = {f for f in pending if f.done()}
            if not done:
                time.sleep(POLL_S)
            for line in tail.lines():
                if progress is not None:
                    progress(line)
            for future in done:
                results[futures[future]] = future.result()
            pending -= done
        finished = True
        return [results[k] for k in k_all]
    finally:
        if client is None and finished:
            pool.shutdown(wait=True)
        elif not finished:
            stop()


def _cancel_dask(client, futures) -> None:
    from rcsim.analysis.engine.campaign.cluster import quiet_dask

    with quiet_dask(), contextlib.suppress(Exception):
        client.cancel(futures, force=True)
