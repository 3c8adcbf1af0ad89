"""The continuous failure margin of a run: how far it ended from the campaign's failure criterion.

One number per run, ``margin``, in units of the thresholds (a fraction of each): the smallest of
one term per criterion the campaign applies,

* rate (always): ``(thr - max_axis |final rate error|) / thr``;
* attitude (when ``failure.attitude_error_deg`` is set): ``(att_thr - final attitude error) /
  att_thr``;
* each ``[failure]`` budget set (``max_propellant_kg``, ``max_delta_v_m_s``):
  ``(budget - value) / budget``;
* propellant exhaustion (when a vehicle file tracks propellant): ``-1`` for a run whose
  propellant ran out, no term otherwise (a step, not a distance: the runs table records the
  propellant used, not a reserve to measure against);

so that **a run fails exactly when its margin is not >= 0** (``failed == ~(margin >= 0)``): the
rate criterion fails at the threshold itself (``not |error| < thr``), so a rate term of exactly
0 is returned as the float just below 0; the attitude criterion fails only beyond it
(``not error <= att_thr``), so its 0 stays 0.  A run whose simulation failed has no flight and
a NaN margin (failed).  A criterion added to the campaign adds one term to
:func:`criterion_terms` (a rare-event estimation, :mod:`rcsim.analysis.apps.rare`, needs the
margin's sign to be the criterion: its identity test, ``tests/analysis/engine/test_run_margin.py``,
flies a campaign and checks every run).

Must not import: rcsim.analysis.apps, rcsim.analysis.engine.campaign.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

#: The ``margin`` column's meaning (runs table schema).
MARGIN_MEANING = (
    "distance to the failure criterion in fractions of its thresholds: the smallest of "
    "(thr - max_axis |final rate error|) / thr, (att_thr - final_att_err_deg) / att_thr "
    "when an attitude threshold is set, (budget - value) / budget for each [failure] budget "
    "set (max_propellant_kg, max_delta_v_m_s), and -1 when the propellant ran out; below 0 (or "
    "NaN: sim_failed) exactly when failed"
)

#: The float just below 0: a rate term of exactly 0 fails (``not |error| < thr``).
JUST_BELOW_ZERO = -np.finfo(float).tiny


def criterion_terms(
    *,
    final_rate_err_rad_s: np.ndarray,
    rate_threshold_rad_s: float,
    final_att_err_deg: np.ndarray | None = None,
    attitude_threshold_deg: float | None = None,
    propellant_exhausted_s: np.ndarray | None = None,
    budgets: Mapping[str, tuple[np.ndarray, float]] | None = None,
) -> Mapping[str, np.ndarray]:
    """One margin term per criterion, each (n,) in fractions of its threshold (module
    docstring).

    Parameters
    ----------
    final_rate_err_rad_s : ndarray, (n, 3)
        Final rate error per body axis, rad/s (the values the criterion compares).
    rate_threshold_rad_s : float
    final_att_err_deg : ndarray, (n,), optional
        Final total attitude error, deg; used only with ``attitude_threshold_deg``.
    attitude_threshold_deg : float, optional
    propellant_exhausted_s : ndarray, (n,), optional
        When each run's propellant ran out (NaN: it did not); None when not tracked.
    budgets : dict of str to (ndarray (n,), float), optional
        The ``[failure]`` budgets set: name -> (the run's value, the budget > 0),
        e.g. ``{"max_propellant_kg": (propellant_kg, 0.05)}``; a run fails above a budget, so
        its term ``(budget - value) / budget`` fails below 0 and passes at 0.

    Returns
    -------
    dict of str to ndarray (n,)
        ``"rate"``, and ``"attitude"``, ``"propellant"`` when those criteria apply.
    """
    worst = np.max(np.abs(np.asarray(final_rate_err_rad_s, float)), axis=1)
    thr = float(rate_threshold_rad_s)
    rate = (thr - worst) / thr
    terms = {"rate": np.where(rate == 0.0, JUST_BELOW_ZERO, rate)}
    if attitude_threshold_deg is not None and final_att_err_deg is not None:
        att_thr = float(attitude_threshold_deg)
        terms["attitude"] = (att_thr - np.asarray(final_att_err_deg, float)) / att_thr
    if propellant_exhausted_s is not None:
        ran_out = np.isfinite(np.asarray(propellant_exhausted_s, float))
        terms["propellant"] = np.where(ran_out, -1.0, np.inf)
    for key, (value, limit) in (budgets or {}).items():
        terms[key] = (float(limit) - np.asarray(value, float)) / float(limit)
    return terms


def run_margin(terms: Mapping[str, np.ndarray], sim_failed: np.ndarray) -> np.ndarray:
    """(n,) the margin: the smallest term per run, NaN where the simulation failed.

    NaN in a term (a NaN final error) makes the margin NaN, i.e. failed, as the criterion
    counts it (``not NaN < thr``).
    """
    stacked = np.vstack([np.asarray(t, float) for t in terms.values()])
    worst = np.min(stacked, axis=0)  # NaN propagates: np.min is NaN if any term is
    return np.where(np.asarray(sim_failed, bool), np.nan, worst)
