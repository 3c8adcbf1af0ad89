"""One chunk of a campaign: draw the runs' vehicles, fly them as one batch, tabulate outcomes.

A chunk is a contiguous range of run ids of one case.  Everything here is a function of the
spec and the run ids only (per-run random streams, per-run independent simulations), so a
chunk's table is the same whichever process, worker or chunk size produced it.  This module
is what a Dask worker imports; it writes nothing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from rcsim.spacecraft.dispersions import DispersedRuns, dispersion_frame, draw_runs
from rcsim.spacecraft.propulsion import PropulsionParams
from rcsim.spacecraft.simulation import History
from rcsim.spacecraft.vehicle import AXES, N_JETS, VehicleParams, load_model

# A firing continues into the next cycle only if it filled the previous one -- the same rule
# (and tolerance) as spacecraft.propulsion.apply_valve_limits, so firing counts agree with it.
_FULL_CYCLE_RTOL = 1e-12


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


def warm_up() -> None:
    """Import what a chunk needs and compile the model once (run on each Dask worker before the
    campaign's clock starts, so start-up is not billed to the first chunk)."""
    import importlib

    for module in ("rcsim.lookup.pattern_recognition", "rcsim.lookup.phase_plane"):
        importlib.import_module(module)

    load_model()


# A chunk's simulation records every cycle of every run (spacecraft.simulation.History: 29
# float64 per run and cycle).  Long runs get smaller chunks so that one chunk's record stays
# under this budget [bytes]: a 500 s maneuver in a 256-run chunk would otherwise hold 740 MB.
HISTORY_BUDGET_BYTES = 192 * 2**20
HISTORY_BYTES_PER_RUN_CYCLE = 29 * 8
# Chunk counts are rounded up to a multiple of this, so that 1, 2 or 4 workers get equal shares
# and finish together (5 chunks on 2 workers leave one idle for the last fifth of the work).
CHUNK_COUNT_MULTIPLE = 4


def max_chunk_runs(spec, duration_s: float) -> int:
    """Most runs per chunk for runs of ``duration_s``: ``spec.chunk_size``, or fewer when the
    chunk's per-cycle record would exceed :data:`HISTORY_BUDGET_BYTES`."""
    cycles = int(np.ceil(duration_s / PropulsionParams().cycle_s))
    by_memory = HISTORY_BUDGET_BYTES // (cycles * HISTORY_BYTES_PER_RUN_CYCLE)
    return int(max(1, min(spec.chunk_size, by_memory)))


def plan_chunks(spec) -> list[Chunk]:
    """Chunks of at most :func:`max_chunk_runs` runs (sizes as equal as possible), in run-id
    order.

    A chunk is one batched simulation, so all its runs must last equally long: chunks span
    consecutive cases of equal duration (e.g. all 26 rate cases), which keeps batches large
    when runs per case are few.  The plan is a function of the spec only (results never depend
    on it: every run draws from its own seed stream).
    """
    chunks = []
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
            chunks.append(Chunk(first, stop))
            first = stop
    return chunks


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
    """

    chunk: Chunk
    runs: pd.DataFrame
    envelope: pd.DataFrame
    histories: dict


def fly_runs(spec, run_ids: np.ndarray, *, nthread: int = 1,
             model=None) -> tuple[History, DispersedRuns]:
    """Draw and fly campaign runs ``run_ids`` (cases of equal duration) as one batch."""
    from rcsim.analysis.flight import fly_batch
    from rcsim.lookup.registry import make_controller

    model = load_model() if model is None else model
    run_ids = np.asarray(run_ids, dtype=np.int64)
    dispersed = draw_runs(VehicleParams.nominal(1, model), spec.sigmas, spec.seed, run_ids)
    scenarios = [spec.cases[c] for c in run_ids // spec.runs_per_case]
    controller = make_controller(spec.controller, table=spec.table, model=model)
    history = fly_batch(scenarios, dispersed.params, controller, model=model, nthread=nthread)
    return history, dispersed


def axis_jets() -> np.ndarray:
    """(3, 16) bool: the jets that torque roll, pitch, yaw (Table 2)."""
    from rcsim.models.tables import load_jet_map

    return (load_jet_map() != 0).T


def firing_starts(on_time_s: np.ndarray, cycle_s: float) -> np.ndarray:
    """(n, K, 16) bool: a jet starts a new firing in the cycle (it was not on at the cycle's
    start, i.e. did not fill the previous cycle)."""
    full = on_time_s >= cycle_s * (1.0 - _FULL_CYCLE_RTOL)
    prev_full = np.zeros_like(full)
    prev_full[:, 1:] = full[:, :-1]
    return (on_time_s > 0) & ~prev_full


def outcomes(history: History, spec, cycle_s: float, isp_s: float) -> pd.DataFrame:
    """Outcome columns of each run of a flown batch (degrees and deg/s at this boundary).

    Definitions (``thr`` = ``spec.rate_threshold_rad_s``; rate errors sampled at each cycle's
    start and at the end of the run):

    * ``firings_to_rate_<axis>``: firing events on the axis's jets (cycles in which at least
      one of them starts a firing -- a jet pair firing together is one event) before the
      commanded rate is first reached on that axis: the first sample with ``|rate error| < thr``
      taken while none of the axis's jets is in the middle of a firing (a firing that
      overshoots sweeps the error through zero mid-firing; that is not reaching the rate).
      All of the run's events if never reached.
    * ``time_to_rate_<axis>_s``: time of that first sample (NaN if never).
    * ``settling_time_s``: start of the final stretch in which every axis stays under ``thr``
      through the end of the run (NaN if the run does not end under it).
    * ``failed``: the simulation failed, or some axis ends with ``|rate error| >= thr``, or
      (if set) the final total attitude error exceeds ``spec.attitude_threshold_rad``.
    Runs whose simulation failed get NaN outcomes: their state is not a flight.
    """
    n, K = history.rate_err_B.shape[:2]
    thr = spec.rate_threshold_rad_s
    rate = np.concatenate([history.rate_err_B, history.final.rate_err_B[:, None]], axis=1)
    below = np.abs(rate) < thr  # (n, K + 1, 3)
    times = np.arange(K + 1) * cycle_s
    jets = axis_jets()
    # Sample k is taken mid-firing on an axis when one of its jets filled cycle k - 1 and is
    # still on in cycle k.  A firing that overshoots sweeps the rate error through zero, so one
    # such sample would lie under thr although the firing ends far from the command: only
    # samples between firings count as "reached".
    on = history.on_time_s
    full = on >= cycle_s * (1.0 - _FULL_CYCLE_RTOL)  # (n, K, 16)
    going_on = full[:, :-1] & (on[:, 1:] > 0)  # filled cycle k - 1 and still on in cycle k
    mid = np.zeros_like(below)
    jets_f = jets.T.astype(float)  # (16, 3): a matmul counts an axis's jets, cheaper than any()
    mid[:, 1:K] = (going_on.astype(float) @ jets_f) > 0
    settled = below & ~mid
    reached = settled.any(axis=1)  # (n, 3)
    first = np.where(reached, settled.argmax(axis=1), K + 1)  # first sample reached

    starts = firing_starts(history.on_time_s, cycle_s)  # (n, K, 16)
    events = (starts.astype(float) @ jets_f) > 0  # (n, K, 3)
    before = np.arange(K)[None, :, None] < first[:, None, :]
    to_rate = (events & before).sum(axis=1)

    all_below = below.all(axis=2)  # (n, K + 1)
    # suffix[k]: all samples k..K are under thr; settling index = first such k.
    suffix = np.flip(np.logical_and.accumulate(np.flip(all_below, axis=1), axis=1), axis=1)
    settle = np.where(suffix[:, -1], times[suffix.argmax(axis=1)], np.nan)

    final_rate_deg = np.degrees(history.final.rate_err_B)
    final_att_deg = np.degrees(history.final.att_err_B)
    att_total = np.linalg.norm(final_att_deg, axis=1)
    prop = history.propulsion
    cols: dict[str, np.ndarray] = {}
    for a, axis in enumerate(AXES):
        cols[f"final_rate_err_{axis}_deg_s"] = final_rate_deg[:, a]
    for a, axis in enumerate(AXES):
        cols[f"final_att_err_{axis}_deg"] = final_att_deg[:, a]
    cols["final_att_err_deg"] = att_total
    for a, axis in enumerate(AXES):
        cols[f"firings_to_rate_{axis}"] = to_rate[:, a].astype(float)
    for a, axis in enumerate(AXES):
        cols[f"time_to_rate_{axis}_s"] = np.where(reached[:, a], times[np.minimum(first[:, a], K)],
                                                  np.nan)
    for a, axis in enumerate(AXES):
        cols[f"firings_{axis}"] = events[:, :, a].sum(axis=1).astype(float)
    cols["firings_total"] = prop.firings.sum(axis=1).astype(float)
    for j in range(N_JETS):
        cols[f"jet_{j + 1:02d}_on_time_s"] = prop.on_time_s[:, j]
    cols["propellant_kg"] = prop.propellant_kg(isp_s)
    cols["settling_time_s"] = settle
    frame = pd.DataFrame(cols)

    sim_failed = np.asarray(history.failed, bool)
    reasons = []
    for i in range(n):
        if sim_failed[i]:
            reasons.append(history.reason[i] or "simulation failed")
            continue
        bad = [f"{AXES[a]} {abs(final_rate_deg[i, a]):.4g}" for a in range(3)
               if not abs(rate[i, -1, a]) < thr]
        why = []
        if bad:
            why.append(f"final |rate error| >= {np.degrees(thr):.4g} deg/s: " + ", ".join(bad))
        if spec.attitude_threshold_rad is not None and not (
                att_total[i] <= np.degrees(spec.attitude_threshold_rad)):
            why.append(f"final attitude error {att_total[i]:.4g} deg > "
                       f"{np.degrees(spec.attitude_threshold_rad):.4g} deg")
        reasons.append("; ".join(why))
    frame.loc[sim_failed, :] = np.nan  # outcomes of a non-flight are not numbers
    frame["sim_failed"] = sim_failed
    frame["failed"] = np.array([bool(r) for r in reasons])
    frame["reason"] = reasons
    return frame


def envelope(history: History, cases: np.ndarray, alive: np.ndarray) -> pd.DataFrame:
    """Per case and cycle, min / max / sum over the runs ``alive`` (bool, (n,)) of that case
    (``cases``: case index per run, (n,)), plus a row for the final sample.

    Columns ``case_index, cycle, t_s, n_runs`` and, per axis, ``att_err_<axis>_deg_{min,max,sum}``,
    ``rate_<axis>_deg_s_{min,max,sum}``, ``on_time_<axis>_s_sum`` (on-time of the axis's jets
    summed over jets and runs) and ``firing_<axis>_runs`` (runs with any of them on).
    """
    frames = [_case_envelope(history, int(c), alive & (cases == c))
              for c in np.unique(cases[alive])]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def _case_envelope(history: History, case: int, alive: np.ndarray) -> pd.DataFrame:
    K = history.t_s.size
    cycle = history.t_s[1] - history.t_s[0] if K > 1 else 0.0
    att = np.degrees(np.concatenate([history.att_err_B[alive], history.final.att_err_B[alive, None]], 1))
    rate = np.degrees(np.concatenate([history.omega_B[alive], history.final.omega_B[alive, None]], 1))
    on = np.concatenate([history.on_time_s[alive], np.zeros((int(alive.sum()), 1, N_JETS))], 1)
    jets = axis_jets()
    cols = {
        "case_index": np.full(K + 1, case, dtype=np.int64),
        "cycle": np.arange(K + 1, dtype=np.int64),
        "t_s": np.append(history.t_s, history.t_s[-1] + cycle) if K else np.zeros(1),
        "n_runs": np.full(K + 1, int(alive.sum()), dtype=np.int64),
    }
    for a, axis in enumerate(AXES):
        for stat in ("min", "max", "sum"):
            cols[f"att_err_{axis}_deg_{stat}"] = getattr(att[:, :, a], stat)(axis=0)
        for stat in ("min", "max", "sum"):
            cols[f"rate_{axis}_deg_s_{stat}"] = getattr(rate[:, :, a], stat)(axis=0)
        axis_on = on[:, :, jets[a]]
        cols[f"on_time_{axis}_s_sum"] = axis_on.sum(axis=(0, 2))
        cols[f"firing_{axis}_runs"] = (axis_on > 0).any(axis=2).sum(axis=0).astype(np.int64)
    return pd.DataFrame(cols)


def _keep(spec, run_ids: np.ndarray, failed: np.ndarray) -> np.ndarray:
    """Which runs' histories the spec keeps."""
    if spec.histories == "all":
        return np.ones(run_ids.size, bool)
    if spec.histories == "failures":
        return failed.copy()
    if spec.histories == "first":
        return run_ids % spec.runs_per_case < spec.first_k
    return np.zeros(run_ids.size, bool)


def _row_frame(spec, dispersed: DispersedRuns, out: pd.DataFrame) -> pd.DataFrame:
    cases = dispersed.run_ids // spec.runs_per_case
    head = pd.DataFrame({
        "run_id": dispersed.run_ids,
        "case": [spec.cases[c].name for c in cases],
        "case_index": cases.astype(np.int64),
        "seed": np.full(dispersed.run_ids.size, spec.seed, dtype=np.int64),
    })
    return pd.concat([head, dispersion_frame(dispersed), out.reset_index(drop=True)], axis=1)


def _raised(spec, run_ids: np.ndarray, exc: BaseException, model) -> pd.DataFrame:
    """Rows for runs whose flight raised: inputs recorded, outcomes NaN, failed with reason."""
    dispersed = draw_runs(VehicleParams.nominal(1, model), spec.sigmas, spec.seed, run_ids)
    n = run_ids.size
    template = _template_columns()
    out = pd.DataFrame({c: np.full(n, np.nan) for c in template})
    out["sim_failed"] = True
    out["failed"] = True
    out["reason"] = f"exception: {type(exc).__name__}: {exc}".replace("\n", " ")
    return _row_frame(spec, dispersed, out)


def _template_columns() -> list[str]:
    cols = [f"final_rate_err_{a}_deg_s" for a in AXES] + [f"final_att_err_{a}_deg" for a in AXES]
    cols += ["final_att_err_deg"] + [f"firings_to_rate_{a}" for a in AXES]
    cols += [f"time_to_rate_{a}_s" for a in AXES] + [f"firings_{a}" for a in AXES]
    cols += ["firings_total"] + [f"jet_{j + 1:02d}_on_time_s" for j in range(N_JETS)]
    return cols + ["propellant_kg", "settling_time_s"]


def simulate_chunk(spec, chunk: Chunk, nthread: int = 1) -> ChunkResult:
    """Fly one chunk; never raises for a run's sake.

    If the batch raises (a controller or model error), each run is flown alone so that only
    the runs that raise by themselves are recorded failed, with the exception as the reason.
    """
    model = load_model()
    cycle_s = PropulsionParams().cycle_s
    try:
        history, dispersed = fly_runs(spec, chunk.run_ids, nthread=nthread, model=model)
    except Exception as exc:  # noqa: BLE001 - recorded as the failure reason of its runs
        if chunk.stop - chunk.first == 1:
            return ChunkResult(chunk, _raised(spec, chunk.run_ids, exc, model),
                               pd.DataFrame(), {})
        parts = [simulate_chunk(spec, Chunk(i, i + 1), nthread)
                 for i in range(chunk.first, chunk.stop)]
        env = [p.envelope for p in parts if not p.envelope.empty]
        return ChunkResult(
            chunk=chunk,
            runs=pd.concat([p.runs for p in parts], ignore_index=True),
            envelope=_combine(env) if env else pd.DataFrame(),
            histories={k: v for p in parts for k, v in p.histories.items()},
        )
    from rcsim.analysis.flight import history_frame

    out = outcomes(history, spec, cycle_s, dispersed.params.isp_s)
    runs = _row_frame(spec, dispersed, out)
    keep = _keep(spec, chunk.run_ids, runs["failed"].to_numpy())
    histories = {int(chunk.run_ids[i]): history_frame(history, int(i)) for i in np.flatnonzero(keep)}
    env = envelope(history, chunk.run_ids // spec.runs_per_case, ~np.asarray(history.failed, bool))
    return ChunkResult(chunk, runs, env, histories)


def _combine(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """Merge envelope frames of the same cycles (min of mins, max of maxes, sum of sums)."""
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
