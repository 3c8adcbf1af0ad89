"""Propellant, the refinement's stated second objective.

A table change that removes failures by firing longer can cost far more propellant than it
buys: on an Apollo-like vehicle a held-out seed showed cases whose mean propellant rose 62-86 %
for changes the search had taken on failures alone.  The rule here:

* A change whose per-case mean propellant rises by at most ``max_rise`` (default
  :data:`MAX_RISE`, 10 %) over the paired runs is judged on failures alone (the McNemar gate of
  :mod:`rcsim.analysis.apps.refinement.gate`).
* A change that raises it by more must **pay for it with failures**: the one-sided 95 % lower
  confidence bound of its failure reduction (the share of runs that stop failing, net) must be
  at least :data:`GAIN_PER_10PCT` (1 percentage point of runs) per 10 % of propellant rise.
  A change whose failures are only equal (or fewer by a margin the runs cannot show) is refused.

The lower bound is exact and conditional, like the gate's test: of the ``m = b + c``
discordant runs (``b`` failed before only, ``c`` after only), the share that improved has the
Clopper-Pearson one-sided lower bound ``pi_lo = Beta(0.05; b, c + 1)``, so the net reduction
per run is at least ``m (2 pi_lo - 1) / n``.  Means are reported with a Student-t 95 % interval
over the case's runs (:func:`mean_interval`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

#: Default largest rise of a case's mean propellant judged on failures alone (a fraction).
MAX_RISE = 0.10

#: Failure reduction (share of runs, lower 95 % bound) a change must show per 10 % of
#: propellant rise beyond ``max_rise``: one percentage point.
GAIN_PER_10PCT = 0.01

#: Confidence of the one-sided lower bound of the failure reduction, and of the t intervals.
CONFIDENCE = 0.95


def mean_interval(values, confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """``(mean, lo, hi)`` of ``values`` [kg] with a two-sided Student-t interval (NaN runs,
    a simulation that failed, are left out; fewer than two runs: the interval is NaN)."""
    x = np.asarray(values, float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float("nan"), float("nan"), float("nan")
    mean = float(x.mean())
    if x.size < 2:
        return mean, float("nan"), float("nan")
    half = float(stats.t.ppf(0.5 + confidence / 2, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size))
    return mean, mean - half, mean + half


def case_propellant(runs: pd.DataFrame, n_trials: int) -> pd.DataFrame:
    """Per trial ``0 .. n_trials - 1`` of a scoring frame (``trial, propellant_kg``): the mean
    propellant per run and its t 95 % interval, ``propellant_kg, ci_lo_kg, ci_hi_kg``."""
    rows = []
    groups = dict(tuple(runs.groupby("trial")["propellant_kg"]))
    for t in range(n_trials):
        g = groups.get(t)
        rows.append(mean_interval(np.array([]) if g is None else g.to_numpy()))
    return pd.DataFrame(rows, columns=["propellant_kg", "ci_lo_kg", "ci_hi_kg"])


def rise(before_kg: float, after_kg: float) -> float:
    """Relative change of the mean propellant (0.2: 20 % more); 0 when neither used any,
    infinite when only the change uses some."""
    if not before_kg > 0:
        return 0.0 if not after_kg > 0 else float("inf")
    return after_kg / before_kg - 1.0


def failure_gain_lower_bound(b: int, c: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided lower confidence bound of the net failure reduction per run, ``(b - c) / n``
    in expectation: ``m (2 pi_lo - 1) / n`` with ``m = b + c`` and ``pi_lo`` the exact
    (Clopper-Pearson) one-sided lower bound of ``b / m`` (module docstring).  0 discordant
    runs: 0."""
    m = int(b) + int(c)
    if m == 0 or n <= 0:
        return 0.0
    pi_lo = float(stats.beta.ppf(1.0 - confidence, b, c + 1)) if b > 0 else 0.0
    return m * (2.0 * pi_lo - 1.0) / n


@dataclass(frozen=True)
class PropellantVerdict:
    """The propellant rule on one row change's paired runs.

    ``before_kg`` / ``after_kg``: mean propellant per run; ``rise``: relative change (a
    fraction); ``gain_lo``: lower bound of the failure reduction per run; ``needed``: the
    reduction the rise asks for (0 within ``max_rise``); ``passes``: the change may be kept on
    propellant; ``reason``: why not ("" when it passes).
    """

    before_kg: float
    after_kg: float
    rise: float
    gain_lo: float
    needed: float
    passes: bool
    reason: str

    @property
    def rise_pct(self) -> float:
        return 100.0 * self.rise


def propellant_check(
    before: pd.DataFrame, after: pd.DataFrame, max_rise: float = MAX_RISE
) -> PropellantVerdict:
    """The rule of the module docstring on paired runs (``k, failed, propellant_kg`` per run,
    the same ``k`` before and after)."""
    b_runs = before.set_index("k").sort_index()
    a_runs = after.set_index("k").sort_index()
    if not b_runs.index.equals(a_runs.index):
        raise ValueError("before and after must fly the same runs (same k)")
    fb, fa = b_runs["failed"].to_numpy(bool), a_runs["failed"].to_numpy(bool)
    b, c = int((fb & ~fa).sum()), int((~fb & fa).sum())
    mb = mean_interval(b_runs["propellant_kg"])[0]
    ma = mean_interval(a_runs["propellant_kg"])[0]
    r = rise(mb, ma)
    gain_lo = failure_gain_lower_bound(b, c, fb.size)
    if not r > max_rise:
        return PropellantVerdict(mb, ma, r, gain_lo, 0.0, True, "")
    needed = GAIN_PER_10PCT * r / 0.10
    passes = bool(gain_lo >= needed)
    reason = (
        ""
        if passes
        else (
            f"propellant {100 * r:+.1f} % (limit {100 * max_rise:g} %) with failures "
            f"{int(fb.sum())} -> {int(fa.sum())}: the failure reduction's 95 % lower bound "
            f"{100 * gain_lo:.1f} % of runs is under the {100 * needed:.1f} % it must pay"
        )
    )
    return PropellantVerdict(mb, ma, r, gain_lo, needed, passes, reason)


def rule_text(max_rise: float) -> str:
    """The rule in one sentence, for the changelog's reader and the report."""
    return (
        f"A change raising a case's mean propellant by more than {100 * max_rise:.0f} % is kept "
        f"only if the one-sided 95 % lower bound of its failure reduction (exact, on the paired "
        f"runs) is at least {100 * GAIN_PER_10PCT:.0f} percentage point of runs per 10 % of "
        f"propellant rise; with failures only equal it is refused. Propellant means carry "
        f"Student-t 95 % intervals over the case's runs."
    )
