"""Failure probabilities with their uncertainty: binomial intervals, the runs a bound needs, and
the paired test of two tables flown on the same runs.

Every probability rcsim reports carries an interval (a review board reads "0 failures in 100
runs" very differently from "0 in 10,000").  The functions here are the one place that says how:

* :func:`clopper_pearson` -- the exact (conservative) two-sided interval, used for every
  reported failure probability: its coverage is at least the nominal level for every true
  probability and every sample size, which is what a bound a board signs off needs;
* :func:`wilson` -- the score interval, shorter, for plots and quick looks;
* :func:`runs_to_bound` -- how many runs (at the observed failure rate) bound the failure
  probability below ``p_max`` at the given confidence: the zero-failure case is the classic
  "rule of three" generalised, ``n >= ln(alpha) / ln(1 - p_max)``;
* :func:`mcnemar_exact` -- the exact McNemar test of two tables flown over the *same* dispersed
  runs (common random numbers): only discordant runs carry evidence;
* :func:`mcnemar_one_sided` -- its one-sided form, "the second table is better", which the
  refinement's acceptance rule uses (:mod:`rcsim.analysis.apps.refinement.gate`);
* :func:`holm` -- Holm's step-down adjustment of several such tests (family-wise error).

All functions are vectorised over numpy arrays of counts.

References
----------
Clopper, C. J. and Pearson, E. S. (1934), "The use of confidence or fiducial limits illustrated
in the case of the binomial", Biometrika 26(4).  Wilson, E. B. (1927), "Probable inference, the
law of succession, and statistical inference", JASA 22.  McNemar, Q. (1947), "Note on the
sampling error of the difference between correlated proportions or percentages",
Psychometrika 12(2).  Hanley, J. A. and Lippman-Hand, A. (1983), "If nothing goes wrong, is
everything all right?", JAMA 249(13) (the rule of three).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

#: Confidence of every interval rcsim reports unless told otherwise.
CONFIDENCE = 0.95


def _counts(k, n) -> tuple[np.ndarray, np.ndarray]:
    k, n = np.broadcast_arrays(np.asarray(k, float), np.asarray(n, float))
    if np.any(n < 0) or np.any(k < 0) or np.any(k > n):
        raise ValueError("counts must satisfy 0 <= k <= n")
    return k, n


def clopper_pearson(k, n, confidence: float = CONFIDENCE) -> tuple[np.ndarray, np.ndarray]:
    """Exact two-sided interval ``(lo, hi)`` for a binomial probability: ``k`` of ``n`` runs.

    ``lo = Beta(alpha/2; k, n - k + 1)`` (0 when ``k = 0``) and
    ``hi = Beta(1 - alpha/2; k + 1, n - k)`` (1 when ``k = n``).  ``n = 0`` gives (0, 1).
    """
    k, n = _counts(k, n)
    a = 1.0 - confidence
    with np.errstate(invalid="ignore", divide="ignore"):
        lo = np.where(k > 0, stats.beta.ppf(a / 2, k, n - k + 1), 0.0)
        hi = np.where(k < n, stats.beta.ppf(1 - a / 2, k + 1, n - k), 1.0)
    return np.nan_to_num(lo, nan=0.0), np.nan_to_num(hi, nan=1.0)


def wilson(k, n, confidence: float = CONFIDENCE) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval ``(lo, hi)`` for ``k`` of ``n``; ``n = 0`` gives (0, 1)."""
    k, n = _counts(k, n)
    z = stats.norm.ppf(0.5 + confidence / 2)
    safe = np.maximum(n, 1.0)
    p = k / safe
    centre = (p + z * z / (2 * safe)) / (1 + z * z / safe)
    half = z * np.sqrt(p * (1 - p) / safe + z * z / (4 * safe * safe)) / (1 + z * z / safe)
    # At k = 0 (k = n) the bound is exactly 0 (1); the formula leaves an ulp of round-off.
    lo = np.where((n > 0) & (k > 0), np.clip(centre - half, 0.0, 1.0), 0.0)
    hi = np.where((n > 0) & (k < n), np.clip(centre + half, 0.0, 1.0), 1.0)
    return lo, hi


def upper_bound(k, n, confidence: float = CONFIDENCE) -> np.ndarray:
    """One-sided exact upper bound: the largest probability not rejected at ``confidence``
    by ``k`` failures in ``n`` runs (``Beta(confidence; k + 1, n - k)``; 1 when ``k = n``)."""
    k, n = _counts(k, n)
    with np.errstate(invalid="ignore"):
        hi = np.where(k < n, stats.beta.ppf(confidence, k + 1, n - k), 1.0)
    return np.nan_to_num(hi, nan=1.0)


def runs_to_bound(k, n, p_max, confidence: float = CONFIDENCE) -> np.ndarray:
    """Runs needed for the one-sided exact upper bound to fall below ``p_max``, at the failure
    rate observed (``k`` of ``n``; with ``k = 0``, no failures in any of them).

    Returns the smallest ``N`` with ``upper_bound(round(N k / n), N) < p_max``; with no failure
    observed that is ``ceil(ln(1 - confidence) / ln(1 - p_max))`` (about ``3 / p_max`` at 95 %,
    the rule of three).  ``inf`` when the observed rate itself is ``>= p_max`` (no number of
    runs at that rate bounds it below ``p_max``).
    """
    k, n = _counts(k, n)
    p_max = np.broadcast_to(np.asarray(p_max, float), k.shape)
    if np.any((p_max <= 0) | (p_max >= 1)):
        raise ValueError("p_max must be in (0, 1)")
    rate = np.divide(k, n, out=np.zeros_like(k), where=n > 0)
    out = np.full(k.shape, np.inf)
    for idx in np.ndindex(k.shape):
        r, pm = rate[idx], p_max[idx]
        if r >= pm:
            continue
        out[idx] = _smallest_n(float(r), float(pm), confidence)
    return out


def _smallest_n(r: float, pm: float, confidence: float) -> int:
    """The smallest ``N`` with ``upper_bound(round(N r), N) < pm`` (``r < pm``).

    ``N -> upper_bound(round(N r), N)`` is a sawtooth, not monotone: it jumps up each time
    ``round(N r)`` gains a failure.  Within one tooth (one failure count ``j``) the bound
    falls with ``N``, so the answer is in the first tooth whose last ``N`` is below ``pm``,
    at the first ``N`` of that tooth that is (a bisection on that tooth alone).
    """

    def bound(j, m):
        return upper_bound(j, m, confidence)

    # Some N that bounds it: the rule of three's N, doubled until the bound is below pm
    # (it tends to r < pm, so the doubling ends).
    top = max(1, int(np.ceil(np.log(1 - confidence) / np.log(1 - pm))))
    while bound(np.round(top * r), top) >= pm:
        top *= 2
    if r == 0.0:  # one tooth: j = 0 throughout
        first, last, j = 1, top, 0
    else:
        js = np.arange(int(np.round(top * r)) + 1, dtype=float)
        # Each tooth's last N (at most top): the largest N with round(N r) == j.
        last_n = np.minimum(np.floor((js + 0.5) / r), top)
        last_n -= np.round(last_n * r) > js
        last_n = np.maximum(last_n, 1)
        ok = (np.round(last_n * r) == js) & (bound(js, last_n) < pm)
        j = int(np.flatnonzero(ok)[0])
        last = int(last_n[j])
        first = max(1, int(np.ceil((j - 0.5) / r)) - 1)
        while np.round(first * r) < j:
            first += 1
    lo, hi = first, last
    while lo < hi:
        mid = (lo + hi) // 2
        if bound(j, mid) < pm:
            hi = mid
        else:
            lo = mid + 1
    return hi


def mcnemar_exact(b, c) -> np.ndarray:
    """Exact McNemar p-value (two-sided) of paired binary outcomes.

    Two tables flown over the same runs: ``b`` runs fail (or repeat) with the first table and
    not with the second, ``c`` the other way round.  Under "the tables are equally good" each
    discordant run is a fair coin, so ``min(b, c) ~ Binomial(b + c, 1/2)``; the p-value is
    ``min(1, 2 P(X <= min(b, c)))``, 1 when there is no discordant run.
    """
    b, c = np.broadcast_arrays(np.asarray(b, float), np.asarray(c, float))
    if np.any(b < 0) or np.any(c < 0):
        raise ValueError("discordant counts must be >= 0")
    m = b + c
    p = 2.0 * stats.binom.cdf(np.minimum(b, c), m, 0.5)
    return np.where(m > 0, np.minimum(p, 1.0), 1.0)


def mcnemar_one_sided(b, c) -> np.ndarray:
    """Exact one-sided McNemar p-value that the second of two paired tables is better.

    ``b`` runs are bad (fail, or fail or repeat) with the first table and good with the second,
    ``c`` the other way round.  Conditional on the ``m = b + c`` discordant runs, "no better"
    makes each a fair coin at best, so the p-value is the binomial upper tail
    ``P(X >= b) = sum_{i=b}^{m} C(m, i) / 2^m`` with ``X ~ Binomial(m, 1/2)`` (McNemar 1947,
    exact form), 1 when ``b = 0``.  Equals ``scipy.stats.binomtest(b, m, 0.5,
    alternative="greater").pvalue``.
    """
    b, c = np.broadcast_arrays(np.asarray(b, float), np.asarray(c, float))
    if np.any(b < 0) or np.any(c < 0):
        raise ValueError("discordant counts must be >= 0")
    return np.where(b > 0, stats.binom.sf(b - 1, b + c, 0.5), 1.0)


def holm_adjusted(pvalues) -> np.ndarray:
    """Holm step-down adjusted p-values (family-wise error), in the order of ``pvalues``:
    sorted ascending, ``max_{j <= i} (m - j) p_(j)``, capped at 1 (Holm 1979)."""
    p = np.asarray(pvalues, dtype=float)
    order = np.argsort(p, kind="stable")
    m = p.size
    adj = np.maximum.accumulate((m - np.arange(m)) * p[order])
    out = np.empty(m)
    out[order] = np.minimum(adj, 1.0)
    return out


def holm(pvalues, alpha: float) -> np.ndarray:
    """Holm's step-down test: which of the hypotheses with ``pvalues`` are rejected with the
    family-wise error rate held at ``alpha`` (Holm 1979, "A simple sequentially rejective
    multiple test procedure", Scand. J. Statist. 6(2)).

    Sorted ascending, ``p_(i)`` is compared with ``alpha / (m - i)`` (``i`` from 0); the first
    that exceeds its level stops the procedure, and it and every larger p-value stand: the
    rejected ones are those whose :func:`holm_adjusted` p-value is at most ``alpha``.
    """
    return holm_adjusted(pvalues) <= alpha
