"""The intervals of rare-event estimates (rcsim.analysis.engine.rare.intervals).

Oracles: Au & Beck's (2001) CoV formulas written out by hand for small cases; the exact
binomial formulas of rcsim.analysis.results.proportions (the results layer's, which the engine
package may not import, so it keeps its own copy: the two must agree).
"""

import math

import numpy as np
import pytest

from rcsim.analysis.engine.rare import intervals
from rcsim.analysis.results import proportions


def test_gamma_of_chains_that_never_move_is_chain_length_minus_one():
    # A chain that repeats its seed has rho(k) = 1 for every lag, so
    # gamma = 2 sum_{k=1}^{n_s-1} (1 - k/n_s) = n_s - 1 exactly (the definition of gamma).
    seeds = np.array([True, False, False, True, False, True, False, False, False, False])
    ind = np.tile(seeds, (10, 1))  # (n_s, n_c): every state equals its chain's seed
    assert intervals.chain_gamma(ind) == pytest.approx(9.0, rel=1e-12)


def test_gamma_written_out_for_a_small_chain_set():
    # Two chains of three states, hand-computed from the definition of R(k): p = 3/6,
    # R(1) = (I0 I1 + I1 I2 summed over chains) / 4 - p^2 = (1 + 1) / 4 - 1/4 = 1/4,
    # R(2) = (I0 I2 summed) / 2 - p^2 = 1/2 - 1/4 = 1/4, R(0) = 1/4:
    # gamma = 2 (2/3 * 1 + 1/3 * 1) = 2.
    ind = np.array([[1, 0], [1, 0], [1, 0]], dtype=bool)
    assert intervals.chain_gamma(ind) == pytest.approx(2.0, rel=1e-12)
    # Alternating states: R(1) = 0/4 - 1/4, R(2) = (I0 I2 = 1 for chain 0) / 2 - 1/4 = 1/4:
    # gamma = 2 (2/3 (-1) + 1/3 (1)) = -2/3.
    alt = np.array([[1, 0], [0, 1], [1, 0]], dtype=bool)
    assert intervals.chain_gamma(alt) == pytest.approx(-2.0 / 3.0, rel=1e-12)


def test_gamma_is_zero_without_chains_or_without_variance():
    assert intervals.chain_gamma(np.array([[True, False, True]])) == 0.0
    assert intervals.chain_gamma(np.ones((10, 5), bool)) == 0.0


def test_gamma_of_independent_states_is_near_zero():
    # Independent Bernoulli(0.1) states: gamma's expectation is 0; its sampling spread with
    # 100 chains of 10 is about 0.13 (measured: sd 0.13, mean -0.01 over 1000 draws), so
    # |gamma| < 0.5 is nearly four spreads.
    rng = np.random.default_rng(np.random.SeedSequence(7))
    ind = rng.random((10, 100)) < 0.1
    assert abs(intervals.chain_gamma(ind)) < 0.5


def test_level_and_combined_cov_are_au_and_becks_formulas():
    assert intervals.level_cov2(0.1, 1000, 0.0) == pytest.approx(0.9 / 100.0, rel=1e-15)
    assert intervals.level_cov2(0.1, 1000, 2.0) == pytest.approx(3 * 0.9 / 100.0, rel=1e-15)
    assert intervals.level_cov2(0.0, 1000, 0.0) == math.inf
    assert intervals.combined_cov([0.04, 0.09]) == pytest.approx(math.sqrt(0.13), rel=1e-15)
    assert intervals.combined_cov([0.04, 0.09], correlated=True) == pytest.approx(0.5)


def test_lognormal_interval_is_symmetric_in_log_and_has_the_normal_quantile():
    lo, hi = intervals.lognormal_interval(1e-5, 0.3)
    s = math.sqrt(math.log(1 + 0.09))
    assert math.log(hi / 1e-5) == pytest.approx(1.959964 * s, rel=1e-6)
    assert math.log(1e-5 / lo) == pytest.approx(1.959964 * s, rel=1e-6)
    assert intervals.lognormal_upper(1e-5, 0.3, 0.975) == pytest.approx(hi, rel=1e-12)


@pytest.mark.parametrize("k, n", [(0, 10), (3, 1000), (999, 1000), (1000, 1000), (50, 100)])
def test_exact_intervals_agree_with_the_results_layer(k, n):
    lo, hi = proportions.clopper_pearson(k, n)
    assert intervals.clopper_pearson(k, n) == pytest.approx((float(lo), float(hi)), rel=1e-12)


@pytest.mark.parametrize("n", [30, 1000, 30000])
def test_zero_failure_bound_is_the_results_layers_and_about_three_over_n(n):
    bound = intervals.zero_failure_bound(n)
    assert bound == pytest.approx(float(proportions.upper_bound(0, n)), rel=1e-10)
    # Rule of three: -ln(0.05) / n = 2.996 / n to first order in 1/n.
    assert bound == pytest.approx(2.995732 / n, rel=2.0 / n)


def test_plain_mc_runs_at_a_cov():
    # (1 - p) / (p cov^2): P = 1e-5 at CoV 0.3 needs 1.11e6 runs (the "~10^6").
    assert intervals.plain_mc_runs(1e-5, 0.3) == pytest.approx((1 - 1e-5) / 9e-7, rel=1e-12)
