"""Every flag `rcsim analyze` raises is calibrated: null tables, and planted truth with cases.

Oracle: synthetic campaigns with rate cases whose mechanism is known by construction
(:func:`rcsim.analysis.results.drivers.synthetic.stratified_campaign`), analysed by the real
pipeline (:func:`~rcsim.analysis.results.drivers.pipeline.analyze`).  Small tables (26 cases x 100
runs, 30 noise inputs, 50 permutations for inputs and 25 for pairs) keep the module under a
minute; the full-size check (26 x 1,000 runs, 100 inputs, default permutations) is
``benchmarks/null_calibration.py`` and its figures are in docs/drivers.md.

Bounds.  Each flag family (singles, pairs, per case) is meant to have a family-wise error of
at most alpha = 0.05 per table.  With ``n`` independent tables the number of tables with a
false flag is then at most Binomial(n, 0.05); the tests assert it is at most that
distribution's 0.99 quantile (``binom.ppf(0.99, n, 0.05)``: 5 of 30, 4 of 20, 2 of 6, 1 of 4).  A
correct test fails this with probability <= 1 %; the seeds are fixed, so the outcome is
deterministic -- the probability says how tight the bound is, not how often it flakes.  The
old tests, on the real campaign's measure (25 % of null tables with a "significant" pair,
every pair holding a driver significant), fail it at once.
"""

import pytest
from scipy.stats import binom

from rcsim.analysis.results.drivers.synthetic import calibration, calibration_settings

ALPHA = 0.05
SMALL = {"runs_per_case": 100, "n_noise": 30}
SETTINGS = calibration_settings(n_permutations=50)  # pairs: 25 (smallest p 1/26 < 0.05)


def bound(n: int) -> int:
    """Most tables with a false flag that a family-wise level of ALPHA allows (0.99 quantile)."""
    return int(binom.ppf(0.99, n, ALPHA))


def test_null_tables_raise_false_flags_at_most_at_alpha():
    # Pure null: failures at random (5 %) in every case, every input noise.
    r = calibration("null", range(30), SETTINGS, **SMALL)
    assert r["tables"] == 30
    for family in ("false_single", "false_pair", "false_case"):
        assert r[family] <= bound(30), (family, r)


def test_a_strong_single_driver_makes_no_interaction():
    # One strong driver in every case: every pair holding it differs between failed and
    # successful runs (the old pair test called them all significant), none adds to it.
    r = calibration("single", range(20), SETTINGS, **SMALL)
    assert r["true_singles"] >= 19, r  # the driver itself is found (power, not a rate bound)
    assert r["false_pair"] <= bound(20), r
    assert r["false_single"] <= bound(20), r
    assert r["false_case"] <= bound(20), r


def test_two_drivers_in_two_cases_are_found_per_case_and_are_no_interaction():
    # a fails case-05, b fails case-19: both are per-case drivers (family-wise over every case
    # and input), and the pair (a, b) -- jointly significant pooled -- is no interaction.
    r = calibration("two-cases", range(4), SETTINGS, runs_per_case=200, n_noise=30)
    assert r["true_case"] >= 3, r  # power: 4 of 4 measured (every planted case driver)
    assert r["false_pair"] <= bound(4), r
    assert r["false_case"] <= bound(4), r


@pytest.mark.parametrize("scenario", ["pair", "ratio-band"])
def test_planted_interactions_are_found_as_interactions(scenario):
    # Pure pair (failures when exactly one input is high) and a narrow band of the ratio a/b:
    # no product of an a-effect and a b-effect within a case; both must be interactions.
    r = calibration(scenario, range(6), SETTINGS, **SMALL)
    assert r["true_interaction"] >= 5, r  # power: 6 of 6 measured at these seeds
    assert r["interaction_first"] >= 5, r
    assert r["false_pair"] <= bound(6), r


def test_bh_qvalues_by_hand():
    import numpy as np

    from rcsim.analysis.results.drivers.pipeline import bh_qvalues

    # p sorted 0.01, 0.02, 0.03, 0.5 (m = 4): p * m / rank = 0.04, 0.04, 0.04, 0.5, then the
    # running minimum from the top; returned in the input order.
    q = bh_qvalues([0.5, 0.01, 0.03, 0.02])
    np.testing.assert_allclose(q, [0.5, 0.04, 0.04, 0.04])


def test_conditional_null_is_a_distribution_on_the_tables_with_these_margins():
    import numpy as np
    from scipy.special import gammaln

    from rcsim.analysis.results.drivers.interaction import conditional_null

    # One 2x2x2 table: runs n[a, b], failures f[a, b].  Oracle: enumerate x = f[1, 1] with the
    # three two-way margins fixed and weight each table by 1 / prod(cell!).
    n = np.array([[[[30.0, 20.0], [25.0, 25.0]]]])
    f = np.array([[[[3.0, 4.0], [2.0, 6.0]]]])
    lo, prob = conditional_null(n, f)
    fr1, fc1, ft = 8.0, 10.0, 15.0
    w = {}
    for x in range(0, 11):
        cells = [x, fr1 - x, fc1 - x, ft - fr1 - fc1 + x]
        runs = [25, 25, 20, 30]  # n11, n10, n01, n00
        if min(cells) < 0 or any(c > r for c, r in zip(cells, runs)):
            continue
        others = [r - c for c, r in zip(cells, runs)]
        w[x] = np.exp(-sum(gammaln(np.array(cells + others, float) + 1)))
    total = sum(w.values())
    got = {int(lo[0, 0]) + g: p for g, p in enumerate(prob[0, 0]) if p > 0}
    assert set(got) == set(w)
    for x in w:
        assert abs(got[x] - w[x] / total) < 1e-12


def test_sum_distribution_is_the_convolution_of_the_cases():
    import numpy as np

    from rcsim.analysis.results.drivers.interaction import sum_distribution

    # Oracle: the distribution of a sum of independent variables is the convolution of their
    # distributions (np.convolve, case after case).  FFT round-off: ~1e-16 of the largest mass,
    # so 1e-12 absolute is generous.  A tiny memory budget forces one pair per transform.
    rng = np.random.default_rng(5)
    prob = rng.random((7, 4, 6))
    prob[:, :, 4:] *= rng.random((7, 4, 2)) < 0.5  # some supports shorter than others
    prob /= prob.sum(axis=-1, keepdims=True)
    for budget in (64 << 20, 1):
        got = sum_distribution(prob, budget_bytes=budget)
        for p in range(7):
            want = np.array([1.0])
            for s in range(4):
                want = np.convolve(want, prob[p, s])
            np.testing.assert_allclose(got[p], want, atol=1e-12)
