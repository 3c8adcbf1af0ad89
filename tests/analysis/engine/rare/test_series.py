"""A failure with several criteria as a series system (rcsim.analysis.engine.rare.series).

Oracles: the analytic union of half-spaces in independent coordinates,
``P = 1 - prod_i (1 - Phi(-beta_i))`` (limit_states.CriteriaLimitState); the series-system
bounds ``max_i P_i <= P(union) <= sum_i P_i`` and Bonferroni's inequality (a union of 2k
one-sided misses of probability alpha / (2k) each has probability at most alpha), recomputed
here from the criteria's own intervals; the identity ``1_F = sum_i 1_{F_i} / m`` (m the
criteria failed) for the joint estimate's weights; repeated_subset_simulation itself for one
criterion (bit for bit); the binomial law of a coverage count, as in test_repeats.py.  Every
estimation is seeded, so every test here is deterministic.
"""

import math

import numpy as np
import pytest
from scipy import stats

from rcsim.analysis.engine.rare import SubsetConfig, limit_states, repeated_subset_simulation
from rcsim.analysis.engine.rare.result import RareEventResult
from rcsim.analysis.engine.rare.series import (
    CRITERION_STRIDE,
    combine_series,
    flight_ids,
    series_budget,
    series_subset_simulation,
    union_probability,
)

#: As test_repeats.py: a calibrated 95 % interval covers fewer than 90 of 100 times with
#: probability binom.cdf(89, 100, 0.95) = 1.1 %.
MIN_COVERED = 90
FAR = limit_states.far_criterion(10)


def _part(status, p=None, lo=None, hi=None, bound=None, confidence=0.975):
    return RareEventResult(
        method="subset simulation",
        status=status,
        probability=p,
        cov=None if p is None else 0.3,
        interval=None if lo is None else (lo, hi),
        upper_bound=bound,
        confidence=confidence,
        n_evaluations=100,
        levels=[],
        closest_failure=None,
        failures_u=np.empty((0, 2)),
        failures_margin=np.empty(0),
        failures_id=np.empty(0, np.int64),
    )


def test_the_analytic_truth_is_the_union_of_independent_half_spaces():
    # Phi(-10) = 7.62e-24 and Phi(-4.5) = 3.398e-6 (scipy.stats.norm.sf); the issue's truth
    # 3.4e-6 (72 in 2e7 plain draws).
    p1, p2 = stats.norm.sf(10.0), stats.norm.sf(4.5)
    assert FAR.probability == pytest.approx(1 - (1 - p1) * (1 - p2), rel=1e-12)
    assert FAR.probability == pytest.approx(3.3977e-6, rel=1e-4)
    assert union_probability([0.5, 0.5]) == pytest.approx(0.75, rel=1e-15)
    u = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 4.5], [11.0, 5.0]])
    u = np.hstack([u, np.zeros((4, 8))])
    # g_1 = 0.3 (1 - u_1 / 10), g_2 = 1 - u_2 / 4.5, by hand:
    np.testing.assert_allclose(
        FAR.margins(u), [[0.3, 1.0], [0.0, 1.0], [0.3, 0.0], [-0.03, 1 - 5 / 4.5]], atol=1e-15
    )
    np.testing.assert_allclose(FAR(u), [0.3, 0.0, 0.0, 1 - 5 / 4.5], atol=1e-15)


def test_the_issue_s_case_is_explored_and_covered():
    # The issue's call on one margin (seed 3, K = 4, N = 500, 20,000 evaluations) says "not
    # resolved ... P < 4.23e-11"; as a series system the second criterion is estimated on its
    # own margin and the interval holds the truth.
    config = SubsetConfig(n_per_level=500, max_evaluations=20_000)
    single = repeated_subset_simulation(FAR, 10, config, 4, seed=3)
    assert single.status == "not_resolved" and single.upper_bound < 1e-10
    assert "several criteria" in single.reason  # the single margin's bound says its premise
    res = series_subset_simulation(FAR.margins, 10, config, 4, seed=3, names=FAR.names)
    assert res.status == "partial"  # c0 (10 sigma) saw no failure: a bound only
    assert res.criteria[0].status == "not_resolved" and res.criteria[1].probability > 0
    lo, hi = res.interval
    assert lo <= FAR.probability <= hi
    assert res.n_evaluations <= 20_000
    # The rule, recomputed from the criteria's own figures.
    assert lo == res.criteria[1].interval[0]
    assert hi == pytest.approx(res.criteria[1].interval[1] + res.criteria[0].upper_bound)
    assert res.criterion_confidence == pytest.approx(0.975)
    text = res.summary()
    assert f"{lo:.3g} - {hi:.3g}" in text and "c0: no failure seen" in text


def test_combination_rules():
    a = _part("converged", 2e-6, 1e-6, 4e-6)
    b = _part("converged", 3e-6, 2e-6, 5e-6)
    none = [np.empty((0, 2)), np.empty((0, 2))]
    res = combine_series(["a", "b"], [a, b], none, np.zeros(2), 1000)
    assert res.status == "converged"
    assert res.interval == (2e-6, pytest.approx(9e-6))
    # No failure samples recorded: each weight defaults to 1 (the sum, the upper bound).
    assert res.probability == pytest.approx(5e-6)
    # Weights E[1/m | F_i]: a's 4 failure samples fail b too in 2 of them -> (1 + 1 + 1/2 +
    # 1/2) / 4 = 0.75; b's 2 samples fail a in both -> 0.5.
    fa = np.array([[-1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [-1.0, -1.0]])
    fb = np.array([[-1.0, -1.0], [-1.0, -1.0]])
    res = combine_series(["a", "b"], [a, b], [fa, fb], np.array([4, 4]), 1000)
    assert res.weights == (0.75, 0.5)
    assert res.probability == pytest.approx(2e-6 * 0.75 + 3e-6 * 0.5)
    # A criterion with a bound only: its bound enters the upper end, nothing the lower.
    c = _part("not_resolved", bound=1e-7)
    res = combine_series(["a", "c"], [a, c], none, np.zeros(2), 1000)
    assert res.status == "partial" and res.interval == (1e-6, pytest.approx(4.1e-6))
    # Every criterion bounded: the sum of the bounds, no interval.
    res = combine_series(["c", "d"], [c, _part("not_resolved", bound=2e-7)], none, [0, 0], 10)
    assert res.status == "not_resolved" and res.upper_bound == pytest.approx(3e-7)
    assert res.interval is None and "P < 3e-07" in res.summary()
    # Bounded by its own chains, but failed on the other criterion's points: not explored.
    res = combine_series(["a", "c"], [a, c], none, np.array([5, 3]), 1000, resolve="more N")
    assert res.status == "not_explored" and res.unexplored == ("c",)
    assert res.interval is None and res.upper_bound is None and res.probability is None
    text = res.summary()
    assert "'c'" in text and "3 of the points" in text and "more N" in text
    assert "P <" not in text and "P =" not in text and "e-0" not in text


def test_bonferroni_coverage_of_the_rule_on_exact_intervals():
    # Two criteria whose own intervals at 97.5 % are exact (each misses below and above with
    # 1.25 % each, independently drawn): the combined interval must cover P(union) in at
    # least 95 % of draws (Bonferroni).  P_1 = 1e-5, P_2 = 3e-5, disjoint regions (P(union) =
    # their sum, the hardest case for the upper end).  20,000 draws: the count's standard
    # error at 95 % is 0.15 points.
    rng = np.random.default_rng(7)
    p = np.array([1e-5, 3e-5])
    n = 20_000
    # An interval (lo, hi) = (P e^{-z s + e}, P e^{z s + e}) with e ~ N(0, s^2): exact.
    s, z = 0.4, stats.norm.ppf(1 - 0.025 / 2)
    e = rng.normal(0, s, (n, 2))
    lo, hi = p * np.exp(e - z * s), p * np.exp(e + z * s)
    covered = (lo.max(axis=1) <= p.sum()) & (p.sum() <= hi.sum(axis=1))
    assert covered.mean() >= 0.95


def test_level_zero_is_flown_once_and_every_flight_once():
    seen = []

    def g(u, ids):
        seen.append(np.asarray(ids).copy())
        return FAR.margins(u)

    config = SubsetConfig(n_per_level=200, max_evaluations=4000)
    res = series_subset_simulation(g, 10, config, 2, seed=1, names=FAR.names)
    ids = np.concatenate(seen)
    assert ids.size == np.unique(ids).size == res.n_evaluations
    # Level 0 of both repeats once (2 x 200), then each criterion's chains under its offset.
    level0 = ids[(ids % 2**27) < 200]
    assert level0.size == 400
    chains = ids[(ids % 2**27) >= 200]
    assert set(((chains % 2**27) // CRITERION_STRIDE).tolist()) == {0, 1}
    assert res.n_evaluations <= 4000
    # Budget: level 0 once, the rest split over 2 criteria x 2 repeats.
    assert series_budget(4000, 200, 2, 2) == 200 + (4000 - 400) // 4
    np.testing.assert_array_equal(
        flight_ids(np.array([5, 250, 2**27 + 5, 2**27 + 250]), 1, 200),
        [5, 250 + CRITERION_STRIDE, 2**27 + 5, 2**27 + 250 + CRITERION_STRIDE],
    )


def test_one_criterion_is_the_repeated_estimator_bit_for_bit():
    limit = limit_states.linear(10, 1e-4)
    config = SubsetConfig(n_per_level=200, max_evaluations=6000)
    plain = repeated_subset_simulation(limit, 10, config, 3, seed=5)
    res = series_subset_simulation(
        lambda u, ids: limit(u)[:, None], 10, config, 3, seed=5, names=["only"]
    )
    assert res.criteria[0].probability == plain.probability
    assert res.criteria[0].interval == plain.interval
    assert res.interval == plain.interval


def test_a_criterion_its_chains_cannot_follow_is_reported_not_explored():
    # Criterion "step" is a step in u_2 (fails beyond 3.5 sigma: 2.3e-4), like propellant
    # exhaustion: its own chains cannot descend a flat margin, and level 0 (2 x 200 points)
    # happens to see no failure (seed 0); criterion "ramp" = 1 - u_2 / 4 drives its chains
    # past 3.5 sigma, where "step" fails.  A bound on "step" from its own level 0 alone would
    # be 1 - 0.0125^(1/200) = 2.2e-2, valid as plain Monte Carlo but the region was found
    # elsewhere: the result must state neither bound nor interval, and name the criterion.
    def g(u, ids):
        step = np.where(u[:, 1] > 3.5, -1.0, 1.0)
        return np.stack([1.0 - u[:, 1] / 4.0, step], axis=1)

    config = SubsetConfig(n_per_level=200, max_evaluations=6000)
    res = series_subset_simulation(g, 4, config, 2, seed=0, names=["ramp", "step"])
    assert res.criteria[1].status == "not_resolved"
    assert res.found_elsewhere[1] > 0
    assert res.status == "not_explored" and res.unexplored == ("step",)
    assert res.interval is None and res.upper_bound is None
    text = res.summary()
    assert "'step'" in text and "more runs per level than 200" in text
    assert "P <" not in text and "P =" not in text


def test_a_margin_of_the_wrong_shape_is_refused():
    config = SubsetConfig(n_per_level=100)
    with pytest.raises(ValueError, match="shape"):
        series_subset_simulation(lambda u, ids: FAR(u), 10, config, 1, seed=0, names=FAR.names)


def _coverage(limit, budget, reps=100):
    config = SubsetConfig(n_per_level=500, max_evaluations=budget)
    covered, estimates = 0, []
    for seed in range(reps):
        res = series_subset_simulation(
            limit.margins, limit.dim, config, 4, seed=seed, names=limit.names
        )
        assert res.status in ("converged", "budget", "partial"), res.summary()
        lo, hi = res.interval
        covered += lo <= limit.probability <= hi
        estimates.append(res.probability)
    return covered, np.array(estimates)


def test_series_intervals_cover_the_far_criterion():
    # The issue's state and settings (K = 4, N = 500, 20,000 evaluations), seeds 0-99 as
    # benchmarks/rare_event_series.py --budget 20000: on one margin 34 of 100 statements hold
    # the truth; as a series system 100 of 100 (docs/rare_events.md).
    covered, est = _coverage(FAR, 20_000)
    assert covered >= MIN_COVERED
    # The joint estimate: P_2 alone here (c0 is 2e-18 of it); subset simulation at N = 500 is
    # biased by up to 10 % (test_repeats.py); the bound guards against gross errors (a
    # criterion lost: 0; both summed twice: 2x).
    assert 0.8 < est.mean() / FAR.probability < 1.25


@pytest.mark.slow
def test_series_intervals_cover_two_criteria_within_reach():
    # Both criteria fail within reach (1.0e-6 and 1.0e-5, d = 86), the rarer one closer at
    # nominal; 30,000 evaluations (the 1e-6 criterion needs seven levels).  Measured: 100 of
    # 100 (docs/rare_events.md); one margin covered 21 of 100.
    limit = limit_states.two_criteria(86)
    assert limit.probability == pytest.approx(union_probability(limit.probabilities))
    covered, est = _coverage(limit, 30_000)
    assert covered >= MIN_COVERED
    assert 0.8 < est.mean() / limit.probability < 1.25
    assert math.isfinite(est.sum())
