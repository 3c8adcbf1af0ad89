"""One chunk of a campaign: draw the runs' vehicles, fly them as one batch, tabulate outcomes.

A chunk is a contiguous range of run ids of one case.  Everything here is a function of the
spec and the run ids only (per-run random streams, per-run independent simulations), so a
chunk's table is the same whichever process, worker or chunk size produced it.  This module
is what a Dask worker imports; it writes nothing.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rcsim.analysis.engine.campaign.effects import (
    adapt_options,
    draw_effects,
    mode_frame,
    mode_pairs,
)
from rcsim.analysis.engine.campaign.limits import HISTORY_BUDGET_BYTES

# firing_starts is re-exported only for old import paths (no in-tree importer is left; to be
# dropped once the lead confirms).
from rcsim.analysis.engine.campaign.outcomes import axis_jets, firing_starts, outcomes  # noqa: F401
from rcsim.analysis.engine.runs_table import (
    check_run_frame,
    input_frame,
    missing_outcomes,
    records_products,
)
from rcsim.spacecraft import cycle_kernel
from rcsim.spacecraft.dispersions import DispersedRuns, draw_runs
from rcsim.spacecraft.guards import history_bytes, invalid_runs
from rcsim.spacecraft.simulation import History
from rcsim.spacecraft.vehicle.model import AXES
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

if TYPE_CHECKING:
    from rcsim.analysis.engine.campaign.spec import CampaignSpec


@dataclass(frozen=True)
class Chunk:
    """Runs ``first .. stop - 1`` (a contiguous range; may span cases of equal duration)."""

    first: int
    stop: int

    @property
    def run_ids(self) -> np.ndarray:
        return np.arange(self.first, self.stop, dtype=np.int64)

    @property
    def name(self) -> str:
        return f"{self.first:07d}-{self.stop - 1:07d}"


def warm_up(spec: CampaignSpec | None = None) -> None:
    """Import what a chunk needs, and compile the campaign's vehicle model once when given
    (run on each worker before the campaign's clock starts, so start-up is not billed to the
    first chunk)."""
    import importlib

    for module in ("rcsim.lookup.pattern_recognition", "rcsim.lookup.phase_plane"):
        importlib.import_module(module)
    if spec is not None:
        spec.vehicle.model  # noqa: B018 - compiled once per process, cached by SHA-256


# Chunk counts are rounded up to a multiple of this, so that 1, 2 or 4 workers get equal shares
# and finish together (5 chunks on 2 workers leave one idle for the last fifth of the work).
CHUNK_COUNT_MULTIPLE = 4


def max_chunk_runs(spec: CampaignSpec, duration_s: float) -> int:
    """Most runs per chunk for runs of ``duration_s``: ``spec.chunk_size``, or fewer when the
    chunk's per-cycle record would exceed :data:`HISTORY_BUDGET_BYTES`."""
    cycles = int(np.ceil(duration_s / spec.cycle_s))
    # Imperfect sensors record what the controller measured; timing and faults record what
    # the jets delivered (rcsim.spacecraft.guards.history_bytes).
    # A vehicle with slosh or appendages records its mode coordinates and rates too (the
    # joints after the free one).
    extra = dict(spec.effects.records(), n_jets=spec.n_jets, n_modes=spec.vehicle.model.njnt - 1)
    # history_bytes(n, cycles) is affine in n: the shared time column plus n runs' records.
    shared = history_bytes(0, cycles, **extra)
    per_run = history_bytes(1, cycles, **extra) - shared
    by_memory = (HISTORY_BUDGET_BYTES - shared) // per_run
    return int(max(1, min(spec.chunk_size, by_memory)))


def plan_chunks(spec: CampaignSpec) -> list[Chunk]:
    """:func:`iter_chunks` as a list (for small campaigns and tests)."""
    return list(iter_chunks(spec))


def iter_chunks(spec: CampaignSpec) -> Iterator[Chunk]:
    """Chunks of at most :func:`max_chunk_runs` runs (sizes as equal as possible), in run-id
    order, generated one at a time (a campaign of many runs never holds its whole plan).

    A chunk is one batched simulation, so all its runs must last equally long: chunks span
    consecutive cases of equal duration (e.g. all 26 rate cases), which keeps batches large
    when runs per case are few.  The plan is a function of the spec only (results never depend
    on it: every run draws from its own seed stream).
    """
    groups: list[list[int]] = []
    for c, case in enumerate(spec.cases):
        if groups and spec.cases[groups[-1][-1]].duration_s == case.duration_s:
            groups[-1].append(c)
        else:
            groups.append([c])
    for group in groups:
        lo, hi = group[0] * spec.runs_per_case, (group[-1] + 1) * spec.runs_per_case
        # Equal sizes (within one run), so parallel chunks finish together.
        limit = max_chunk_runs(spec, spec.cases[group[0]].duration_s)
        count = -(-(hi - lo) // limit)
        count = min(hi - lo, -(-count // CHUNK_COUNT_MULTIPLE) * CHUNK_COUNT_MULTIPLE)
        size, extra = divmod(hi - lo, count)
        first = lo
        for k in range(count):
            stop = first + size + (1 if k < extra else 0)
            yield Chunk(first, stop)
            first = stop


@dataclass
class ChunkResult:
    """What a chunk returns to the campaign runner (plain DataFrames: cheap to ship from Dask).

    Attributes
    ----------
    chunk : Chunk
    runs : DataFrame
        One row per run (the runs.parquet columns).
    envelope : DataFrame
        Per-cycle min / max / sum over the chunk's simulated runs (for envelope plots).
    histories : dict of int -> DataFrame
        Per-cycle histories of the runs the spec keeps.
    solver : dict of str -> int
        The controller's solver counts over the chunk (:func:`fly_runs`; empty for a
        controller without them).
    crashes : tuple of str
        One line per run whose flight software crashed its process
        (:func:`crashed_chunk`), for the console.
    """

    chunk: Chunk
    runs: pd.DataFrame
    envelope: pd.DataFrame
    histories: dict
    solver: dict = field(default_factory=dict)
    crashes: tuple = ()


class Cancelled(BaseException):
    """A chunk was abandoned because its campaign was interrupted.

    A BaseException, like KeyboardInterrupt: it must pass through the ``except Exception``
    that records a raising run as failed.
    """


class _Cancellable:
    """A controller that raises :class:`Cancelled` at its next step once ``cancel`` is set.

    The controller is called once per control cycle of the batch, so an interrupted campaign
    stops its chunks in flight within a cycle's computation instead of finishing them.
    """

    def __init__(self, inner, cancel: threading.Event):
        self._inner, self._cancel = inner, cancel

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def initial_state(self, n_runs: int):
        return self._inner.initial_state(n_runs)

    def step(self, nav, state):
        if self._cancel.is_set():
            raise Cancelled()
        return self._inner.step(nav, state)


def fly_runs(
    spec: CampaignSpec,
    run_ids: np.ndarray,
    *,
    nthread: int = 1,
    cancel: threading.Event | None = None,
    solver: dict | None = None,
) -> tuple[History, DispersedRuns]:
    """Draw and fly campaign runs ``run_ids`` (cases of equal duration) as one batch.

    The vehicles come from the runs' dispersion streams; sensors, timing and faults (those
    the spec has) from children of their noise streams
    (:mod:`rcsim.analysis.engine.campaign.effects`), so a run flies the same whichever chunk holds
    it (and :func:`run_rows` records the same draws).  ``cancel``: when set (from another thread),
    the flight raises :class:`Cancelled`.  ``solver``: filled with the controller's solver
    counts when it has them (``solver_counts()``: the allocator's, e.g. its exact solves).
    """
    from rcsim.analysis.engine.flight import fly_batch

    vehicle = spec.vehicle
    run_ids = np.asarray(run_ids, dtype=np.int64)
    dispersed = draw_runs(vehicle.nominal(1), spec.sigmas, spec.seed, run_ids)
    scenarios = [spec.cases[c] for c in run_ids // spec.runs_per_case]
    effects = draw_effects(spec.effects, spec.seed, run_ids, spec.n_jets)[0]
    options = (
        {"adapt_options": adapt_options(spec.effects)} if spec.controller == "adaptive" else {}
    )
    controller = spec.make_controller(**options)
    if cancel is not None:
        controller = _Cancellable(controller, cancel)
    # The vehicle's valve timing comes with the effects: the spec's [dispersions.timing]
    # disperses about it (rcsim.analysis.engine.campaign.effects).
    history = fly_batch(
        scenarios, dispersed.params, controller, vehicle=vehicle, nthread=nthread, **effects
    )
    counts = getattr(controller, "solver_counts", None)
    if solver is not None and counts is not None:
        solver.update(counts())
    return history, dispersed


def envelope(
    history: History, cases: np.ndarray, alive: np.ndarray, jets: np.ndarray
) -> pd.DataFrame:
    """Per case and cycle, min / max / sum over the runs ``alive`` (bool, (n,)) of that case
    (``cases``: case index per run, (n,)), plus a row for the final sample; ``jets``
    (3, n_jets) bool: each axis's jets (:func:`~rcsim.analysis.engine.campaign.outcomes.axis_jets`).

    Columns ``case_index, cycle, t_s, n_runs`` and, per axis, ``att_err_<axis>_deg_{min,max,sum}``,
    ``rate_<axis>_deg_s_{min,max,sum}``, ``on_time_<axis>_s_sum`` (on-time of the axis's jets
    summed over jets and runs) and ``firing_<axis>_runs`` (runs with any of them on).
    """
    frames = [
        _case_envelope(history, int(c), alive & (cases == c), jets) for c in np.unique(cases[alive])
    ]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def _case_envelope(
    history: History, case: int, alive: np.ndarray, jets: np.ndarray
) -> pd.DataFrame:
    K = history.t_s.size
    cycle = history.cycle_s
    # The runs: a slice when they are consecutive (a chunk is one case; no failures), which
    # reads the history in place; fancy indexing copies every array first.
    ids = np.flatnonzero(alive)
    runs = slice(ids[0], ids[-1] + 1) if ids.size and ids[-1] - ids[0] + 1 == ids.size else ids
    n = ids.size

    def with_final(series: np.ndarray, final: np.ndarray, a: int) -> np.ndarray:
        """(n, K + 1) [deg]: component ``a`` of each run's cycles, then its final sample.
        C-ordered with runs outer, so the sums over runs add them one after another, in run
        order, as they always did (a different layout lets numpy sum pairwise: other bits)."""
        out = np.empty((n, K + 1))
        out[:, :K] = series[runs, :, a]
        out[:, K] = final[runs, a]
        return np.degrees(out, out=out)

    cols = {
        "case_index": np.full(K + 1, case, dtype=np.int64),
        "cycle": np.arange(K + 1, dtype=np.int64),
        "t_s": np.append(history.t_s, history.t_s[-1] + cycle) if K else np.zeros(1),
        "n_runs": np.full(K + 1, n, dtype=np.int64),
    }
    on_sum, firing = _group_on_time(history, runs, ids, jets)
    for a, axis in enumerate(AXES):
        att = with_final(history.att_err_B, history.final.att_err_B, a)
        for stat in ("min", "max", "sum"):
            cols[f"att_err_{axis}_deg_{stat}"] = getattr(att, stat)(axis=0)
        rate = with_final(history.omega_B, history.final.omega_B, a)
        for stat in ("min", "max", "sum"):
            cols[f"rate_{axis}_deg_s_{stat}"] = getattr(rate, stat)(axis=0)
        # The final sample fires nothing: its row is 0, as the zero row summed before was.
        cols[f"on_time_{axis}_s_sum"] = np.append(on_sum[a], 0.0)
        cols[f"firing_{axis}_runs"] = np.append(firing[a], 0)
    return pd.DataFrame(cols)


def _group_on_time(
    history: History, runs: slice | np.ndarray, ids: np.ndarray, jets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per axis and cycle: the on-time of the axis's jets summed over the runs ``runs``
    (``ids`` as indices), and how many of those runs fire one of them; (3, K) each.

    The compiled pass reads the flight's cycle-major record in place
    (:func:`rcsim.spacecraft.cycle_kernel.group_on_time`); the numpy form copies the runs run-major
    (32 MB for a 500-run chunk) and gathers each axis's jets, which numpy lays out jet by jet,
    and that layout is the summation order both keep (a run-major or cycle-major order would
    change the sums' last bits)."""
    record = history.on_time_s.swapaxes(0, 1)  # the (K, n, n_jets) buffer the flight wrote
    # A float64 record, as flights write it: numpy would sum another dtype in that dtype.
    if cycle_kernel.kernel_available() and record.flags.c_contiguous and record.dtype == np.float64:
        return cycle_kernel.group_on_time(record, ids, jets)
    on = np.ascontiguousarray(history.on_time_s[runs])
    sums = np.array([on[:, :, g].sum(axis=(0, 2)) for g in jets])
    firing = np.array([(on[:, :, g] > 0).any(axis=2).sum(axis=0) for g in jets], np.int64)
    return sums, firing


def _keep(spec: CampaignSpec, run_ids: np.ndarray, failed: np.ndarray) -> np.ndarray:
    """Which runs' histories the spec keeps."""
    if spec.histories == "all":
        return np.ones(run_ids.size, bool)
    if spec.histories == "failures":
        return failed.copy()
    if spec.histories == "first":
        return run_ids % spec.runs_per_case < spec.first_k
    return np.zeros(run_ids.size, bool)


def flown_inputs(dispersed: DispersedRuns, flown: RunParameters | None) -> DispersedRuns:
    """``dispersed`` with the vehicle values the simulation read back from MuJoCo's per-run
    model (``History.flown_params``): what runs.parquet records is what the physics flew.

    Runs with invalid parameters keep their draws: they were not flown (NaN outcomes,
    ``sim_failed``; the reason names the invalid value).  Jet tilt and azimuth stay the draws
    (MuJoCo holds only the direction they make; ``tests`` compare the two).
    """
    if flown is None:
        return dispersed
    drawn = dispersed.params
    ok = np.array([not r for r in invalid_runs(drawn)], dtype=bool)

    def pick(read, draw):
        return np.where(ok.reshape((-1,) + (1,) * (draw.ndim - 1)), read, draw)

    params = replace(
        drawn,
        mass_kg=pick(flown.mass_kg, drawn.mass_kg),
        cg_B=pick(flown.cg_B, drawn.cg_B),
        inertia_B=pick(flown.inertia_B, drawn.inertia_B),
        thrust_n=pick(flown.thrust_n, drawn.thrust_n),
        jet_dir_S=pick(flown.jet_dir_S, drawn.jet_dir_S),
        iquat=(
            None if drawn.iquat is None or flown.iquat is None else pick(flown.iquat, drawn.iquat)
        ),
    )
    return replace(dispersed, params=params)


def run_rows(spec: CampaignSpec, dispersed: DispersedRuns, outcome: pd.DataFrame) -> pd.DataFrame:
    """The runs.parquet rows of runs ``dispersed.run_ids``: identity, inputs (vehicle, its
    products of inertia when its principal axes are not B, then the spec's sensor / timing /
    fault draws, then the modes' when the vehicle file disperses them), ``outcome`` (columns:
    :func:`rcsim.analysis.engine.runs_table.run_columns` of ``spec.effects.groups``,
    :func:`~rcsim.analysis.engine.runs_table.records_products`, the vehicle's jets and its
    dispersed modes)."""
    products = records_products(dispersed.params)
    cases = dispersed.run_ids // spec.runs_per_case
    # The effects' draws are a function of (seed, run id): the ones fly_runs flew (a few
    # variates per run, negligible next to a flight).
    effects = draw_effects(spec.effects, spec.seed, dispersed.run_ids, spec.n_jets)[1]
    # The modes as flown: their draws and each run's coupled frequency on its hub as flown.
    modes = mode_frame(
        spec.effects, spec.vehicle.flight_model, dispersed.params, spec.seed, dispersed.run_ids
    )
    head = pd.DataFrame(
        {
            "run_id": dispersed.run_ids,
            "case": [spec.cases[c].name for c in cases],
            "case_index": cases.astype(np.int64),
            "seed": np.full(dispersed.run_ids.size, spec.seed, dtype=np.int64),
        }
    )
    return check_run_frame(
        pd.concat(
            [
                head,
                input_frame(dispersed),
                effects.reset_index(drop=True),
                modes.reset_index(drop=True),
                outcome.reset_index(drop=True),
            ],
            axis=1,
        ),
        spec.effects.groups,
        products,
        n_jets=spec.n_jets,
        modes=mode_pairs(spec.effects),
    )


def tabulate(spec: CampaignSpec, history: History, dispersed: DispersedRuns) -> pd.DataFrame:
    """The runs.parquet rows of a flown batch (inputs as flown, outcomes)."""
    out = outcomes(history, spec)
    return run_rows(spec, flown_inputs(dispersed, history.flown_params), out)


def _raised(spec: CampaignSpec, run_ids: np.ndarray, exc: BaseException) -> pd.DataFrame:
    """Rows for runs whose flight raised: inputs (the draws) recorded, outcomes NaN, failed
    with the exception as the reason."""
    reason = f"exception: {type(exc).__name__}: {exc}".replace("\n", " ")
    return _raised_reason(spec, run_ids, reason)


def simulate_chunk_isolated(spec: CampaignSpec, chunk: Chunk, nthread: int = 1) -> ChunkResult:
    """:func:`simulate_chunk` in a child process, for flight code that may crash its process
    (a C library: what a Dask worker runs, so that a crash ends neither the worker nor the
    campaign); a crash is flown again run by run (:func:`crashed_chunk`)."""
    from rcsim.analysis.engine.isolated import Crash, call_isolated

    ((_, result),) = call_isolated(_simulate_item, [(spec, chunk, nthread)])
    return crashed_chunk(spec, chunk) if isinstance(result, Crash) else result


def _simulate_item(item: tuple) -> ChunkResult:
    spec, chunk, nthread = item
    return simulate_chunk(spec, chunk, nthread)


def crashed_chunk(spec: CampaignSpec, chunk: Chunk) -> ChunkResult:
    """Fly a chunk whose process died, run by run in a child process
    (:func:`rcsim.analysis.engine.isolated.call_isolated`): the runs that crash it are recorded
    failed with the signal and the control cycle as their reason, the others fly as usual;
    ``crashes`` holds one line per crashed run (for the console)."""
    from rcsim.analysis.engine.isolated import Crash, call_isolated

    parts, lines = [], []
    for run_id, result in call_isolated(simulate_one_run, [(spec, r) for r in chunk.run_ids]):
        rid = int(run_id[1])
        if isinstance(result, Crash):
            why = f"flight software {result.describe()}"
            rows = _raised_reason(spec, np.array([rid]), why)
            parts.append(ChunkResult(Chunk(rid, rid + 1), rows, pd.DataFrame(), {}))
            lines.append(f"run {rid}: {why}; recorded failed, the campaign goes on")
        else:
            parts.append(result)
    return merge_parts(chunk, parts, crashes=tuple(lines))


def merge_parts(chunk: Chunk, parts: list[ChunkResult], crashes: tuple = ()) -> ChunkResult:
    """One result for ``chunk`` from the results of its runs flown apart."""
    env = [p.envelope for p in parts if not p.envelope.empty]
    return ChunkResult(
        chunk=chunk,
        runs=pd.concat([p.runs for p in parts], ignore_index=True),
        envelope=combine_envelopes(env) if env else pd.DataFrame(),
        histories={k: v for p in parts for k, v in p.histories.items()},
        solver=add_counts(p.solver for p in parts),
        crashes=crashes + tuple(line for p in parts for line in p.crashes),
    )


def simulate_one_run(item: tuple) -> ChunkResult:
    """``(spec, run_id)``: that run alone (what :func:`crashed_chunk` runs in a child)."""
    spec, run_id = item
    return simulate_chunk(spec, Chunk(int(run_id), int(run_id) + 1), 1)


def _raised_reason(spec: CampaignSpec, run_ids: np.ndarray, reason: str) -> pd.DataFrame:
    """Rows for runs that did not fly to the end: inputs (the draws) recorded, outcomes NaN,
    failed with ``reason``."""
    dispersed = draw_runs(spec.vehicle.nominal(1), spec.sigmas, spec.seed, run_ids)
    return run_rows(spec, dispersed, missing_outcomes(run_ids.size, reason, spec.n_jets))


def simulate_chunk(
    spec: CampaignSpec, chunk: Chunk, nthread: int = 1, cancel: threading.Event | None = None
) -> ChunkResult:
    """Fly one chunk; never raises for a run's sake.

    If the batch raises (a controller or model error), each run is flown alone so that only
    the runs that raise by themselves are recorded failed, with the exception as the reason.
    ``cancel`` (local mode only; an Event does not travel to Dask workers): when set, the
    chunk is abandoned with :class:`Cancelled`.
    """
    try:
        solver: dict = {}
        history, dispersed = fly_runs(
            spec, chunk.run_ids, nthread=nthread, cancel=cancel, solver=solver
        )
    except Exception as exc:  # noqa: BLE001 - recorded as the failure reason of its runs
        if chunk.stop - chunk.first == 1:
            return ChunkResult(chunk, _raised(spec, chunk.run_ids, exc), pd.DataFrame(), {})
        parts = [
            simulate_chunk(spec, Chunk(i, i + 1), nthread, cancel)
            for i in range(chunk.first, chunk.stop)
        ]
        return merge_parts(chunk, parts)
    from rcsim.analysis.engine.flight import history_frame

    runs = tabulate(spec, history, dispersed)
    keep = _keep(spec, chunk.run_ids, runs["failed"].to_numpy())
    histories = {
        int(chunk.run_ids[i]): history_frame(history, int(i)) for i in np.flatnonzero(keep)
    }
    env = envelope(
        history,
        chunk.run_ids // spec.runs_per_case,
        ~np.asarray(history.failed, bool),
        axis_jets(spec),
    )
    return ChunkResult(chunk, runs, env, histories, solver)


def add_counts(counts) -> dict:
    """The key-wise sum of solver-count dicts (:attr:`ChunkResult.solver`)."""
    total: dict = {}
    for one in counts:
        for key, value in one.items():
            total[key] = total.get(key, 0) + int(value)
    return total


def combine_envelopes(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """Merge envelope frames (of :func:`envelope`, or merged ones) per case and cycle: min of
    mins, max of maxes, sum of sums and counts, first ``t_s``.  Associative, so partial merges
    can be merged again."""
    data = pd.concat(frames, ignore_index=True)
    agg = {}
    for col in data.columns:
        if col in ("case_index", "cycle"):
            continue
        if col == "t_s":
            agg[col] = "first"
        elif col.endswith("_min"):
            agg[col] = "min"
        elif col.endswith("_max"):
            agg[col] = "max"
        else:
            agg[col] = "sum"
    return data.groupby(["case_index", "cycle"], as_index=False, sort=True).agg(agg)
