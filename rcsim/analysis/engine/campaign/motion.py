"""Propellant, translation and limit-cycle measures of flown runs.

Per run: propellant per jet, the net delta-v of the CG in N and in B (components and norms),
pulses, pulses at the jets' minimum on-time, pulses per minute and each jet's duty cycle.
Columns, units and meanings: :func:`rcsim.analysis.engine.runs_catalogue.propellant_motion_columns`.
Everything is a whole-batch array operation on the flight's
:class:`~rcsim.spacecraft.history.History` (no loop over runs).
"""

from __future__ import annotations

import numpy as np

from rcsim.spacecraft.history import History
from rcsim.spacecraft.propellant import exhausted_before
from rcsim.spacecraft.vehicle.model import jet_name

# A firing continues into the next cycle only if it filled the previous one -- the same rule
# (and tolerance) as rcsim.spacecraft.propulsion.apply_valve_limits, so firing counts agree with it.
_FULL_CYCLE_RTOL = 1e-12


def firing_starts(on_time_s: np.ndarray, cycle_s: float) -> np.ndarray:
    """(n, K, n_jets) bool: a jet starts a new firing in the cycle (it was not on at the cycle's
    start, i.e. did not fill the previous cycle).  The per-jet reference form of
    :func:`rcsim.analysis.engine.campaign.outcomes.axis_firings`, which outcomes use."""
    full = on_time_s >= cycle_s * (1.0 - _FULL_CYCLE_RTOL)
    prev_full = np.zeros_like(full)
    prev_full[:, 1:] = full[:, :-1]
    return (on_time_s > 0) & ~prev_full


#: ``[failure]`` budgets of a campaign spec: a run fails when its column exceeds
#: the budget; key -> (column, unit, words).
BUDGETS: dict[str, tuple[str, str, str]] = {
    "max_propellant_kg": ("propellant_kg", "kg", "propellant"),
    "max_delta_v_m_s": ("delta_v_N_m_s", "m/s", "net delta-v"),
}
BUDGET_KEYS: tuple[str, ...] = tuple(BUDGETS)


def budget_thresholds(failure: dict) -> dict[str, float]:
    """The budgets a resolved ``[failure]`` table sets (only those: a spec without them
    keeps its manifest)."""
    return {k: float(failure[k]) for k in BUDGET_KEYS if failure.get(k) is not None}


def over_budget(cols: dict, failure: dict) -> dict[str, np.ndarray]:
    """Per budget set in ``failure`` (a resolved ``[failure]`` table): (n,) bool, the run's
    column exceeds it (``>``: at the budget passes; NaN, a non-flight, is not over)."""
    return {
        key: np.asarray(cols[BUDGETS[key][0]], float) > limit
        for key, limit in budget_thresholds(failure).items()
    }


def budget_text(key: str, value: float, limit: float) -> str:
    """A run's reason for exceeding budget ``key``: ``propellant 0.0123 kg > 0.01 kg``."""
    _, unit, words = BUDGETS[key]
    return f"{words} {value:.4g} {unit} > {limit:.4g} {unit}"


def failed_by(criteria: dict[str, np.ndarray]) -> list[str]:
    """Per run, the names of the criteria it failed (``criteria``: name -> (n,) bool), joined
    by ``+`` in the given order; ``""`` when none."""
    names = list(criteria)
    hits = np.stack(
        [
            np.broadcast_to(np.asarray(m, bool), len(next(iter(criteria.values()))))
            for m in criteria.values()
        ],
        axis=1,
    )
    return ["+".join(name for name, hit in zip(names, row) if hit) for row in hits]


#: A pulse is at the minimum on-time when its on-time is within this fraction of a cycle of it
#: (the valve limits pass the command through unchanged: only rounding separates them).
MIN_PULSE_RTOL = 1e-9


def min_pulse_count(history: History) -> np.ndarray:
    """Pulses each run fired at the jets' minimum on-time, (n_runs,) int.

    A pulse starts in a cycle where the jet was not on at its start
    (:func:`firing_starts`); it is a minimum pulse
    when its commanded on-time equals ``history.min_pulse_s`` (shorter than a cycle, so the
    pulse ends in that cycle).  Cycles starting at or after the propellant ran out fire
    nothing (as ``firings_total``).  0 when the jets have no minimum (``min_pulse_s`` 0).
    """
    if history.min_pulse_s <= 0:
        return np.zeros(history.n_runs, np.int64)
    on = history.on_time_s
    at_min = np.abs(on - history.min_pulse_s) <= MIN_PULSE_RTOL * history.cycle_s
    counted = firing_starts(on, history.cycle_s) & at_min  # (n, K, n_jets)
    dead = exhausted_before(history.t_s, history.propellant_exhausted_s)
    if dead is not None:
        counted &= ~dead[:, :, None]
    return counted.sum(axis=(1, 2))


def motion_outcomes(history: History) -> dict[str, np.ndarray]:
    """The propellant, delta-v and pulse columns of every run of a flown batch, name -> (n,).

    Duty and pulse rate are over the flown duration ``n_cycles * cycle_s``; propellant per jet
    is its impulse over ``Isp g0`` at the flown Isp (their sum is ``propellant_kg``).  A
    history without delta-v (not made by a simulation) gets NaN delta-v: unknown, not zero.
    """
    if history.flown_params is None:
        raise ValueError("motion outcomes need a simulation's history (the flown vehicle)")
    prop = history.propulsion
    unknown = np.full((history.n_runs, 3), np.nan)  # a history not made by a simulation
    duration_s = history.on_time_s.shape[1] * history.cycle_s
    cols: dict[str, np.ndarray] = {}
    for frame, dv in (("N", history.delta_v_N), ("B", history.delta_v_B)):
        dv = unknown if dv is None else dv
        for a, axis in enumerate("xyz"):
            cols[f"delta_v_{axis}_{frame}_m_s"] = dv[:, a]
        cols[f"delta_v_{frame}_m_s"] = np.linalg.norm(dv, axis=1)
    pulses = prop.firings.sum(axis=1).astype(float)
    cols["pulses"] = pulses
    cols["min_pulses"] = min_pulse_count(history).astype(float)
    cols["pulses_per_min"] = pulses / (duration_s / 60.0)
    per_jet_kg = prop.jet_propellant_kg(history.flown_params.isp_s)
    duty = prop.on_time_s / duration_s
    for j in range(history.n_jets):
        cols[f"{jet_name(j + 1)}_propellant_kg"] = per_jet_kg[:, j]
    for j in range(history.n_jets):
        cols[f"{jet_name(j + 1)}_duty"] = duty[:, j]
    return cols
