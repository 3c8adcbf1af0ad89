"""Per-case means with 95 % intervals of the propellant, delta-v and pulse outcomes, for
``cases.csv``.

Additive partial sums (count, sum, sum of squares of the runs that flew) merge across chunks
like the other per-case statistics (:func:`rcsim.analysis.engine.campaign.results.case_stats`);
the interval is Student's t on the runs' mean, ``mean +- t_{0.975, n-1} s / sqrt(n)`` (n < 2:
none).  Sums of squares lose nothing that matters here: the outcomes are positive with a
spread of percent or more of their mean, far above the 1e-16 relative rounding.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.stats import t as student_t

#: The outcomes ``cases.csv`` gives the mean of, with ``_mean``, ``_lo95``, ``_hi95`` columns.
CASE_MEANS: tuple[str, ...] = (
    "propellant_kg",
    "delta_v_N_m_s",
    "delta_v_B_m_s",
    "pulses",
    "min_pulses",
)
#: Partial-sum columns start with this (merged by summing).
PREFIX = "_m_"


def mean_sums(runs: pd.DataFrame) -> pd.DataFrame:
    """Per run, the additive terms of each :data:`CASE_MEANS` column: 1, x, x^2 for a run
    that flew (a NaN, a non-flight, adds nothing)."""
    out = {}
    for c in CASE_MEANS:
        x = runs[c].to_numpy(float)
        ok = np.isfinite(x)
        x = np.where(ok, x, 0.0)
        out[f"{PREFIX}{c}_n"] = ok.astype(np.int64)
        out[f"{PREFIX}{c}_sum"] = x
        out[f"{PREFIX}{c}_sq"] = x * x
    return pd.DataFrame(out, index=runs.index)


def means_with_intervals(stats: pd.DataFrame) -> pd.DataFrame:
    """``<column>_mean``, ``_lo95``, ``_hi95`` per case from merged sums (NaN mean with no run
    flown; NaN interval with fewer than 2)."""
    out = {}
    for c in CASE_MEANS:
        n = stats[f"{PREFIX}{c}_n"].to_numpy(float)
        total, sq = (
            stats[f"{PREFIX}{c}_sum"].to_numpy(float),
            stats[f"{PREFIX}{c}_sq"].to_numpy(float),
        )
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(n > 0, total / n, np.nan)
            var = np.where(n > 1, np.maximum(sq - n * mean * mean, 0.0) / (n - 1), np.nan)
            half = student_t.ppf(0.975, np.maximum(n - 1, 1)) * np.sqrt(var / n)
        out[f"{c}_mean"] = mean
        out[f"{c}_lo95"] = mean - half
        out[f"{c}_hi95"] = mean + half
    return pd.DataFrame(out, index=stats.index)
