"""PRIM boxes (rcsim/analysis/results/drivers/boxes.py).

Oracles: planted boxes whose coverage, density and support are known analytically; EMA
Workbench's quantile rule, ported line by line from its ``prim_util.get_quantile``; the
definition of a peeling trajectory (each step a sub-box of the last).  The step-for-step
agreement with EMA Workbench itself is benchmarks/prim_vs_ema.py (docs/drivers.md).
"""

import math

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.results.drivers.boxes import (
    _ema_quantiles,
    choose,
    find_boxes,
    in_box,
    peel,
    regions_1d,
)


def _ema_get_quantile(data, quantile):
    """EMA Workbench 2.5's ``prim_util.get_quantile``, verbatim in substance."""
    data = np.sort(data)
    i = (len(data) - 1) * quantile
    lo, hi = int(math.floor(i)), int(math.ceil(i))
    if quantile > 0.5:
        while data[lo] == data[hi] and lo > 0:
            lo -= 1
    else:
        while data[lo] == data[hi] and hi < len(data) - 1:
            hi += 1
    return (data[lo] + data[hi]) / 2


@pytest.mark.parametrize("m", [2, 3, 20, 21, 101, 997])
def test_quantiles_are_emas_with_and_without_ties(m):
    rng = np.random.default_rng(m)
    X = np.column_stack(
        [rng.random(m), rng.integers(0, 4, m).astype(float), np.full(m, 2.0), rng.normal(size=m)]
    )
    lo, hi = _ema_quantiles(np.ascontiguousarray(X.T), 0.05)
    for j in range(X.shape[1]):
        assert lo[j] == _ema_get_quantile(X[:, j], 0.05)
        assert hi[j] == _ema_get_quantile(X[:, j], 0.95)


def _uniform(n, p, seed):
    rng = np.random.default_rng(seed)
    return pd.DataFrame(rng.random((n, p)), columns=[f"x{k + 1}" for k in range(p)])


def test_planted_box_recovered_with_its_analytic_coverage_and_density():
    """Failures exactly in x1 > 0.7, x2 < 0.4 (support 0.12, coverage 1, density 1): PRIM's
    box has limits within about one peel (5 % of the box's runs: 0.02 of x2 on [0, 0.4]) of the
    planted ones, restricts nothing else, and its coverage, density and support are the planted
    ones to that accuracy."""
    X = _uniform(20_000, 5, 1)
    y = ((X["x1"] > 0.7) & (X["x2"] < 0.4)).to_numpy()
    res = find_boxes(X, y, None, list(X.columns), ratios=False)
    assert len(res.boxes) == 1  # nothing left to explain after the first box
    b = res.boxes[0]
    assert b.dims == ["x1", "x2"]
    assert b.lo[0] == pytest.approx(0.7, abs=0.03) and b.hi[1] == pytest.approx(0.4, abs=0.03)
    assert b.coverage >= 0.9 and b.density >= 0.95
    assert b.support == pytest.approx(0.12, abs=0.015)
    # The exact interval holds the box's density; it is computed on the box's runs.
    assert b.p_lo <= b.density <= b.p_hi and b.failed == round(b.density * b.runs)


def test_trajectory_is_a_sequence_of_shrinking_boxes():
    X = _uniform(5_000, 4, 2)
    rng = np.random.default_rng(3)
    y = rng.random(5_000) < np.where((X["x1"] > 0.6) & (X["x3"] < 0.5), 0.5, 0.03)
    t = peel(X.to_numpy(), y)
    assert t.runs[0] == 5_000 and t.failed[0] == y.sum()
    assert np.all(np.diff(t.runs) < 0)  # each peel removes runs
    assert np.all(np.diff(t.coverage) <= 0)  # coverage never increases
    lo, hi = np.maximum(t.lo, -1.0), np.minimum(t.hi, 2.0)  # +-inf: unrestricted
    assert np.all(np.diff(lo, axis=0) >= 0) and np.all(np.diff(hi, axis=0) <= 0)
    assert t.support[-1] >= 0.05  # never below the floor
    for s in range(t.runs.size):  # the recorded counts are those of the recorded limits
        inside = in_box(X.to_numpy(), None, t.lo[s], t.hi[s], t.cats[s])
        assert inside.sum() == t.runs[s] and y[inside].sum() == t.failed[s]
    step = choose(t, int(y.sum()))
    assert t.coverage[step] >= 0.5 and t.density[step] == t.density[t.coverage >= 0.5].max()


def test_case_dimension_restricted_to_the_failing_cases():
    """Failures only in cases A and B (of four), at x1 > 0.5: the box keeps exactly A and B."""
    X = _uniform(8_000, 3, 4)
    rng = np.random.default_rng(5)
    case = rng.choice(list("ABCD"), 8_000)
    y = (X["x1"] > 0.5).to_numpy() & np.isin(case, ["A", "B"]) & (rng.random(8_000) < 0.6)
    res = find_boxes(X, y, case, list(X.columns), ratios=False)
    b = res.boxes[0]
    assert res.cases_text(b) == "A, B"
    assert "case" in b.dims and "x1" in b.dims and "x2" not in b.dims
    # Analytically: P(fail | box) = 0.6, coverage = 1, support = 1/4 (half of two of 4 cases).
    assert b.density == pytest.approx(0.6, abs=0.05)
    assert b.coverage >= 0.9 and b.support == pytest.approx(0.25, abs=0.03)


def test_a_ratio_band_gets_a_box_on_the_ratio():
    """Failure when thrust/inertia is low: neither input alone bounds it, the ratio does."""
    rng = np.random.default_rng(6)
    n = 6_000
    X = pd.DataFrame({"thrust": rng.uniform(20, 24, n), "inertia": rng.uniform(1200, 1600, n)})
    r = X["thrust"] / X["inertia"]
    y = (r < np.quantile(r, 0.08)).to_numpy()
    res = find_boxes(X, y, None, ["thrust", "inertia"])
    b = res.boxes[0]
    assert "thrust/inertia" in b.dims
    assert b.coverage >= 0.9 and b.density >= 0.9
    j = res.names.index("thrust/inertia")
    assert b.hi[j] == pytest.approx(np.quantile(r, 0.08), rel=0.01)


def test_no_box_without_a_concentration_of_failures():
    X = _uniform(4_000, 3, 7)
    y = np.random.default_rng(8).random(4_000) < 0.1
    res = find_boxes(X, y, None, list(X.columns))
    assert res.boxes == [] and len(res.trajectories) == 1
    assert res.table().empty and list(res.trajectory_table()["reported"]) == [False] * len(
        res.trajectories[0].runs
    )


def test_joint_inputs_explained_and_given_a_1d_range():
    """y = (a > 0.3) & (b > 0.3): P(fail | a) peaks at 0.7 = 1.43x the base rate 0.49 (no 1-D
    region at 2x), so the note must send the reader to the box that bounds a and b."""
    X = _uniform(6_000, 3, 9).rename(columns={"x1": "a", "x2": "b", "x3": "c"})
    y = ((X["a"] > 0.3) & (X["b"] > 0.3)).to_numpy()
    res = find_boxes(X, y, None, ["a", "b"], ratios=False)
    assert set(res.boxes[0].dims) == {"a", "b"}
    drivers = pd.DataFrame(
        {"factor": ["a", "b"], "rank": [1, 2], "significant": True, "failure_region": ""}
    )
    r = regions_1d(X, y, drivers, res).set_index("factor")
    for f in "ab":
        assert "acts jointly" in r.loc[f, "region_note"] and "box 1" in r.loc[f, "region_note"]
        # Any a > t with t >= 0.3 is as dense (0.7); coverage >= 0.5 needs t <= 0.65.
        assert 0.28 <= float(r.loc[f, "region_1d"].removeprefix(">= ").split()[0]) <= 0.65
        assert r.loc[f, "region_1d_coverage"] >= 0.5
        assert r.loc[f, "region_1d_lift"] == pytest.approx(0.7 / 0.49, rel=0.08)


def test_analyze_writes_boxes_trajectory_and_the_reports_figure(tmp_path):
    """``rcsim analyze``'s outputs: boxes.csv, box_limits.csv, trajectory.csv,
    driver_regions.csv, and the trajectory figure in the report and in figures/ (same bytes)."""
    import base64

    from rcsim.analysis.results.drivers.inputs import load_runs
    from rcsim.analysis.results.drivers.outputs import write_analysis
    from rcsim.analysis.results.drivers.pipeline import Settings, analyze
    from rcsim.analysis.results.drivers.synthetic import planted_campaign

    X, y = planted_campaign("one-sided", 0, n_runs=3000, n_noise=6)
    case = np.where(np.arange(3000) % 3 == 0, "rate-01", "rate-02")
    # Failures only in rate-01: the case is a dimension of the box.
    y = y & (case == "rate-01")
    runs = pd.concat([X, pd.DataFrame({"case": case, "failed": y})], axis=1)
    res = analyze(load_runs(runs), Settings(n_permutations=39, forest=False))
    assert res.boxes is not None and "boxes" in res.timings_s
    report = write_analysis(res, tmp_path / "out")
    out = report.parent
    boxes = pd.read_csv(out / "boxes.csv")
    assert list(boxes.columns[:9]) == [
        "box",
        "coverage",
        "density",
        "support",
        "runs",
        "failed",
        "p_fail_ci_lo",
        "p_fail_ci_hi",
        "lift",
    ]
    assert boxes["cases"][0] == "rate-01" and boxes["coverage"][0] >= 0.5
    assert "thrust" in boxes["limits"][0] or "inertia" in boxes["limits"][0]
    traj = pd.read_csv(out / "trajectory.csv")
    assert traj.query("box == 1")["chosen"].sum() == 1
    assert set(pd.read_csv(out / "box_limits.csv")["box"]) == set(boxes["box"])
    regions = pd.read_csv(out / "driver_regions.csv")
    assert set(regions["factor"]) == set(res.drivers.query("significant")["factor"])
    html = report.read_text()
    assert "id='boxes'" in html
    png = (out / "figures" / "prim_trajectory.png").read_bytes()
    assert f"data:image/png;base64,{base64.b64encode(png).decode()}'" in html


def test_a_large_run_set_is_searched_on_a_seeded_subsample(monkeypatch):
    """Beyond MAX_BOX_RUNS the search reads a seeded subsample (the same one every time) and
    says so; the section names both counts."""
    from rcsim.analysis.results.drivers import boxes, report_boxes
    from rcsim.analysis.results.drivers.inputs import load_runs
    from rcsim.analysis.results.drivers.pipeline import DriverResults, Settings

    monkeypatch.setattr(boxes, "MAX_BOX_RUNS", 1000)
    X = _uniform(3000, 3, 10)
    y = ((X["x1"] > 0.8) & (X["x2"] > 0.5)).to_numpy()
    rs = load_runs(pd.concat([X, pd.DataFrame({"failed": y})], axis=1))
    drivers = pd.DataFrame(
        {"factor": ["x1", "x2"], "rank": [1, 2], "significant": True, "failure_region": ""}
    )
    res = DriverResults(runset=rs, settings=Settings(), drivers=drivers)
    res.singles = object()  # has_failures
    a, b = boxes.analyze_boxes(res), boxes.analyze_boxes(res)
    assert a.total_runs == 1000 and a.subsample_of == 3000
    assert a.table().equals(b.table()) and a.boxes[0].dims == ["x1", "x2"]
    res.boxes = a
    html = "".join(report_boxes.section(res).blocks)
    assert "1,000 of the 3,000 runs" in html


def test_the_case_alone_or_one_input_alone():
    """No significant input but several cases: the box is the failing case; one input and one
    case: an ordinary 1-D box; nothing to peel stops the search instead of failing."""
    rng = np.random.default_rng(11)
    n = 3000
    X = pd.DataFrame(rng.random((n, 2)), columns=["a", "b"])
    case = rng.choice(list("ABC"), n)
    y = (case == "A") & (rng.random(n) < 0.5)
    res = find_boxes(X, y, case, [])
    assert res.names == [] and res.cases_text(res.boxes[0]) == "A"
    assert res.boxes[0].density == pytest.approx(0.5, abs=0.05)
    y2 = (X["a"] > 0.9).to_numpy()
    res = find_boxes(X, y2, np.array(["A"] * n), ["a"])
    assert res.case_names == [] and res.boxes[0].dims == ["a"]
