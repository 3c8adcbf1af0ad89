"""Single-factor drivers: which inputs are distributed differently among failed runs.

See :mod:`rcsim.analysis.results.drivers.kde` for the rank scale, the bandwidth rule, the
total-variation score
and the max-T permutation p-values.  This module adds the failure region of each input: the
bins of the input where the smoothed ``P(fail | x)`` is well above the base rate ``pi`` --
at least ``region_factor * pi``, capped at ``(1 + pi) / 2`` so a high base rate still leaves a
reachable threshold -- reported in the input's own units with the share of failures it holds.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers.base import as_rng, check_xy, minority_of
from rcsim.analysis.results.drivers.kde import (
    N_BINS_1D,
    BinnedTV,
    JointStrata,
    Strata,
    bandwidth,
    bin_codes,
    permutation_test,
    rank_scale,
)


class SingleFactorKDE:
    """Rank-scale KDE comparison of failed and successful runs, one input at a time.

    Parameters
    ----------
    n_bins : int
        Rank-scale bins (default 32).
    n_permutations : int
        Label permutations for the p-values (default 200: smallest p = 1/201).
    region_factor : float
        A bin belongs to the failure region when ``P(fail | x) >= region_factor * base rate``.
    random_state : int or numpy.random.Generator
        Seeds the permutations.

    Attributes
    ----------
    feature_names_in_ : list of str
    tv_, null_mean_, score_ : ndarray (p,)
        TV distance, its permutation-null mean, and ``score_ = tv_ - null_mean_``.
    p_value_ : ndarray (p,)
        Max-T adjusted permutation p-value (family: all inputs).
    p_raw_ : ndarray (p,)
        Unadjusted permutation p-value.
    rank_ : ndarray of int (p,)
        1 = largest score.
    bandwidth_ : float
        Kernel sd on the rank scale.
    base_rate_ : float
    conditional_ : ndarray (p, n_bins)
        Smoothed ``P(fail | bin)``.
    region_mask_ : ndarray of bool (p, n_bins)
    regions_ : list of str
        Failure region in input units ("" when none).
    region_fail_share_, region_run_share_ : ndarray (p,)
        Share of failed runs / of all runs inside the region.
    null_tv_ : ndarray (n_permutations, p)
    z_ : ndarray (p,)
        Standardised TV (see :func:`~rcsim.analysis.results.drivers.kde.standardise`).
    null_max_z_ : ndarray (n_permutations,)
        Largest standardised TV of each permutation: combined over independently permuted
        strata (cases) it gives a max-T family across them.
    engine_ : BinnedTV
        The binned counts of the fitted runs (reused by
        :class:`~rcsim.analysis.results.drivers.stability.HalfSampleStability`).
    """

    def __init__(self, n_bins=N_BINS_1D, n_permutations=200, region_factor=2.0, random_state=0):
        self.n_bins = n_bins
        self.n_permutations = n_permutations
        self.region_factor = region_factor
        self.random_state = random_state

    def fit(self, X, y, strata=None, *, codes=None, joint=False):
        """Score every column of ``X`` against the binary outcome ``y`` (True = failed).

        Parameters
        ----------
        X : DataFrame or array-like, (n, p)
        y : array-like of bool, (n,)
        strata : array-like, (n,), optional
            Labels are permuted within strata (e.g. rate cases).
        codes : ndarray of int32, (n, p), optional
            ``bin_codes(rank_scale(X), n_bins)`` when already computed: fits of several
            outcomes over the same inputs share it (the ranking is a third of a fit's time).
        joint : bool
            Draw the permutations as :class:`~rcsim.analysis.results.drivers.kde.JointStrata`
            does: fits of several outcomes whose ``random_state`` is a Generator of the same
            seed then see the same permutations of the runs, so that their null maxima combine
            into one exact max-T family (:mod:`rcsim.analysis.results.drivers.outcomes`).

        Returns
        -------
        self
        """
        X, y, strata, names = check_xy(X, y, strata)
        if int(self.n_permutations) < 1:
            raise ValueError(f"n_permutations must be >= 1, got {self.n_permutations}")
        rng = as_rng(self.random_state)
        minority = minority_of(y)
        if codes is None:
            codes = bin_codes(rank_scale(X), self.n_bins)
        elif np.shape(codes) != X.shape:
            raise ValueError(f"codes must have shape {X.shape}, got {np.shape(codes)}")
        self.bandwidth_ = bandwidth(int(minority.sum()), 1)
        draws = JointStrata if joint else Strata
        self.engine_ = BinnedTV(codes, self.n_bins, h=self.bandwidth_)
        res = permutation_test(
            self.engine_, minority, draws.build(strata, minority), int(self.n_permutations), rng
        )
        self.feature_names_in_ = names
        self.n_features_in_ = len(names)
        self.tv_, self.null_mean_, self.score_ = res.tv, res.null_mean, res.score
        self.p_value_, self.p_raw_, self.null_tv_ = res.p_maxt, res.p_raw, res.null_tv
        self.z_, self.null_max_z_ = res.z, res.null_max_z
        self.rank_ = _ranks(self.score_)
        self._regions(X, y, codes, self.engine_)
        return self

    def null_z(self) -> np.ndarray:
        """Standardised permutation-null TVs (n_permutations, p), on the scale of ``z_``."""
        allv = np.vstack([self.tv_[None], self.null_tv_])
        sd = allv.std(axis=0, ddof=1)
        sd = np.where(sd > 0, sd, np.inf)
        return (self.null_tv_ - allv.mean(axis=0)) / sd

    def _regions(self, X, y, codes, engine):
        base = float(y.mean())
        self.base_rate_ = base
        failed = engine.counts(np.flatnonzero(y)).astype(float)
        pooled = engine.pooled.astype(float)
        self.conditional_ = engine.smooth(failed) / np.maximum(engine.smooth(pooled), 1e-300)
        thr = min(self.region_factor * base, 0.5 * (1.0 + base))
        self.region_mask_ = self.conditional_ >= thr
        in_region = np.take_along_axis(self.region_mask_, codes.T, axis=1)  # (p, n)
        n_fail = max(int(y.sum()), 1)
        self.region_fail_share_ = (in_region & y[None]).sum(axis=1) / n_fail
        self.region_run_share_ = in_region.mean(axis=1)
        edges_u = np.linspace(0.0, 1.0, self.n_bins + 1)
        self.regions_ = [
            _format_region(self.region_mask_[j], np.quantile(X[:, j], edges_u))
            for j in range(X.shape[1])
        ]

    def table(self) -> pd.DataFrame:
        """One row per input, best first: the columns of ``drivers.csv``."""
        df = pd.DataFrame(
            {
                "factor": self.feature_names_in_,
                "score": self.score_,
                "p_value": self.p_value_,
                "rank": self.rank_,
                "failure_region": self.regions_,
                "region_fail_share": self.region_fail_share_,
                "region_run_share": self.region_run_share_,
                "tv": self.tv_,
                "tv_null_mean": self.null_mean_,
                "p_raw": self.p_raw_,
            }
        )
        return df.sort_values("rank", kind="stable").reset_index(drop=True)


def _ranks(score: np.ndarray) -> np.ndarray:
    """1-based ranks, largest score first (ties keep input order)."""
    order = np.argsort(-score, kind="stable")
    rank = np.empty(score.size, dtype=int)
    rank[order] = np.arange(1, score.size + 1)
    return rank


def _format_region(mask: np.ndarray, edges: np.ndarray) -> str:
    """Contiguous runs of ``mask`` as intervals of the input (edges: bin edges in input units)."""
    if not mask.any():
        return ""
    parts = []
    m = mask.size
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    for lo, hi in zip(idx[::2], idx[1::2]):  # bins lo .. hi-1
        a, b = edges[lo], edges[hi]
        if lo == 0 and hi == m:
            parts.append("everywhere")
        elif lo == 0:
            parts.append(f"<= {b:.6g}")
        elif hi == m:
            parts.append(f">= {a:.6g}")
        else:
            parts.append(f"{a:.6g} .. {b:.6g}")
    return " or ".join(parts)


def parse_region(region) -> tuple[str, list]:
    """``(side, [(lo, hi), ...])`` of a driver table's failure region text."""
    if not isinstance(region, str) or not region.strip():
        return "none", []
    parts = []
    for part in region.split(" or "):
        part = part.strip()
        if part == "everywhere":
            parts.append((-np.inf, np.inf))
        elif part.startswith("<="):
            parts.append((-np.inf, float(part[2:])))
        elif part.startswith(">="):
            parts.append((float(part[2:]), np.inf))
        else:
            lo, _, hi = part.partition("..")
            parts.append((float(lo), float(hi)))
    if len(parts) > 1:
        side = "several"
    elif np.isinf(parts[0][0]) and np.isinf(parts[0][1]):
        side = "none"
    elif np.isinf(parts[0][1]):
        side = "high"
    elif np.isinf(parts[0][0]):
        side = "low"
    else:
        side = "middle"
    return side, parts


def in_region(x: np.ndarray, region) -> np.ndarray:
    """Which values of ``x`` lie in the failure region ``region`` (its text), bool (n,)."""
    x = np.asarray(x, float)
    inside = np.zeros(x.size, bool)
    for lo, hi in parse_region(region)[1]:
        inside |= (x >= lo) & (x <= hi)
    return inside
