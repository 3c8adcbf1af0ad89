"""Intervals of a rare-event estimate: subset simulation's coefficient of variation, the
log-normal interval built on it, and the exact binomial intervals and bounds of plain Monte
Carlo.

Subset simulation
-----------------
Level ``j`` of a subset simulation holds ``N`` samples: ``n_c`` Markov chains of ``n_s`` states
each (``N = n_c n_s``; level 0 is ``N`` independent draws, ``n_s = 1``).  The fraction ``p_j`` of
them inside the next region (or, at the last level, inside the failure region) estimates the
level's conditional probability with the squared coefficient of variation of Au & Beck (2001)
(also Papaioannou et al., 2015, whose notation this follows):

    delta_j^2 = (1 - p_j) / (N p_j) * (1 + gamma_j),
    gamma_j   = 2 sum_{k=1}^{n_s - 1} (1 - k / n_s) rho_j(k),

where ``rho_j(k) = R_j(k) / R_j(0)`` is the lag-``k`` autocorrelation of the region's indicator
along the chains, estimated from all chains at once:
``R_j(k) = 1 / (N - k n_c) sum_chains sum_{l < n_s - k} I_l I_{l+k} - p_j^2``.  ``gamma_j`` is
the price of the chains' correlation (0 for independent samples).  The estimate
``P = prod_j p_j`` then has ``delta^2 = sum_j delta_j^2`` when the level estimates are taken as
uncorrelated (the formula implementations usually report), and at most
``delta = sum_j delta_j`` when they are fully correlated (the bound of the same section).

Which one the estimators report was decided by measurement (``benchmarks/rare_event.py``,
``docs/rare_events.md``): the levels *are* correlated (a level's seeds are the previous level's
states, its threshold is set from them), and 95 % intervals on the uncorrelated formula covered
the truth of the linear limit states in only 86-94 % of 200 repetitions (the further the
failure, the less), while the fully correlated bound covered it in 99-100 %.  The reported
``cov`` and the interval use the bound (conservative, honest); the uncorrelated figure is kept
beside it for reference.

The interval is log-normal: ``P`` is a product of level estimates, its logarithm a sum, so
``ln P`` is the near-normal quantity, with ``sigma_ln^2 = ln(1 + delta^2)``; the interval
``P exp(+- z sigma_ln)`` never crosses 0, which a normal interval ``P (1 +- z delta)`` does as soon
as ``delta > 1/z``.

Plain Monte Carlo
-----------------
``k`` failures in ``n`` independent runs: the exact (Clopper & Pearson, 1934) interval, and for
``k = 0`` the exact one-sided bound ``1 - alpha^(1/n)`` (about ``3/n`` at 95 %, the "rule of
three").  These are the formulas of :mod:`rcsim.analysis.results.proportions` (the results
layer, which this engine package may not import); ``tests`` check that both agree.

References
----------
Au, S.-K. and Beck, J. L. (2001), "Estimation of small failure probabilities in high dimensions
by subset simulation", Probabilistic Engineering Mechanics 16(4), 263-277.
Clopper, C. J. and Pearson, E. S. (1934), Biometrika 26(4).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

#: Confidence of every interval the estimators report unless told otherwise.
CONFIDENCE = 0.95


def chain_gamma(indicator: np.ndarray) -> float:
    """Au & Beck's correlation factor ``gamma`` of an indicator along Markov chains.

    Parameters
    ----------
    indicator : ndarray of bool, (n_s, n_c)
        Row ``l`` is the ``l``-th state of every chain (row 0 their seeds).

    Returns
    -------
    float
        ``2 sum_{k=1}^{n_s-1} (1 - k/n_s) rho(k)``; 0 for one state per chain, or when the
        indicator is constant (all in or all out: no variance to correlate).
    """
    ind = np.asarray(indicator, dtype=float)
    n_s, n_c = ind.shape
    p = float(ind.mean())
    r0 = p * (1.0 - p)
    if n_s < 2 or r0 <= 0.0:
        return 0.0
    gamma = 0.0
    for k in range(1, n_s):
        # All chains at once: pairs (l, l + k) within each chain, N - k n_c of them.
        r_k = float(np.sum(ind[:-k] * ind[k:])) / ((n_s - k) * n_c) - p * p
        gamma += 2.0 * (1.0 - k / n_s) * r_k / r0
    return gamma


def level_cov2(p: float, n: int, gamma: float) -> float:
    """``delta_j^2 = (1 - p) / (n p) (1 + gamma)`` of a level's fraction ``p`` of ``n`` samples
    (inf when ``p = 0``: the level saw nothing)."""
    if p <= 0.0:
        return math.inf
    return (1.0 - p) / (n * p) * (1.0 + max(gamma, 0.0))


def combined_cov(level_cov2s, correlated: bool = False) -> float:
    """Coefficient of variation of a product of level estimates: ``sqrt(sum delta_j^2)``
    (levels uncorrelated, Au & Beck's usual formula) or ``sum delta_j`` (fully correlated: the upper
    bound)."""
    values = np.asarray(list(level_cov2s), dtype=float)
    if correlated:
        return float(np.sum(np.sqrt(values)))
    return float(math.sqrt(float(np.sum(values))))


def _z(confidence: float) -> float:
    return float(stats.norm.ppf(0.5 + confidence / 2.0))


def lognormal_interval(p: float, cov: float, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Two-sided interval ``p exp(+- z sigma_ln)``, ``sigma_ln^2 = ln(1 + cov^2)`` (module
    docstring), clipped to [0, 1]."""
    s = math.sqrt(math.log1p(cov * cov))
    z = _z(confidence)
    return p * math.exp(-z * s), min(1.0, p * math.exp(z * s))


def lognormal_upper(p: float, cov: float, confidence: float) -> float:
    """One-sided upper bound ``p exp(z_conf sigma_ln)`` of the same log-normal model."""
    s = math.sqrt(math.log1p(cov * cov))
    return min(1.0, p * math.exp(float(stats.norm.ppf(confidence)) * s))


def clopper_pearson(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """Exact two-sided interval of a binomial probability, ``k`` failures in ``n`` runs."""
    if not 0 <= k <= n or n <= 0:
        raise ValueError(f"need 0 <= k <= n and n > 0, got k={k}, n={n}")
    a = 1.0 - confidence
    lo = 0.0 if k == 0 else float(stats.beta.ppf(a / 2.0, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(1.0 - a / 2.0, k + 1, n - k))
    return lo, hi


def zero_failure_bound(n_effective: float, confidence: float = CONFIDENCE) -> float:
    """Exact one-sided upper bound of a probability after 0 failures in ``n_effective``
    independent runs: ``1 - (1 - confidence)^(1 / n)`` (about ``3 / n`` at 95 %)."""
    if n_effective <= 0:
        return 1.0
    return -math.expm1(math.log1p(-confidence) / n_effective)


def plain_mc_runs(p: float, cov: float) -> float:
    """Runs plain Monte Carlo needs to estimate ``p`` at coefficient of variation ``cov``:
    ``(1 - p) / (p cov^2)`` (the binomial variance ``p (1 - p) / n`` over ``p^2``)."""
    return (1.0 - p) / (p * cov * cov)
