"""Binomial intervals, runs to a bound and the exact McNemar test, against closed forms.

Oracles: for zero failures the exact bounds have closed forms (Clopper-Pearson:
``1 - (alpha/2)^(1/n)``; one-sided: ``1 - alpha^(1/n)``; the runs that bound ``p`` below
``p_max``: ``ceil(ln alpha / ln(1 - p_max))``, the rule of three's exact form); Wilson's upper
bound at ``k = 0`` is ``z^2 / (n + z^2)``; McNemar's exact p-value at ``b = 0`` is ``2 / 2^c``.
Coverage is computed exactly (sum of binomial probabilities), not sampled.
"""

import numpy as np
import pytest
from scipy import stats

from rcsim.analysis.results.proportions import (
    clopper_pearson,
    holm,
    mcnemar_exact,
    mcnemar_one_sided,
    runs_to_bound,
    upper_bound,
    wilson,
)


@pytest.mark.parametrize("n", [1, 10, 100, 26000])
def test_zero_and_all_failures_have_closed_forms(n):
    lo, hi = clopper_pearson(0, n)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / n), rel=1e-10)
    lo, hi = clopper_pearson(n, n)
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / n), rel=1e-10)
    assert upper_bound(0, n) == pytest.approx(1 - 0.05 ** (1 / n), rel=1e-10)
    z2 = stats.norm.ppf(0.975) ** 2
    assert wilson(0, n)[1] == pytest.approx(z2 / (n + z2), rel=1e-12)


def test_clopper_pearson_covers_at_least_the_nominal_level():
    # Exact coverage at n = 50 over a grid of true probabilities: sum of P(k) over the k whose
    # interval contains p.  The exact interval never undercovers (up to float round-off).
    n = 50
    k = np.arange(n + 1)
    lo, hi = clopper_pearson(k, n)
    for p in np.linspace(0.001, 0.999, 199):
        covered = (lo <= p) & (p <= hi)
        assert stats.binom.pmf(k[covered], n, p).sum() >= 0.95 - 1e-12


def test_intervals_are_vectorised_and_ordered():
    k, n = np.array([0, 3, 50]), np.array([100, 100, 50])
    for lo, hi in (clopper_pearson(k, n), wilson(k, n)):
        assert lo.shape == (3,) and np.all(lo <= k / n) and np.all(k / n <= hi)
    with pytest.raises(ValueError):
        clopper_pearson(5, 3)


def test_runs_to_bound_zero_failures_is_the_rule_of_three():
    assert runs_to_bound(0, 100, 0.01) == np.ceil(np.log(0.05) / np.log(0.99))  # 299
    assert runs_to_bound(0, 1, 0.001) == pytest.approx(2995, abs=1)


def test_runs_to_bound_is_the_smallest_that_works():
    # 2 failures in 1000 runs (0.2 %): bound below 1 %.  N works, N - 1 does not.
    need = int(runs_to_bound(2, 1000, 0.01))
    rate = 2 / 1000
    assert upper_bound(round(need * rate), need) < 0.01
    assert upper_bound(round((need - 1) * rate), need - 1) >= 0.01
    assert np.isinf(runs_to_bound(20, 100, 0.1))  # observed 20 % cannot be bounded under 10 %


@pytest.mark.parametrize("k, n", [(1, 200), (3, 1000), (9, 1000), (1, 150), (13, 5200), (0, 200)])
def test_runs_to_bound_is_the_smallest_on_the_sawtooth(k, n):
    """Issue 38: ``N -> upper_bound(round(N k / n), N)`` is a sawtooth (it jumps up when the
    rounded count gains a failure), and a bisection over it returned 1,182 runs for 1 failure
    in 200 where 1,049 already bound it below 1 %.  Oracle: a scan of every N up to 40,000."""
    N = np.arange(1, 40_001)
    ub = upper_bound(np.round(N * (k / n)), N)
    assert int(runs_to_bound(k, n, 0.01)) == int(N[np.flatnonzero(ub < 0.01)[0]])


def test_mcnemar_exact_closed_forms():
    assert mcnemar_exact(0, 6) == pytest.approx(2 / 2**6)
    assert mcnemar_exact(6, 0) == pytest.approx(2 / 2**6)
    assert mcnemar_exact(1, 1) == 1.0 and mcnemar_exact(0, 0) == 1.0
    np.testing.assert_allclose(
        mcnemar_exact([0, 2], [5, 9]), [2 / 32, 2 * stats.binom.cdf(2, 11, 0.5)]
    )


def test_mcnemar_one_sided_is_the_binomial_upper_tail_of_the_discordant_runs():
    """``p = P(X >= b)``, ``X ~ Binomial(b + c, 1/2)`` (McNemar 1947, exact conditional form):
    against scipy's exact binomial test on the same counts, and its closed form at ``c = 0``
    (``2^-b``: one failure removed in 200 runs is p = 0.5, nowhere near significant)."""
    for b, c in [(1, 0), (0, 1), (5, 0), (8, 0), (18, 0), (7, 3), (12, 5), (3, 9), (30, 2)]:
        expected = stats.binomtest(b, b + c, 0.5, alternative="greater").pvalue
        assert mcnemar_one_sided(b, c) == pytest.approx(expected, rel=1e-12), (b, c)
    assert mcnemar_one_sided(1, 0) == pytest.approx(0.5)
    assert mcnemar_one_sided(5, 0) == pytest.approx(1 / 32)  # the fewest discordant runs < 0.05
    assert mcnemar_one_sided(4, 0) > 0.05
    assert mcnemar_one_sided(0, 0) == 1.0 and mcnemar_one_sided(0, 4) == 1.0


def test_holm_steps_down_and_stops_at_the_first_failure():
    # m = 4: levels 0.0125, 0.01667, 0.025, 0.05 for the sorted p-values.
    assert holm([0.01, 0.04, 0.02, 0.005], 0.05).tolist() == [True, True, True, True]
    assert holm([0.01, 0.04, 0.03, 0.005], 0.05).tolist() == [True, False, False, True]
    assert holm([0.01, 0.04, 0.03, 0.02], 0.05).tolist() == [True, False, False, False]
    assert holm([0.013, 0.001, 0.5], 0.05).tolist() == [True, True, False]
    assert holm([], 0.05).tolist() == []
