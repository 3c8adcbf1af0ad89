"""Failure probabilities with intervals, and several outcomes at once (issue 16, items 2 and 4).

Oracles:

* the Clopper-Pearson interval of ``k`` failures in ``n`` runs is, by its definition
  (Clopper and Pearson 1934; e.g. Brown, Cai and DasGupta 2001, Statist. Sci. 16(2), eq. 4),
  ``[B(alpha/2; k, n - k + 1), B(1 - alpha/2; k + 1, n - k)]`` with ``B(q; a, b)`` the
  q-quantile of the Beta(a, b) distribution: computed here with ``scipy.stats.beta.ppf``
  directly, for fixed counts;
* a failure region's probability is a plain recount: the runs whose bin is in the region, and
  the failed runs among them;
* per-axis outcomes on a synthetic runs table whose truth is planted: roll failures driven by
  input ``a`` only, yaw failures by ``b`` only, so each axis's top driver is its own input; the
  roll failures end between 0.04 and 0.06 deg/s and the yaw failures above 0.06, so at the
  second threshold (0.06) exactly the yaw failures remain.
"""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rcsim.analysis.results.drivers import report_outcomes
from rcsim.analysis.results.drivers.inputs import load_runs
from rcsim.analysis.results.drivers.kde import bin_codes, rank_scale
from rcsim.analysis.results.drivers.outcomes import (
    build_outcomes,
    campaign_threshold,
    outcome_table,
)
from rcsim.analysis.results.drivers.pipeline import Settings, analyze
from rcsim.analysis.results.drivers.probabilities import (
    add_region_columns,
    bound_words,
    p_with_ci,
    probability_frame,
)
from rcsim.analysis.results.drivers.single import SingleFactorKDE
from rcsim.analysis.results.proportions import runs_to_bound
from rcsim.models.errors import InputError


@pytest.mark.parametrize("k, n", [(0, 50), (1, 50), (7, 300), (50, 50), (260, 26000)])
def test_interval_is_the_beta_quantiles(k, n):
    t = probability_frame([k], [n], bound_p=0.01).iloc[0]
    lo = stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    assert t["failure_probability"] == k / n
    assert t["cp95_low"] == pytest.approx(lo, rel=1e-12, abs=1e-15)
    assert t["cp95_high"] == pytest.approx(hi, rel=1e-12, abs=1e-15)
    assert t["runs_to_bound"] == runs_to_bound(k, n, 0.01)


def test_known_counts_and_words():
    # 3 of 100: the textbook exact interval 0.62 % .. 8.52 %.
    t = probability_frame([3], [100]).iloc[0]
    assert (round(t["cp95_low"], 4), round(t["cp95_high"], 4)) == (0.0062, 0.0852)
    assert p_with_ci(0.021, 0.014, 0.030) == "p = 2.1 % (95 % CI 1.4-3.0 %)"
    assert p_with_ci(0.0031, 0.00062, 0.125) == "p = 0.31 % (95 % CI 0.062-12.5 %)"
    # No failure in 100 runs: 299 runs bound p below 1 % (rule of three, exact form).
    t0 = probability_frame([0], [100], bound_p=0.01).iloc[0]
    assert t0["runs_to_bound"] == 299
    assert bound_words(299, 100, 0.01) == "299 runs bound it below 1 % (199 more)"
    assert "no number of runs bounds it below 1 %" in bound_words(np.inf, 100, 0.01)


def test_region_probability_is_a_recount():
    # Issue 29: every count said of a region is the count of the runs its text bounds (the text
    # the report shows), so the ranking, the paragraphs and the captions state one number.
    rng = np.random.default_rng(1)
    X = pd.DataFrame(rng.normal(size=(2000, 3)), columns=["a", "b", "c"])
    y = (X["a"] + 0.5 * rng.normal(size=2000)) > 1.5
    sk = SingleFactorKDE(n_permutations=19, random_state=0).fit(X, y.to_numpy())
    d = add_region_columns(sk.table(), sk, X, y.to_numpy(), 0.01).set_index("factor")
    for j, name in enumerate(sk.feature_names_in_):
        inside = np.zeros(len(X), bool)
        for part in filter(None, sk.regions_[j].split(" or ")):  # the test's own reading
            if part.startswith(">="):
                inside |= X[name].to_numpy() >= float(part[2:])
            elif part.startswith("<="):
                inside |= X[name].to_numpy() <= float(part[2:])
            else:
                lo, hi = (float(v) for v in part.split(".."))
                inside |= (X[name].to_numpy() >= lo) & (X[name].to_numpy() <= hi)
        assert d.loc[name, "region_runs"] == inside.sum()
        assert d.loc[name, "region_fail_share"] == (inside & y).sum() / y.sum()
        if inside.any():
            assert d.loc[name, "region_failed"] == (inside & y).sum()
            lo = stats.beta.ppf(0.025, (inside & y).sum(), inside.sum() - (inside & y).sum() + 1)
            assert d.loc[name, "region_cp95_low"] == pytest.approx(lo, rel=1e-9)
        else:
            assert np.isnan(d.loc[name, "region_failure_probability"])
    assert d.loc["a", "region_failure_probability"] > 3 * y.mean()


def _axes_table(n=1500, seed=0):
    """Inputs a, b, c, n1, n2 in two cases; roll fails (0.05 deg/s) when a is in its top
    12 %, yaw fails (0.08 deg/s) when b is in its top 8 %; pitch never fails."""
    rng = np.random.default_rng(seed)
    X = pd.DataFrame(rng.normal(size=(n, 5)), columns=["a", "b", "c", "n1", "n2"])
    roll = X["a"] + 0.2 * rng.normal(size=n) > np.quantile(X["a"], 0.88)
    yaw = X["b"] + 0.2 * rng.normal(size=n) > np.quantile(X["b"], 0.92)
    sign = rng.choice([-1.0, 1.0], size=(n, 3))
    df = X.assign(
        run_id=np.arange(n),
        case=np.where(np.arange(n) % 2 == 0, "rate-01", "rate-02"),
        final_rate_err_roll_deg_s=np.where(roll, 0.05, 0.01) * sign[:, 0],
        final_rate_err_pitch_deg_s=0.002 * sign[:, 1],
        final_rate_err_yaw_deg_s=np.where(yaw, 0.08, 0.003) * sign[:, 2],
        sim_failed=False,
        failed=roll | yaw,
    )
    df["reason"] = np.where(df["failed"], "final |rate error| >= 0.04 deg/s: ...", "")
    return df, roll.to_numpy(), yaw.to_numpy()


MANIFEST = {"thresholds": {"rate_error_deg_s": 0.04, "attitude_error_deg": None}}


def _runset(df):
    rs = load_runs(df, inputs=["a", "b", "c", "n1", "n2"])
    return replace(rs, manifest=MANIFEST)


def test_each_axis_is_driven_by_its_own_input():
    df, roll, yaw = _axes_table()
    # 199 permutations: the outcome family's share (1 % of the 5 % budget) is reachable.
    res = analyze(_runset(df), Settings(n_permutations=199, forest=False, n_splits=2))
    by = {o.name: o for o in res.outcomes.outcomes}
    assert list(by) == ["roll", "pitch", "yaw", "failed at 0.06"]
    assert by["roll"].failed == roll.sum() and by["yaw"].failed == yaw.sum()
    assert by["pitch"].failed == 0 and by["pitch"].singles is None  # nothing to compare
    for name, truth in (("roll", "a"), ("yaw", "b"), ("failed at 0.06", "b")):
        t = by[name].singles.table()
        assert t["factor"][0] == truth, name
        # Flagged family-wise over every outcome and input (the outcome family's share).
        j = list(by[name].singles.feature_names_in_).index(truth)
        assert by[name].significant[j] and by[name].p_family[j] < res.levels["outcomes"]
        # Family-wise over more tests: never below the outcome's own max-T p-value.
        assert (by[name].p_family >= by[name].singles.p_value_ - 1e-12).all()
    # At 0.06 deg/s the roll failures (0.05) pass: exactly the yaw failures remain.
    np.testing.assert_array_equal(by["failed at 0.06"].y, yaw)
    assert res.outcomes.axis_breakdown["pitch only"] == 0
    assert sum(res.outcomes.axis_breakdown.values()) == (roll | yaw).sum()

    t = outcome_table(res)
    assert list(t["outcome"].unique()) == ["failed", "roll", "pitch", "yaw", "failed at 0.06"]
    roll_rows = t[t["outcome"] == "roll"]
    assert roll_rows["factor"].iloc[0] == "a" and roll_rows["significant"].iloc[0]
    assert roll_rows["failure_probability"].iloc[0] == roll.mean()
    assert t.loc[t["outcome"] == "pitch", "factor"].tolist() == [""]
    # Region probabilities were added to the drivers (drivers.csv).
    assert {"region_failure_probability", "region_cp95_low", "region_cp95_high"} <= set(
        res.drivers.columns
    )


def test_threshold_comes_from_the_campaign_and_other_reasons_still_fail():
    assert campaign_threshold({"thresholds": {"rate_error_deg_s": 0.05}}) == 0.05
    assert campaign_threshold({"spec": {"failure": {"rate_error_deg_s": 0.03}}}) == 0.03
    assert campaign_threshold(None) is None
    df, roll, yaw = _axes_table(n=400)
    # A run that failed on attitude (rates fine) fails at either threshold; its rate columns
    # do not say so, its reason does.
    df.loc[0, ["failed", "reason"]] = [True, "final attitude error 3 deg > 2 deg"]
    df.loc[0, ["final_rate_err_roll_deg_s", "final_rate_err_yaw_deg_s"]] = [0.0, 0.0]
    out = build_outcomes(replace(_runset(df), manifest={"thresholds": {"rate_error_deg_s": 0.05}}))
    assert out.threshold == 0.05
    y2 = out.outcomes[-1].y
    assert y2[0] and out.outcomes[0].y.sum() == roll[1:].sum()  # 0.05 >= 0.05: roll fails


def test_tables_without_axes_or_manifest_skip_with_a_note():
    df, _, _ = _axes_table(n=300)
    no_axes = df.drop(columns=["final_rate_err_pitch_deg_s"])
    out = build_outcomes(_runset(no_axes))
    assert out.outcomes == [] and "per-axis" in out.notes[0]
    out = build_outcomes(load_runs(df, inputs=["a", "b"]))  # no manifest: threshold unknown
    assert out.outcomes == [] and "threshold" in out.notes[0]
    res = analyze(_runset(no_axes), Settings(n_permutations=19, forest=False, n_splits=2))
    t = outcome_table(res)
    assert t["outcome"].unique().tolist() == ["failed"]


@pytest.mark.parametrize(
    "field, value", [("bound_p", 0.0), ("bound_p", 1.5), ("second_threshold", -0.06)]
)
def test_settings_refuse_bad_values(field, value):
    with pytest.raises(InputError) as err:
        Settings(**{field: value})
    assert err.value.parameter == field


def test_shared_codes_give_the_same_fit():
    """The outcomes share one ranking of the inputs (``codes=``): the fit is the one without."""
    df, roll, _ = _axes_table(n=600)
    X = df[["a", "b", "c"]]
    codes = bin_codes(rank_scale(X.to_numpy()), 32)
    a = SingleFactorKDE(n_permutations=39, random_state=4).fit(X, roll, df["case"])
    b = SingleFactorKDE(n_permutations=39, random_state=4).fit(X, roll, df["case"], codes=codes)
    pd.testing.assert_frame_equal(a.table(), b.table())
    with pytest.raises(ValueError, match="codes"):
        SingleFactorKDE().fit(X, roll, codes=codes[:, :2])


def test_propellant_and_delta_v_are_outcomes_driven_by_their_inputs():
    """Planted truth (issue 28): propellant_kg grows with input c, delta_v_N_m_s with n1;
    the budgets in the manifest split them.  Each outcome's top driver must be its input,
    flagged inside the report's one outcome family; without budgets the outcome is the top
    decile; the columns are never inputs of a table analysed without named inputs."""
    df, _, _ = _axes_table()
    rng = np.random.default_rng(3)
    df["propellant_kg"] = 0.01 + 0.002 * df["c"] + 0.0004 * rng.normal(size=len(df))
    df["delta_v_N_m_s"] = 0.003 + 0.001 * df["n1"] + 0.0002 * rng.normal(size=len(df))
    budgets = {"max_propellant_kg": 0.013, "max_delta_v_m_s": 0.0045}
    rs = replace(_runset(df), manifest={"thresholds": {**MANIFEST["thresholds"], **budgets}})
    res = analyze(rs, Settings(n_permutations=199, forest=False, n_splits=2))
    by = {o.name: o for o in res.outcomes.outcomes}
    prop, dv = by["propellant > 0.013"], by["delta-v > 0.0045"]
    np.testing.assert_array_equal(prop.y, df["propellant_kg"].to_numpy() > 0.013)
    np.testing.assert_array_equal(dv.y, df["delta_v_N_m_s"].to_numpy() > 0.0045)
    for o, truth in ((prop, "c"), (dv, "n1")):
        assert o.singles.table()["factor"][0] == truth, o.name
        j = list(o.singles.feature_names_in_).index(truth)
        assert o.significant[j] and o.p_family[j] < res.levels["outcomes"]
    # No budget: the top decile, at or above the 90th percentile of the runs.
    top = build_outcomes(_runset(df)).outcomes
    decile = {o.name: o for o in top}["propellant top 10 %"]
    q = np.quantile(df["propellant_kg"], 0.9)
    np.testing.assert_array_equal(decile.y, df["propellant_kg"].to_numpy() >= q)
    # Issue 38: its share is 10 % by construction -- no interval, no runs to bound it.
    assert decile.by_construction and not prop.by_construction
    res_top = analyze(_runset(df), Settings(n_permutations=19, forest=False, n_splits=1))
    t = outcome_table(res_top).drop_duplicates("outcome").set_index("outcome")
    assert np.isnan(t.loc["propellant top 10 %", ["cp95_low", "cp95_high"]].astype(float)).all()
    section = " ".join(report_outcomes.outcomes(res_top).blocks)
    assert "% (the top decile by construction: no interval)" in section
    # A table analysed with its numeric columns as inputs leaves the outcomes out.
    plain = load_runs(df.drop(columns=["final_rate_err_pitch_deg_s"]))
    assert "propellant_kg" not in plain.X.columns and "delta_v_N_m_s" not in plain.X.columns
    assert "c" in plain.X.columns
