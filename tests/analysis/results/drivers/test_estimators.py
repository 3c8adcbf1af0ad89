"""Estimator contract and the KDE engine's arithmetic.

Oracles: scikit-learn's estimator conventions (``__init__`` only stores, ``fit`` returns self,
learned attributes end in ``_``); exact counting identities of the binned engine; the
permutation p-value's definition.
"""

import inspect

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.results.drivers.baseline import TTestBaseline
from rcsim.analysis.results.drivers.kde import (
    COUNT_PASS_BYTES,
    BinnedTV,
    Strata,
    bin_codes,
    rank_scale,
    smoothing_matrix,
)
from rcsim.analysis.results.drivers.maps import KNNFailureMap
from rcsim.analysis.results.drivers.pairs import PairKDE
from rcsim.analysis.results.drivers.pipeline import Settings
from rcsim.analysis.results.drivers.second_opinion import ForestImportance
from rcsim.analysis.results.drivers.single import SingleFactorKDE, _format_region
from rcsim.analysis.results.drivers.stability import HalfSampleStability
from rcsim.analysis.results.drivers.synthetic import planted_campaign
from rcsim.analysis.results.proportions import holm_adjusted
from rcsim.models.errors import InputError

ESTIMATORS = [SingleFactorKDE, PairKDE, KNNFailureMap, ForestImportance, HalfSampleStability]


@pytest.mark.parametrize("cls", ESTIMATORS)
def test_init_only_stores_parameters(cls):
    est = cls()
    params = [p for p in inspect.signature(cls).parameters]
    assert sorted(vars(est)) == sorted(params)
    assert not any(k.endswith("_") for k in vars(est))


def test_fit_returns_self_and_is_reproducible():
    X, y = planted_campaign("one-sided", seed=3, n_runs=600, n_noise=4)
    a = SingleFactorKDE(n_permutations=50, random_state=7)
    assert a.fit(X, y) is a
    b = SingleFactorKDE(n_permutations=50, random_state=7).fit(X, y)
    np.testing.assert_array_equal(a.p_value_, b.p_value_)
    np.testing.assert_array_equal(a.score_, b.score_)
    p = PairKDE(n_permutations=30, random_state=7)
    assert p.fit(X, y, single_score=a.score_) is p
    assert p.pairs_.shape == (15, 2)  # 6 inputs -> 6*5/2 pairs
    m = KNNFailureMap(k_grid=(5, 20), n_grid=10)
    assert m.fit(X[["thrust", "inertia"]], y) is m
    assert m.k_ in (5, 20)
    s = HalfSampleStability(n_splits=2)
    assert s.fit(X, y, a, p) is s
    assert s.single_half_rank_.shape == (4, 6)


def test_forest_importance_does_not_depend_on_the_prediction_blocks(monkeypatch):
    # The shuffled held-out copies are predicted a block of inputs at a time to bound memory;
    # a forest predicts each row on its own and the shuffles are drawn input by input, so one
    # input per block and all inputs in one block give the same AUC drops to the last bit.
    from rcsim.analysis.results.drivers import second_opinion

    X, y = planted_campaign("one-sided", seed=5, n_runs=800, n_noise=5)
    fits = []
    for block_bytes in (1, 2**40):
        monkeypatch.setattr(second_opinion, "PREDICT_BLOCK_BYTES", block_bytes)
        fits.append(ForestImportance(n_estimators=20, random_state=3).fit(X, y))
    one, whole = fits
    assert np.isfinite(one.importance_mean_).all()
    np.testing.assert_array_equal(one.importance_mean_, whole.importance_mean_)
    np.testing.assert_array_equal(one.importance_sd_, whole.importance_sd_)
    # The planted mechanism's inputs (the first two) are the forest's two highest-ranked.
    assert set(np.flatnonzero(one.rank_ <= 2)) == {0, 1}


def test_knn_map_does_not_depend_on_the_query_blocks(monkeypatch):
    # Neighbours are queried a block of runs at a time to bound memory (the whole table was
    # ~0.5 GB at 10^5 runs); each run's neighbours are its own, so blocks of 97 runs (and a
    # short last one) give the same cross-validated k, Brier scores and map to the last bit.
    from rcsim.analysis.results.drivers import maps

    X, y = planted_campaign("two-sided", seed=2, n_runs=2000, n_noise=0)
    whole = KNNFailureMap().fit(X, y)
    monkeypatch.setattr(maps, "MAP_QUERY_ROWS", 97)
    blocks = KNNFailureMap().fit(X, y)
    assert blocks.k_ == whole.k_ and blocks.cv_brier_ == whole.cv_brier_
    assert len(whole.cv_brier_) == 6  # every k of the grid was scored
    np.testing.assert_array_equal(blocks.prob_, whole.prob_)
    np.testing.assert_array_equal(blocks.uncertainty_, whole.uncertainty_)


def test_bad_fit_input_is_a_clear_error():
    X, y = planted_campaign("null", seed=1, n_runs=100, n_noise=2)
    with pytest.raises(InputError, match="both failed and successful"):
        SingleFactorKDE().fit(X, np.zeros(100, bool))
    with pytest.raises(InputError, match="binary"):
        SingleFactorKDE().fit(X, np.arange(100))
    Xn = X.copy()
    Xn.iloc[3, 1] = np.nan
    with pytest.raises(InputError, match="'inertia'.*NaN"):
        SingleFactorKDE().fit(Xn, y)


@pytest.mark.parametrize(
    "field, value",
    [
        ("n_permutations", 18),
        ("pair_permutations", 5),
        ("n_permutations", 19.5),
        ("random_state", -1),
    ],
)
def test_settings_refuse_values_that_cannot_give_a_verdict(field, value):
    """Oracle: with B permutations the smallest p-value is 1/(B+1), so B < 19 can never reach
    p < 0.05; the error names the library's field (the CLI maps it to its flag)."""
    with pytest.raises(InputError) as err:
        Settings(**{field: value})
    assert err.value.parameter == field and err.value.value == value
    # The boundary itself is accepted.
    assert Settings(n_permutations=19, pair_permutations=19).pair_b == 19


def test_rank_scale_is_uniform_and_unit_free():
    # PIT of distinct values: exactly (k - 1/2)/n for k = 1..n, whatever the units.
    x = np.array([[3.0, 1e6], [1.0, -5.0], [2.0, 7.0]])
    np.testing.assert_allclose(rank_scale(x)[:, 0], [5 / 6, 1 / 6, 3 / 6])
    np.testing.assert_array_equal(rank_scale(x), rank_scale(x * [1.0, 1e-3] + [10, 0]))
    # Ranked a column at a time (bounded temporaries): scipy's whole-table form, ties included.
    from scipy.stats import rankdata

    t = np.random.default_rng(3).integers(0, 9, size=(500, 4)).astype(float)  # many ties
    whole = (rankdata(t, axis=0, method="average") - 0.5) / 500
    np.testing.assert_array_equal(rank_scale(t), whole)


def test_smoothing_keeps_mass_and_pair_counts_marginalise():
    K = smoothing_matrix(16, 0.07)
    np.testing.assert_allclose(K.sum(axis=0), 1.0, atol=1e-12)  # columns renormalised
    rng = np.random.default_rng(0)
    codes = bin_codes(rng.random((500, 3)), 16)
    pairs = np.array([[0, 1], [0, 2], [1, 2]])
    e2 = BinnedTV(codes, 16, pairs, h=0.05)
    e1 = BinnedTV(codes, 16, h=0.05)
    # Summing a pair's 2-D counts over b gives a's 1-D counts exactly (same bins).
    np.testing.assert_array_equal(e2.pooled[0].sum(axis=1), e1.pooled[0])
    np.testing.assert_array_equal(e2.pooled[2].sum(axis=0), e1.pooled[2])
    assert e2.pooled.sum() == 3 * 500


def test_bincount_passes_change_no_count():
    # Counts are integers: any split of the rows into passes sums to the same cells.  Pairs
    # of many inputs get passes bounded by COUNT_PASS_BYTES (a 90-input campaign's ~4,000
    # pairs held 120 MB of indices a pass at the old fixed 4096 rows).
    rng = np.random.default_rng(1)
    codes = bin_codes(rng.random((3000, 6)), 16)
    pairs = np.array([(a, b) for a in range(6) for b in range(a + 1, 6)])
    rows = rng.choice(3000, 700, replace=False)
    for p in (None, pairs):
        whole = BinnedTV(codes, 16, p, h=0.05, chunk_rows=4096)
        split = BinnedTV(codes, 16, p, h=0.05, chunk_rows=64)
        np.testing.assert_array_equal(split.pooled, whole.pooled)
        np.testing.assert_array_equal(split.counts(rows), whole.counts(rows))
    assert BinnedTV(codes, 16, pairs, h=0.05).chunk_rows == 4096  # few pairs: the old size
    many = np.array([(a, b) for a in range(90) for b in range(a + 1, 90)])
    wide = BinnedTV(bin_codes(rng.random((50, 90)), 16), 16, many, h=0.05)
    assert 64 <= wide.chunk_rows < 4096
    assert wide.chunk_rows * wide.n_tests * 4 <= COUNT_PASS_BYTES


def test_tv_of_identical_groups_is_zero_and_disjoint_is_one():
    # Inputs constructed so the oracle is exact: a column equal to the label separates
    # perfectly only after smoothing is negligible (tiny h), giving TV = 1.
    n = 400
    y = np.arange(n) < n // 2
    x = np.where(y, 0.1, 0.9) + np.linspace(0, 0.05, n)
    codes = bin_codes(rank_scale(x[:, None]), 32)
    e = BinnedTV(codes, 32, h=1e-4)
    assert e.tv(np.flatnonzero(y))[0] == pytest.approx(1.0, abs=1e-9)
    # Every other run failed on a uniform grid: both groups fill the same bins equally.
    codes = bin_codes(rank_scale(np.arange(n, dtype=float)[:, None]), 32)
    alt = np.arange(n) % 2 == 0
    assert BinnedTV(codes, 32, h=0.05).tv(np.flatnonzero(alt))[0] < 0.02


def test_stratified_permutations_keep_each_stratum_count():
    strata = np.repeat([0, 1, 2], [50, 30, 20])
    minority = np.zeros(100, bool)
    minority[[1, 2, 60, 61, 62, 99]] = True
    st = Strata.build(strata, minority)
    rows = st.draw(np.random.default_rng(1))
    np.testing.assert_array_equal(np.bincount(strata[rows], minlength=3), [2, 3, 1])


def _lexsort_draw(st, keys):
    """The draw by its definition: rows sorted by (stratum, key), the first take[s] of each."""
    order = np.lexsort((keys, st.labels))
    pos = np.arange(order.size) - np.repeat(st.start, st.size)
    return order[pos < np.repeat(st.take, st.size)]


@pytest.mark.parametrize("n_strata", [1, 26, 100])
def test_per_stratum_draw_is_the_lexsort_draw(n_strata):
    """The fast draw (one stable sort per stratum) returns exactly the rows, in the same order,
    that sorting all rows by (stratum, key) does, ties included: p-values are unchanged."""
    rng = np.random.default_rng(n_strata)
    strata = rng.integers(0, n_strata, 3000).astype(str)
    st = Strata.build(strata, rng.random(3000) < 0.1)
    for seed in range(5):
        keys = np.random.default_rng(seed).random(strata.size)
        np.testing.assert_array_equal(st.draw(np.random.default_rng(seed)), _lexsort_draw(st, keys))
        keys[::7] = 0.5  # ties: both keep the rows' order
        np.testing.assert_array_equal(st._draw_per_stratum(keys), _lexsort_draw(st, keys))


def test_p_values_are_valid_and_corrected():
    X, y = planted_campaign("one-sided", seed=5, n_runs=1000, n_noise=6)
    s = SingleFactorKDE(n_permutations=99, random_state=0).fit(X, y)
    assert np.all((s.p_value_ >= 1 / 100) & (s.p_value_ <= 1))
    assert np.all(s.p_value_ >= s.p_raw_ - 1e-12)  # max-T adjustment never lowers a p-value
    assert s.rank_[:2].max() == 2  # the planted drivers thrust, inertia rank 1 and 2


def test_failure_region_format_and_share():
    edges = np.linspace(0, 32, 33)
    mask = np.zeros(32, bool)
    mask[:3] = True
    mask[30:] = True
    assert _format_region(mask, edges) == "<= 3 or >= 30"
    mask[:] = False
    mask[10:12] = True
    assert _format_region(mask, edges) == "10 .. 12"
    X, y = planted_campaign("one-sided", seed=2, n_runs=2000, n_noise=2)
    s = SingleFactorKDE(n_permutations=20).fit(X, y)
    j = s.feature_names_in_.index("thrust")
    # Planted: failures need low thrust (module docstring); the region is one low interval.
    assert s.regions_[j].startswith("<= ")
    bound = float(s.regions_[j][3:])
    inside = X["thrust"].to_numpy() <= bound
    # Share of failures in the region, recomputed from the data (bin edges are quantiles,
    # so a run at the edge may fall either side: 1 run's share of tolerance).
    assert s.region_fail_share_[j] == pytest.approx((inside & y).sum() / y.sum(), abs=1.5 / y.sum())


def test_holm_matches_the_step_down_definition():
    p = np.array([0.01, 0.04, 0.03, 0.2])
    # Holm: sorted 0.01*4, max(0.03*3, .04), max(0.04*2, .09), max(0.2, .09) -> 0.04, .09, .09, .2
    np.testing.assert_allclose(holm_adjusted(p), [0.04, 0.09, 0.09, 0.2])


def test_ttest_baseline_misses_a_two_sided_driver():
    # Planted two-sided: failed runs' mean thrust equals the successful runs' (hot and cold).
    X, y = planted_campaign("two-sided", seed=0, n_runs=2000, n_noise=4)
    t = TTestBaseline().fit(X, y)
    k = SingleFactorKDE(n_permutations=50).fit(X, y)
    j = t.feature_names_in_.index("thrust")
    assert t.p_value_[j] > 0.05
    assert k.p_value_[j] < 0.05 and k.rank_[j] == 1


def test_pair_gain_flags_a_pure_interaction():
    X, y = planted_campaign("pair", seed=4, n_runs=2000, n_noise=4)
    s = SingleFactorKDE(n_permutations=50).fit(X, y)
    p = PairKDE(n_permutations=50).fit(X, y, single_score=s.score_)
    t = p.table()
    assert {t["factor_a"][0], t["factor_b"][0]} == {"a", "b"}
    assert t["gain"][0] > 0.1 and t["p_value"][0] < 0.05
    assert s.p_value_.min() > 0.05  # no single input shows it (planted)


def test_knn_map_masks_empty_cells():
    rng = np.random.default_rng(0)
    # Two clusters far apart: the cells between them (and not next to a cluster) hold no run
    # and must be masked.
    a = np.r_[rng.normal(0, 0.1, 300), rng.normal(10, 0.1, 300)]
    b = rng.normal(0, 1, 600)
    y = np.r_[np.zeros(300, bool), rng.random(300) < 0.5]
    m = KNNFailureMap(k_grid=(10,), n_grid=20).fit(pd.DataFrame({"a": a, "b": b}), y)
    assert np.isnan(m.prob_[8:12]).all()
    filled = ~np.isnan(m.prob_)
    assert np.all((m.prob_[filled] >= 0) & (m.prob_[filled] <= 1))
    assert np.all(m.uncertainty_[filled] > 0)
