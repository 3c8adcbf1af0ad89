"""Fly candidate lookup tables over the same dispersed runs, all in one batched campaign.

A *trial* is one candidate table flown on one rate case.  Run ``k`` of a trial on case ``c``
flies the vehicle of campaign run ``c * runs_per_case + k`` -- the same draw from
``SeedSequence(seed, spawn_key=(run_id,))`` for every candidate (common random numbers), so a
difference between candidates is the table's doing, not sampling noise.  The baseline trials
(the table as it is) are exactly the runs ``rcsim campaign run`` flies with the same seed.

Every run of every trial goes into one list of runs, cut into chunks that are flown by the
campaign's local worker processes (:mod:`rcsim.analysis.engine.campaign.local`: one per CPU, so a
chunk's numpy work never waits on another's), each chunk one batched simulation in which every
run carries its own table (:meth:`rcsim.lookup.pattern_recognition.LookupController.for_runs`).
Results are the same for any worker count: each chunk is a pure function of its runs.
"""

from __future__ import annotations

import os
import sys
from collections import deque
from dataclasses import dataclass
from itertools import islice

import numpy as np
import pandas as pd

from rcsim.analysis.engine.campaign.chunk import max_chunk_runs
from rcsim.analysis.engine.campaign.effects import draw_effects
from rcsim.analysis.engine.campaign.local import kill_pool, submit, worker_pool
from rcsim.analysis.engine.campaign.outcomes import outcomes
from rcsim.analysis.engine.campaign.spec import CampaignSpec
from rcsim.analysis.engine.flight import fly_batch
from rcsim.analysis.engine.interrupts import raise_if_interrupted
from rcsim.analysis.results.scoring import trial_frame
from rcsim.lookup.pattern_recognition import LookupController, LookupParams
from rcsim.lookup.table_plugins import TablePlugin
from rcsim.models.tables import LookupTable
from rcsim.spacecraft.dispersions import draw_runs
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: Chunks submitted per worker process at a time (one flying, one waiting, so that a worker
#: never waits for this process to hand it the next).
IN_FLIGHT_PER_WORKER = 2


@dataclass(frozen=True)
class Trials:
    """Candidate tables and the case each is flown on.

    Attributes
    ----------
    times_s : ndarray, (n_trials, 26, 16)
        Each candidate's firing times [s].
    case : ndarray of int, (n_trials,)
        Table row (0-based case index) the trial flies.
    label : tuple of str
        What the candidate is (for the changelog and messages).
    k : tuple of arrays, optional
        The runs each trial flies (run numbers within its case); None: runs ``0 ..
        runs_per_case - 1`` of every trial.  A change to a row moves only the runs that fire
        the row: the other runs of another case need not be flown again.
    """

    times_s: np.ndarray
    case: np.ndarray
    label: tuple
    k: tuple | None = None

    @property
    def n_trials(self) -> int:
        return int(self.case.size)


def _fly_chunk(
    spec: CampaignSpec,
    table: LookupTable,
    params: RunParameters,
    run_times: np.ndarray,
    cases: np.ndarray,
    lookup_params: LookupParams,
    run_ids: np.ndarray,
    nthread: int = 1,
    plugin: TablePlugin | None = None,
) -> pd.DataFrame:
    """Fly one chunk: run ``i`` flies case ``cases[i]`` with vehicle ``params.take(i)`` and
    table ``run_times[i]``; return its outcome columns.  Runs in a worker process.  The
    spec's vehicle is flown as a campaign flies it (its model, profile, valve limits, tank,
    and the effects campaign run ``run_ids[i]`` draws: valve timing, pulses, blowdown, modes,
    :func:`~rcsim.analysis.engine.campaign.effects.draw_effects`).  ``plugin``: a plug-in
    flies the tables instead of the built-in lookup controller, each distinct table's runs as
    one batch (:mod:`rcsim.lookup.table_plugins`)."""
    if plugin is None:
        controller = LookupController.for_runs(table, run_times, lookup_params).record_rows()
        history = fly_batch(
            [spec.cases[c] for c in cases],
            params,
            controller,
            vehicle=spec.vehicle,
            nthread=nthread,
            **draw_effects(spec.effects, spec.seed, run_ids, spec.n_jets)[0],
        )
        out = outcomes(history, spec)
        assert controller.rows_fired is not None  # recorded by the flight
        out["rows_fired"] = rows_bitmask(controller.rows_fired)
        return out
    parts = []
    n_rows = np.asarray(table.firing_time_s).shape[0]
    for idx, ctl in plugin.controllers(spec.vehicle, table, run_times):
        history = fly_batch(
            [spec.cases[c] for c in cases[idx]],
            params.take(idx),
            ctl,
            vehicle=spec.vehicle,
            nthread=nthread,
            **draw_effects(spec.effects, spec.seed, run_ids[idx], spec.n_jets)[0],
        )
        part = outcomes(history, spec)
        part["rows_fired"] = rows_bitmask(plugin.rows_fired(ctl, idx.size, n_rows))
        parts.append(part.set_axis(idx))
    return pd.concat(parts).sort_index().reset_index(drop=True)


def rows_bitmask(rows_fired: np.ndarray) -> np.ndarray:
    """(n_runs,) int64: bit ``r`` set when the run fired table row ``r`` (``rows_fired``,
    (n_runs, n_rows) bool, at most 63 rows; a rate-case table has 26)."""
    rows_fired = np.asarray(rows_fired, bool)
    if rows_fired.shape[1] > 63:
        raise ValueError(f"at most 63 table rows can be recorded, got {rows_fired.shape[1]}")
    weights = np.left_shift(np.int64(1), np.arange(rows_fired.shape[1], dtype=np.int64))
    return (rows_fired.astype(np.int64) * weights).sum(axis=1)


def evaluate(
    spec: CampaignSpec,
    table: LookupTable,
    trials: Trials,
    *,
    lookup_params: LookupParams | None = None,
    threads: int | None = None,
    progress: bool | None = None,
    desc: str = "refine",
    runs_per_case: int | None = None,
    plugin: TablePlugin | None = None,
) -> pd.DataFrame:
    """Fly every trial over the first ``runs_per_case`` dispersed runs of its case.

    Parameters
    ----------
    spec : rcsim.analysis.engine.campaign.spec.CampaignSpec
        A rate-cases campaign: its cases (one per table row), seed, dispersions, failure
        threshold and runs per case.
    table : LookupTable
        The table the candidates edit (jet roles are learned from it).
    trials : Trials
    lookup_params : LookupParams, optional
        Default: the spec's vehicle's profile (:meth:`LookupParams.from_profile`).
    threads : int, optional
        Chunks in flight, each in its own worker process (default: CPU count; 1: in this
        process, on MuJoCo's threads).
    progress : bool, optional
        Progress bar on stderr; default only when stderr is a terminal.
    runs_per_case : int, optional
        Runs ``0 .. runs_per_case - 1`` of each case (numbered as the campaign numbers them,
        ``case * spec.runs_per_case + k``: the campaign's own draws); default all of them.
    plugin : TablePlugin, optional
        A plug-in that flies the tables (:mod:`rcsim.lookup.table_plugins`); default the
        built-in lookup controller with ``lookup_params``.

    Returns
    -------
    DataFrame
        One row per run: ``trial, case_index, k, failed, repeated`` (some axis needed more
        than one firing event to reach its commanded rate), ``firings_to_rate_<axis>``,
        ``final_rate_err_<axis>_deg_s``, ``propellant_kg`` and ``rows_fired`` (bit ``r`` set:
        the run started a firing with table row ``r``, :func:`rows_bitmask`).
    """
    from tqdm import tqdm

    stride = spec.runs_per_case
    n = stride if runs_per_case is None else min(int(runs_per_case), stride)
    vehicle = spec.vehicle
    if lookup_params is None:
        lookup_params = LookupParams.from_profile(vehicle.control)
    # Draw each involved case's runs once; every candidate of that case reuses them (about the
    # nominal vehicle the campaign disperses: the same draws as its runs).
    involved = np.unique(trials.case)
    run_ids = (involved[:, None] * stride + np.arange(n)[None, :]).ravel()
    params_all = draw_runs(vehicle.nominal(1), spec.sigmas, spec.seed, run_ids).params
    first_row = {int(c): i * n for i, c in enumerate(involved)}

    if trials.k is None:
        trial_of_run = np.repeat(np.arange(trials.n_trials), n)
        k_of_run = np.tile(np.arange(n), trials.n_trials)
    else:
        ks = [np.asarray(k, int) for k in trials.k]
        if any(k.size and (k.min() < 0 or k.max() >= n) for k in ks):
            raise ValueError(f"a trial's runs must be in 0..{n - 1}")
        trial_of_run = np.repeat(np.arange(trials.n_trials), [k.size for k in ks])
        k_of_run = np.concatenate(ks) if ks else np.zeros(0, int)
    case_of_run = trials.case[trial_of_run]
    row_of_run = np.array([first_row[int(c)] for c in trials.case])[trial_of_run] + k_of_run
    threads = max(1, threads or os.cpu_count() or 1)
    # Chunks as the campaign sizes them (its chunk size, under its per-chunk history memory
    # budget for this duration), equal and a multiple of the thread count so that the threads
    # finish together (one 512-run chunk and one 8-run chunk would idle one).
    limit = max_chunk_runs(spec, spec.cases[0].duration_s)
    count = -(-trial_of_run.size // limit)
    count = min(trial_of_run.size, -(-count // threads) * threads)
    bounds = np.linspace(0, trial_of_run.size, count + 1).round().astype(int)
    chunks = [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]

    def work(
        sl: slice,
    ) -> tuple[
        CampaignSpec, LookupTable, RunParameters, np.ndarray, np.ndarray, LookupParams, np.ndarray
    ]:
        return (
            spec,
            table,
            params_all.take(row_of_run[sl]),
            trials.times_s[trial_of_run[sl]],
            case_of_run[sl],
            lookup_params,
            run_ids[row_of_run[sl]],
        )

    show = sys.stderr.isatty() if progress is None else progress
    frames = []
    with tqdm(
        total=trial_of_run.size,
        unit="run",
        desc=desc,
        disable=not show,
        file=sys.stderr,
        dynamic_ncols=True,
    ) as bar:
        workers = min(threads, len(chunks))
        if workers == 1:
            for sl in chunks:
                frames.append(_fly_chunk(*work(sl), nthread=threads, plugin=plugin))
                bar.update(sl.stop - sl.start)
                raise_if_interrupted()  # one a library swallowed (rcsim.analysis.engine.interrupts)
        else:
            pool = worker_pool(workers)
            try:
                # A few chunks in flight, not all: each holds its runs' vehicles and tables
                # (~1.9 MB a 500-run chunk: all 52 of a 26,000-run evaluation, ~100 MB).
                # Results are taken in chunk order, so the frame is the same either way.
                todo = iter(chunks)
                flying = deque(
                    (sl, submit(pool, _fly_chunk, *work(sl), 1, plugin))
                    for sl in islice(todo, IN_FLIGHT_PER_WORKER * workers)
                )
                while flying:
                    sl, future = flying.popleft()
                    frames.append(future.result())
                    bar.update(sl.stop - sl.start)
                    raise_if_interrupted()
                    nxt = next(todo, None)
                    if nxt is not None:
                        flying.append((nxt, submit(pool, _fly_chunk, *work(nxt), 1, plugin)))
            except BaseException:  # an interrupt: stop the workers now, not after their chunks
                kill_pool(pool)
                raise
            pool.shutdown(wait=True)
    return trial_frame(trial_of_run, case_of_run, k_of_run, pd.concat(frames, ignore_index=True))


def runs_from_campaign(
    campaign_runs: pd.DataFrame, cases: np.ndarray, runs_per_case: int
) -> pd.DataFrame:
    """A campaign's ``runs.parquet`` rows as :func:`evaluate` would return them for trials
    that fly the campaign's own table on ``cases`` (one trial per case, in that order).

    A rate-cases campaign with the same seed, dispersions, duration and runs per case flies
    exactly the runs of those trials (run ``c * runs_per_case + k``), so flying them again
    would only repeat it.
    """
    want = np.asarray(cases, int)
    rows = campaign_runs[campaign_runs["case_index"].isin(want)].sort_values("run_id")
    if len(rows) != want.size * runs_per_case:
        raise ValueError(
            f"the campaign has {len(rows)} runs of these cases, expected "
            f"{want.size * runs_per_case}"
        )
    trial_of_case = {int(c): t for t, c in enumerate(want)}
    out = trial_frame(
        rows["case_index"].map(trial_of_case).to_numpy(),
        rows["case_index"].to_numpy(),
        (rows["run_id"] - rows["case_index"] * runs_per_case).to_numpy(),
        rows.reset_index(drop=True),
    )
    return out.sort_values(["trial", "k"], kind="stable").reset_index(drop=True)
