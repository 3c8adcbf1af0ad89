"""The outcomes of flown runs: firings, times to rate, final errors, failure and its reason.

One row per run, columns :func:`rcsim.analysis.engine.runs_table.outcome_columns` of the flown
vehicle's jets; a function of the batch's :class:`~rcsim.spacecraft.simulation.History`, the spec's
thresholds and its vehicle's jet map only (no I/O beyond reading the vehicle file).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from rcsim.analysis.engine.campaign.motion import (
    _FULL_CYCLE_RTOL,
    BUDGETS,
    budget_text,
    budget_thresholds,
    failed_by,
    motion_outcomes,
    over_budget,
)
from rcsim.analysis.engine.campaign.motion import firing_starts as firing_starts  # re-exported
from rcsim.analysis.engine.run_margin import criterion_terms, run_margin
from rcsim.analysis.engine.runs_table import outcome_frame
from rcsim.spacecraft import cycle_kernel
from rcsim.spacecraft.propellant import exhausted_before, exhausted_text
from rcsim.spacecraft.simulation import History
from rcsim.spacecraft.vehicle.model import AXES, jet_name

if TYPE_CHECKING:
    from rcsim.analysis.engine.campaign.spec import CampaignSpec


def _channel_table(spec: CampaignSpec | None) -> bool:
    """Whether the campaign flies a channel table (:mod:`rcsim.models.tables.channels`)."""
    from rcsim.models.tables import PAPER_LOOKUP_TABLES, is_channel_table

    table = getattr(spec, "table", None)  # None: no table, or a spec-like without one
    return table is not None and table not in PAPER_LOOKUP_TABLES and is_channel_table(table)


def axis_jets(spec: CampaignSpec) -> np.ndarray:
    """(3, n_jets) bool: the jets that count as roll, pitch, yaw jets for a campaign.

    The jets that torque each axis (the spec's vehicle's torque signs nonzero,
    :attr:`rcsim.spacecraft.vehicle.Vehicle.axis_signs`: Table 2 for the paper's); for a
    campaign flying a channel table, the jets its channels of each axis fire
    (:func:`rcsim.lookup.channels.axis_jets_of`: on a coupled layout every jet torques several
    axes, so the torque signs alone say little about which firing serves which axis).
    """
    table = getattr(spec, "table", None)
    if table is not None and _channel_table(spec):
        from rcsim.lookup.channels import axis_jets_of
        from rcsim.models.tables import load_recipe, recipe_path

        return axis_jets_of(load_recipe(recipe_path(table)))
    return (spec.vehicle.axis_signs != 0).T


def _cycle_major(a: np.ndarray) -> np.ndarray:
    """(K, n, ...) view of a history's (n, K, ...) array: the layout its buffers are written
    in (:meth:`rcsim.spacecraft.simulation.BatchSimulation.run`), where elementwise passes read
    memory in order."""
    return a.swapaxes(0, 1)


def _jet_bits(mask: np.ndarray) -> np.ndarray:
    """(..., words) unsigned ints: ``mask`` (..., n_jets) bool packed into words of 8, 16, 32
    or 64 bits (the narrowest that holds every jet; 64-bit words beyond 64 jets), jet j in bit
    j % width of word j // width.  Whether some jet of an axis is on is then one AND per cycle
    and run, not a pass over every jet; the masks are exact (no rounding to differ)."""
    n_jets = mask.shape[-1]
    width = next((w for w in (8, 16, 32) if n_jets <= w), 64)
    words = -(-n_jets // width)
    if n_jets != words * width:
        padded = np.zeros(mask.shape[:-1] + (words * width,), bool)
        padded[..., :n_jets] = mask
        mask = padded
    mask = np.ascontiguousarray(mask).reshape(mask.shape[:-1] + (words, width))
    # An integer matmul (exact) with the bit weights packs them, ~2x faster than packbits.
    weights = np.left_shift(1, np.arange(width, dtype=np.uint64)).astype(f"uint{width}")
    return mask.view(np.uint8) @ weights


def _axes_of(bits: np.ndarray, jets: np.ndarray) -> np.ndarray:
    """(n, K, 3) bool: some jet of each axis is set in ``bits`` ((K, n, words) of
    :func:`_jet_bits`); ``jets`` (3, n_jets) bool, the axes' jets (:func:`axis_jets`)."""
    masks = _jet_bits(jets)  # (3, words)
    hit = (bits[:, :, None, :] & masks) != 0  # (K, n, 3, words)
    out = hit[..., 0] if masks.shape[1] == 1 else hit.any(axis=-1)
    return out.swapaxes(0, 1)


def axis_firings(
    on_time_s: np.ndarray, cycle_s: float, jets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per run, cycle and axis: a firing of the axis's jets starts, and one goes on.

    Parameters
    ----------
    on_time_s : ndarray, (n, K, n_jets)
        Commanded on-times [s] (a history's, whose buffers are cycle-major).
    cycle_s : float
        Control cycle [s].
    jets : ndarray of bool, (3, n_jets)
        The axes' jets (:func:`axis_jets`).

    Returns
    -------
    starts : ndarray of bool, (n, K, 3)
        Some jet of the axis starts a firing in the cycle (:func:`firing_starts`, the per-jet
        form this computes on packed jet masks).
    going_on : ndarray of bool, (n, K - 1, 3)
        For cycles 1..K-1: some jet of the axis filled the previous cycle and is still on.
    """
    on = _cycle_major(on_time_s)  # (K, n, n_jets)
    full_at = cycle_s * (1.0 - _FULL_CYCLE_RTOL)
    if cycle_kernel.kernel_available() and on.flags.c_contiguous and on.dtype == np.float64:
        # One compiled pass over the record in place: the same rule, booleans.
        starts, going_on = cycle_kernel.group_firings(on, jets, full_at)
        return starts.swapaxes(0, 1), going_on.swapaxes(0, 1)
    on_bits = _jet_bits(on > 0)  # (K, n, words)
    prev_full = np.zeros_like(on_bits)
    prev_full[1:] = _jet_bits(on[:-1] >= full_at)
    return _axes_of(on_bits & ~prev_full, jets), _axes_of(prev_full[1:] & on_bits[1:], jets)


def outcomes(history: History, spec: CampaignSpec) -> pd.DataFrame:
    """Outcome columns of each run of a flown batch (degrees and deg/s at this boundary).

    The control cycle is the one the batch flew (``history.cycle_s``); propellant is at the
    flown vehicles' Isp (``history.flown_params``).

    Definitions (``thr`` = ``spec.rate_threshold_rad_s``; rate errors sampled at each cycle's
    start and at the end of the run):

    * ``firings_to_rate_<axis>``: firing events on the axis's jets (:func:`axis_jets`; cycles
      in which at least one of them starts a firing -- a jet pair firing together is one
      event; for a channel table, the first cycle of a run of cycles in which the axis's
      jets fire) before the
      commanded rate is first reached on that axis: the first sample with ``|rate error| < thr``
      taken while none of the axis's jets is in the middle of a firing (a firing that
      overshoots sweeps the error through zero mid-firing; that is not reaching the rate).
      All of the run's events if never reached.
    * ``time_to_rate_<axis>_s``: time of that first sample (NaN if never).
    * ``rate_settled_time_s``: start of the final stretch in which every axis stays under
      ``thr`` through the end of the run (NaN if the run does not end under it).
    * Firing events in a cycle that starts at or after the run's propellant ran out are not
      counted (the jets deliver nothing; :mod:`rcsim.spacecraft.propellant`), as
      ``firings_total`` does not count them.
    * ``failed``: the simulation failed, or some axis ends with ``|rate error| >= thr``, or
      (if set) the final total attitude error exceeds ``spec.attitude_threshold_rad``, or the
      propellant ran out (a vehicle file's tracked propellant, :mod:`rcsim.spacecraft.propellant`).
    Runs whose simulation failed get NaN outcomes: their state is not a flight.  Columns,
    units and meanings: :func:`rcsim.analysis.engine.runs_table.outcome_columns`.  An axis's
    jets are those of :func:`axis_jets` of the spec's vehicle.
    """
    n, K = history.rate_err_B.shape[:2]
    cycle_s = history.cycle_s
    thr = spec.rate_threshold_rad_s
    rate = np.concatenate([history.rate_err_B, history.final.rate_err_B[:, None]], axis=1)
    below = np.abs(rate) < thr  # (n, K + 1, 3)
    times = np.arange(K + 1) * cycle_s
    jets = axis_jets(spec)
    if jets.shape[1] != history.n_jets:  # pragma: no cover - the spec's vehicle is the flown one
        raise AssertionError(f"{jets.shape[1]} jets in the jet map, {history.n_jets} flown")
    # Sample k is taken mid-firing on an axis when one of its jets filled cycle k - 1 and is
    # still on in cycle k.  A firing that overshoots sweeps the rate error through zero, so one
    # such sample would lie under thr although the firing ends far from the command: only
    # samples between firings count as "reached".
    mid = np.zeros_like(below)
    if _channel_table(spec):
        # A channel's jets fire their recipe's share of every cycle (0.99 of it, or less when
        # shared jets are scaled), never a full cycle: a firing is a run of consecutive cycles
        # in which the axis's jets are on, an event the first cycle of such a run.
        active = _axes_of(_jet_bits(_cycle_major(history.on_time_s) > 0), jets)  # (n, K, 3)
        mid[:, 1:K] = active[:, :-1] & active[:, 1:]
        events = active.copy()
        events[:, 1:] &= ~active[:, :-1]
    else:
        events, mid[:, 1:K] = axis_firings(history.on_time_s, cycle_s, jets)
    # Commands after the propellant ran out are no firings (rcsim.spacecraft.propellant).
    dead = exhausted_before(times[:K], history.propellant_exhausted_s)  # (n, K) or None
    if dead is not None:
        events &= ~dead[:, :, None]
    settled = below & ~mid
    reached = settled.any(axis=1)  # (n, 3)
    first = np.where(reached, settled.argmax(axis=1), K + 1)  # first sample reached

    # Events before the first sample reached: the running count of events (cycle-major, the
    # layout they are made in) read at that sample.
    counted = np.cumsum(events.swapaxes(0, 1), axis=0, dtype=np.int64)  # (K, n, 3)
    upto = np.minimum(first, K) - 1  # last cycle before that sample; -1: none
    to_rate = np.where(
        upto >= 0, np.take_along_axis(counted, np.maximum(upto, 0)[None], axis=0)[0], 0
    )

    all_below = below[:, :, 0] & below[:, :, 1] & below[:, :, 2]  # (n, K + 1)
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
        cols[f"time_to_rate_{axis}_s"] = np.where(
            reached[:, a], times[np.minimum(first[:, a], K)], np.nan
        )
    for a, axis in enumerate(AXES):
        cols[f"firings_{axis}"] = events[:, :, a].sum(axis=1).astype(float)
    cols["firings_total"] = prop.firings.sum(axis=1).astype(float)
    for j in range(history.n_jets):
        cols[f"{jet_name(j + 1)}_on_time_s"] = prop.on_time_s[:, j]
    assert history.flown_params is not None, "outcomes() needs a simulation's history"
    cols["propellant_kg"] = prop.propellant_kg(history.flown_params.isp_s)
    cols["rate_settled_time_s"] = settle
    cols.update(motion_outcomes(history))

    sim_failed = np.asarray(history.failed, bool)
    exhausted = history.propellant_exhausted_s  # None: propellant not tracked
    failure = (getattr(spec, "resolved", None) or {}).get("failure") or {}
    over = over_budget(cols, failure)  # the spec's propellant / delta-v budgets
    reasons = []
    for i in range(n):
        if sim_failed[i]:
            reasons.append(history.reason[i] or "simulation failed")
            continue
        bad = [
            f"{AXES[a]} {abs(final_rate_deg[i, a]):.4g}"
            for a in range(3)
            if not abs(rate[i, -1, a]) < thr
        ]
        why = []
        if bad:
            why.append(f"final |rate error| >= {np.degrees(thr):.4g} deg/s: " + ", ".join(bad))
        if spec.attitude_threshold_rad is not None and not (
            att_total[i] <= np.degrees(spec.attitude_threshold_rad)
        ):
            why.append(
                f"final attitude error {att_total[i]:.4g} deg > "
                f"{np.degrees(spec.attitude_threshold_rad):.4g} deg"
            )
        if exhausted is not None and np.isfinite(exhausted[i]):
            why.append(exhausted_text(exhausted[i]))
        for key, mask in over.items():
            if mask[i]:
                column = BUDGETS[key][0]
                why.append(budget_text(key, cols[column][i], failure[key]))
        reasons.append("; ".join(why))
    # Outcomes of a non-flight are not numbers.
    out: dict[str, Any] = {
        k: np.where(sim_failed, np.nan, np.asarray(v, float)) for k, v in cols.items()
    }
    out["sim_failed"] = sim_failed
    out["failed"] = np.array([bool(r) for r in reasons], dtype=bool)
    out["reason"] = reasons
    # Which criteria each run failed, by name (the reasons' criteria, as flags).
    flew = ~sim_failed
    att_thr = spec.attitude_threshold_rad
    criteria = {
        "simulation": sim_failed,
        "rate": flew & ~(np.abs(rate[:, -1]) < thr).all(axis=1),
        "attitude": flew & (att_thr is not None and ~(att_total <= np.degrees(att_thr or 0.0))),
        "propellant_exhausted": flew & (exhausted is not None and np.isfinite(exhausted)),
        **{key: flew & mask for key, mask in over.items()},
    }
    out["failed_by"] = failed_by(criteria)
    out["margin"] = run_margin(
        criterion_terms(
            final_rate_err_rad_s=rate[:, -1],
            rate_threshold_rad_s=thr,
            final_att_err_deg=att_total,
            attitude_threshold_deg=(
                None
                if spec.attitude_threshold_rad is None
                else float(np.degrees(spec.attitude_threshold_rad))
            ),
            propellant_exhausted_s=exhausted,
            budgets={
                key: (np.asarray(cols[BUDGETS[key][0]], float), limit)
                for key, limit in budget_thresholds(failure).items()
            },
        ),
        sim_failed,
    )
    return outcome_frame(out, history.n_jets)
