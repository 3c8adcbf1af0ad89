"""Noisy-sensor Monte Carlo (Pittella & Sands 2023, Section 3): integrator, draws, tables, CLI.

Everything is nondimensional (unit rotation in unit time), as in the paper.
"""

import os

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import quad, solve_ivp

from rcsim.analysis.apps.cli import main
from rcsim.analysis.apps.studies import noisy_sensor as ns
from rcsim.lookup import single_axis as sa
from rcsim.models.errors import InputError

ARCH = {a.key: a for a in sa.ARCHITECTURES}


def _quiet_run(key, dt=ns.DT, record=True):
    cfg = ns.StudyConfig(runs=2, noise_var=0.0, inertia_spread=0.0, dt=dt)
    return ns.simulate(ARCH[key], ns.draw_runs(cfg), dt=dt, record=record)


def _trajectory_error(result):
    """Largest deviation of angle and rate from the optimal trajectory (Eq. 12 integrated)."""
    return max(
        np.abs(result["theta"][0] - sa.optimal_angle(result["t"])).max(),
        np.abs(result["omega"][0] - sa.optimal_rate(result["t"])).max(),
    )


# --------------------------------------------------------------- deterministic oracles --
def test_open_loop_without_noise_is_exact():
    # Oracle: Section 2.3, u* reaches theta(1) = 1, omega(1) = 0 with J* = 6 exactly.  RK4 is
    # exact when the solution is a polynomial of degree <= 4 (theta cubic, J cubic), so only
    # round-off of 100 steps remains: 1e-12.
    r = _quiet_run("open_loop")
    assert r["theta_f"][0] == pytest.approx(1.0, abs=1e-12)
    assert r["omega_f"][0] == pytest.approx(0.0, abs=1e-12)
    assert r["J"][0] == pytest.approx(6.0, abs=1e-12)
    assert _trajectory_error(r) < 1e-12


def test_open_loop_cost_does_not_vary_under_noise_and_final_angle_is_one_over_inertia():
    # Oracle: J is the cost of the commanded u*, which ignores sensors, so it is identical in
    # every run (Table 1: sigma_J = 0); with domega/dt = u*/I, theta(1) = 1/I and
    # omega(1) = (1/I) int u* = 0 analytically.  1e-12: round-off as above.
    cfg = ns.StudyConfig(runs=200, seed=5)
    draws = ns.draw_runs(cfg)
    r = ns.simulate(ARCH["open_loop"], draws)
    assert np.all(r["J"] == r["J"][0]) and r["J"][0] == pytest.approx(6.0, abs=1e-12)
    np.testing.assert_allclose(r["theta_f"] * draws.inertia[:, 0], 1.0, atol=1e-12)
    np.testing.assert_allclose(r["omega_f"], 0.0, atol=1e-12)


def test_rtoc_without_noise_reproduces_optimal_trajectory():
    # Oracle: Bellman optimality - from any point of the optimal trajectory, Eq. 13 returns
    # u*, so the closed loop follows Eq. 12 until the switch and open loop after it.  The
    # only deviation is RK4 truncation error of the closed loop (whose gain 6/T^2 grows to
    # ~550 at the switch): measured 1.7e-5 at dt = 0.01, bounded here by 1e-4, and it must
    # shrink like dt^4 (>= 8x per halving allows for the pre-asymptotic regime).
    coarse = _trajectory_error(_quiet_run("rtoc", dt=0.01))
    fine = _trajectory_error(_quiet_run("rtoc", dt=0.005))
    assert coarse < 1e-4
    assert fine < coarse / 8.0
    assert _quiet_run("rtoc")["J"][0] == pytest.approx(6.0, abs=1e-3)


def test_control_inversion_without_noise_reproduces_optimal_trajectory():
    # Oracle: Eqs. 15-17 make u = u* + K_P (theta* - theta) + K_V (omega* - omega); starting on
    # the optimal trajectory the correction stays zero, so the result equals open-loop
    # optimal to round-off (1e-12), including J = 6.
    r = _quiet_run("control_inversion")
    assert _trajectory_error(r) < 1e-12
    assert r["J"][0] == pytest.approx(6.0, abs=1e-12)


def test_pv_without_noise_matches_analytic_step_response():
    # Oracle: the closed loop theta'' + K_V theta' + K_P theta = K_P (Eq. 14, I = 1) has the
    # analytic solution below; J = 1/2 int u^2 by adaptive quadrature of it.  RK4 global error
    # at dt = 0.01 is ~(w_n dt)^4 ~ 1e-5 relative at most, hence 1e-5 absolute.
    kp, kv = 37.0, 8.5
    wn, zeta = np.sqrt(kp), kv / (2.0 * np.sqrt(kp))
    wd = wn * np.sqrt(1.0 - zeta**2)

    def theta(t):
        return 1.0 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))

    def omega(t):
        return np.exp(-zeta * wn * t) * (wn**2 / wd) * np.sin(wd * t)

    cost = quad(
        lambda t: 0.5 * (kp * (1.0 - theta(t)) - kv * omega(t)) ** 2, 0.0, 1.0, epsabs=1e-12
    )[0]
    r = _quiet_run("pv")
    assert r["theta_f"][0] == pytest.approx(theta(1.0), abs=1e-5)
    assert r["omega_f"][0] == pytest.approx(omega(1.0), abs=1e-5)
    assert r["J"][0] == pytest.approx(cost, rel=1e-5)


@pytest.mark.parametrize("key", ["double_integrator", "double_integrator_tuned"])
def test_double_integrator_filters_match_independent_integrator(key):
    # Oracle: theta'' = K_P (theta*(t) - theta) - K_V theta' (Section 2.5 with the filter's
    # exact output theta* = 3t^2 - 2t^3) solved by scipy's DOP853 at rtol 1e-11.  Our RK4
    # at dt = 0.01 is within 1e-5 (global error ~(sqrt(K_P) dt)^4 ~ 1e-5 for K_P = 78).
    kp, kv = ARCH[key].params.kp, ARCH[key].params.kv

    def rhs(t, y):
        u = kp * (sa.optimal_angle(t) - y[0]) - kv * y[1]
        return [y[1], u, 0.5 * u * u]

    ref = solve_ivp(rhs, (0.0, 1.0), [0.0, 0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-12)
    r = _quiet_run(key)
    assert r["theta_f"][0] == pytest.approx(ref.y[0, -1], abs=1e-5)
    assert r["omega_f"][0] == pytest.approx(ref.y[1, -1], abs=1e-5)
    assert r["J"][0] == pytest.approx(ref.y[2, -1], rel=1e-5)


def test_noise_free_mode_is_deterministic():
    # With no noise and no inertia spread every run is the same manoeuvre: zero spreads
    # (up to the round-off of averaging identical numbers).
    result = ns.run_study(ns.StudyConfig(runs=5, noise_var=0.0, inertia_spread=0.0))
    spreads = result.summary[["sigma_theta", "sigma_omega", "sigma_J"]].to_numpy()
    assert np.all(spreads < 1e-12)


# ------------------------------------------------------------------------------ draws --
def test_first_runs_do_not_depend_on_run_count():
    # Standard: run i draws from SeedSequence(seed, spawn_key=(i,)).  Draws are bitwise
    # equal; results agree to 1e-12 (a batched LAPACK solve may round differently).
    small = ns.run_study(ns.StudyConfig(runs=10, seed=11))
    large = ns.run_study(ns.StudyConfig(runs=50, seed=11))
    d10 = ns.draw_runs(ns.StudyConfig(runs=10, seed=11))
    d50 = ns.draw_runs(ns.StudyConfig(runs=50, seed=11))
    np.testing.assert_array_equal(d10.inertia, d50.inertia[:10])
    np.testing.assert_array_equal(d10.noise, d50.noise[:10])
    cols = ["theta_f", "omega_f", "J", "theta_f_measured", "omega_f_measured"]
    first = large.runs[large.runs["run"] < 10].reset_index(drop=True)
    np.testing.assert_allclose(
        small.runs[cols].to_numpy(), first[cols].to_numpy(), rtol=0, atol=1e-12
    )
    assert list(small.runs["architecture"]) == list(first["architecture"])


def test_same_seed_gives_identical_results():
    a = ns.run_study(ns.StudyConfig(runs=20, seed=9)).runs
    b = ns.run_study(ns.StudyConfig(runs=20, seed=9)).runs
    pd.testing.assert_frame_equal(a, b)


def test_simulate_rejects_draws_for_another_step():
    draws = ns.draw_runs(ns.StudyConfig(runs=2))
    with pytest.raises(ValueError, match="dt"):
        ns.simulate(ARCH["pv"], draws, dt=0.02)


def test_seed_changes_the_draws():
    a = ns.draw_runs(ns.StudyConfig(runs=3, seed=1))
    b = ns.draw_runs(ns.StudyConfig(runs=3, seed=2))
    assert not np.array_equal(a.noise, b.noise)
    assert not np.array_equal(a.inertia, b.inertia)


def test_draw_statistics():
    # Oracle: noise N(0, V) and inertia U[1 - F, 1 + F].  With 2000 runs x 101 x 2 noise
    # samples the sample variance is within 2 % of V (its relative standard error is
    # sqrt(2 / 404000) = 0.2 %); the inertia mean is within 4 standard errors of 1.
    cfg = ns.StudyConfig(runs=2000, seed=3, noise_var=4e-4, inertia_spread=0.2)
    d = ns.draw_runs(cfg)
    assert d.noise.shape == (2000, 101, 2) and d.inertia.shape == (2000, 1)
    assert d.noise.var() == pytest.approx(4e-4, rel=0.02)
    assert abs(d.noise.mean()) < 4 * 0.02 / np.sqrt(d.noise.size)
    assert d.inertia.min() >= 0.8 and d.inertia.max() <= 1.2
    assert abs(d.inertia.mean() - 1.0) < 4 * (0.4 / np.sqrt(12)) / np.sqrt(2000)


# ----------------------------------------------------------- paper Table 1 and Table 2 --
PAPER_TABLE1 = pd.DataFrame(
    [
        ("P+V", 1.0176, 0.0099, -0.1128, 0.0140, 40.1842, 0.5979),
        ("Open-loop optimal", 1.0029, 0.0163, 0.0004, 0.0220, 6.0000, 0.0000),
        ("RTOC", 1.0028, 0.0225, 0.0087, 0.0156, 5.9701, 0.00001),
        ("Double integrator", 0.8399, 0.0100, 1.0640, 0.0146, 2.2295, 0.0560),
        ("Double int., tuned", 1.0227, 0.0116, -0.0140, 0.0510, 13.3345, 0.7892),
        ("Control inversion", 0.9996, 0.0105, -0.0016, 0.0155, 6.0412, 0.1045),
    ],
    columns=["architecture", "theta_f", "sigma_theta", "omega_f", "sigma_omega", "J", "sigma_J"],
)


def test_percent_table_reproduces_paper_table2_from_its_table1():
    # Oracle: paper Table 2 is 100 (x - x_openloop) / x_openloop of Table 1, rounded to
    # whole percent (tolerance 0.5 + the effect of Table 1's 4-decimal rounding).  Its
    # sigma_J column divides by sigma_J = 0 and is undefined here (NaN).
    pct = ns.percent_table(PAPER_TABLE1.assign(wall_s=0.0)).set_index("architecture")
    expected = {
        ("P+V", "sigma_theta"): -39,
        ("P+V", "J"): 570,
        ("P+V", "sigma_omega"): -36,
        ("RTOC", "sigma_theta"): 38,
        ("RTOC", "sigma_omega"): -29,
        ("Double integrator", "theta_f"): -16,
        ("Double integrator", "J"): -63,
        ("Double int., tuned", "sigma_omega"): 132,
        ("Double int., tuned", "J"): 122,
        ("Control inversion", "sigma_theta"): -36,
        ("Control inversion", "J"): 1,
    }
    for (row, col), value in expected.items():
        assert pct.loc[row, col] == pytest.approx(value, abs=0.6), (row, col)
    # omega_f percentages explode because the reference is 0.0004 (Table 2: -28,300 %).
    assert pct.loc["P+V", "omega_f"] == pytest.approx(-28300, rel=0.01)
    assert pct["sigma_J"].isna().all()


def test_paper_reconstruction_matches_table1_except_rtoc():
    # Oracle: paper Table 1.  Our reconstruction of its set-up (inertia redrawn every step,
    # final *sensor readings* tabulated; see docs/noisy-sensor.md) must agree with it within
    # sampling error: means within 4 combined standard errors, spreads within 4 standard
    # errors of a standard deviation (~sigma / sqrt(2N) each) plus 10 % for non-normal
    # tails, plus Table 1's 4-decimal rounding.  RTOC is excluded: its published
    # sigma_J = 1e-5 cannot come from a noise-fed feedback law (documented).
    n = 1000
    result = ns.run_study(ns.StudyConfig(runs=n, seed=0, inertia_model="per-step"), measured=True)
    ours = result.summary.set_index("architecture")
    paper = PAPER_TABLE1.set_index("architecture")
    for row in paper.index.drop("RTOC"):
        for mean, sd in (("theta_f", "sigma_theta"), ("omega_f", "sigma_omega"), ("J", "sigma_J")):
            se = np.hypot(paper.loc[row, sd], ours.loc[row, sd]) / np.sqrt(n)
            assert abs(ours.loc[row, mean] - paper.loc[row, mean]) <= 4 * se + 5e-5, (row, mean)
            sd_tol = 4 * ours.loc[row, sd] / np.sqrt(n) + 0.1 * ours.loc[row, sd] + 5e-5
            assert abs(ours.loc[row, sd] - paper.loc[row, sd]) <= sd_tol, (row, sd)


def test_summary_uses_sample_standard_deviation():
    runs = pd.DataFrame(
        {
            "architecture": "A",
            "run": [0, 1, 2],
            "theta_f": [1.0, 2.0, 3.0],
            "omega_f": [0.0, 0.0, 3.0],
            "J": [5.0, 5.0, 5.0],
        }
    )
    row = ns.summarize(runs).iloc[0]
    assert row["theta_f"] == 2.0 and row["sigma_theta"] == pytest.approx(1.0)  # ddof = 1
    assert row["sigma_omega"] == pytest.approx(np.sqrt(3.0)) and row["sigma_J"] == 0.0
    assert np.isnan(row["wall_s"])


# ------------------------------------------------------------------------ user input --
@pytest.mark.parametrize(
    "kwargs, parameter",
    [
        ({"runs": -5}, "runs"),
        ({"runs": 1}, "runs"),
        ({"runs": 2.5}, "runs"),
        ({"seed": -1}, "seed"),
        ({"noise_var": -1e-4}, "noise_var"),
        ({"noise_var": float("inf")}, "noise_var"),
        ({"inertia_spread": 1.0}, "inertia_spread"),
        ({"inertia_spread": -0.1}, "inertia_spread"),
        ({"inertia_model": "x"}, "inertia_model"),
        ({"dt": 0.03}, "dt"),
    ],
)
def test_bad_settings_raise_input_error_naming_parameter(kwargs, parameter):
    # Library errors name the library's parameter and its value, never a CLI flag (issue 8).
    with pytest.raises(InputError) as info:
        ns.StudyConfig(**kwargs)
    assert info.value.parameter == parameter
    assert info.value.value == kwargs[parameter]
    assert str(info.value).startswith(f"{parameter} ") and "--" not in str(info.value)


def test_study_that_cannot_fit_in_memory_is_refused_up_front():
    # 1e12 runs x 101 noise rows x 2 x 8 bytes = 1.6 PB of draws alone: refused before any
    # allocation (issue 8: a MemoryError traceback), naming the parameter and what fits.
    with pytest.raises(InputError) as info:
        ns.StudyConfig(runs=10**12)
    assert info.value.parameter == "runs" and "memory" in str(info.value)
    assert ns.study_bytes(ns.StudyConfig(runs=2)) < 10**5  # the usual sizes are far below


# -------------------------------------------------------------------------------- CLI --
def test_cli_writes_all_outputs(tmp_path, capsys):
    out = tmp_path / "study"
    code = main(["study", "noisy-sensor", "--runs", "12", "--seed", "4", "--out", str(out)])
    assert code == 0
    assert sorted(f for f in os.listdir(out) if not f.startswith(".")) == sorted(ns.OUTPUT_FILES)
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary.columns) == list(ns.SUMMARY_COLUMNS)
    assert list(summary["architecture"]) == [a.label for a in sa.ARCHITECTURES]
    assert list(pd.read_csv(out / "percent.csv").columns) == list(ns.PERCENT_COLUMNS)
    runs = pd.read_parquet(out / "runs.parquet")
    assert len(runs) == 6 * 12 and set(runs["run"]) == set(range(12))
    assert (out / "scatter.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert str(out) in capsys.readouterr().out
    assert [p.name for p in tmp_path.iterdir()] == ["study"]  # no temp dirs left


def test_cli_replaces_previous_outputs_only_with_overwrite(tmp_path, capsys):
    out = tmp_path / "study"
    assert main(["study", "noisy-sensor", "--runs", "3", "--out", str(out)]) == 0
    before = (out / "runs.parquet").read_bytes()
    # Without --overwrite the earlier study is kept and the user is told how to replace it.
    assert main(["study", "noisy-sensor", "--runs", "4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--overwrite" in err and err.count("\n") == 1
    assert (out / "runs.parquet").read_bytes() == before
    assert main(["study", "noisy-sensor", "--runs", "4", "--out", str(out), "--overwrite"]) == 0
    assert len(pd.read_parquet(out / "runs.parquet")) == 6 * 4
    assert [p.name for p in tmp_path.iterdir()] == ["study"]


def test_cli_never_replaces_another_commands_directory(tmp_path, capsys):
    # A campaign directory (marker written by `rcsim campaign run`) survives even --overwrite.
    out = tmp_path / "campaign"
    out.mkdir()
    (out / ".rcsim-output").write_text("written by rcsim campaign run\n")
    (out / "cases.csv").write_text("case,runs\n")
    assert main(["study", "noisy-sensor", "--runs", "3", "--out", str(out), "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert "campaign run" in err and str(out) in err and err.count("\n") == 1
    assert sorted(p.name for p in out.iterdir()) == [".rcsim-output", "cases.csv"]


def test_library_writer_records_the_study_in_the_marker(tmp_path):
    out = tmp_path / "study"
    assert main(["study", "noisy-sensor", "--runs", "3", "--out", str(out)]) == 0
    marker = (out / ".rcsim-output").read_text().splitlines()
    assert marker[0] == "written by rcsim study noisy-sensor"
    assert "summary.csv" in marker[1]  # the record of outputs (issue 31)


@pytest.mark.parametrize(
    "argv, option",
    [
        (["--runs", "-3"], "--runs"),
        (["--noise-var", "-1"], "--noise-var"),
        (["--inertia-spread", "1.5"], "--inertia-spread"),
        (["--seed", "-2"], "--seed"),
        (["--runs", "many"], "--runs"),
    ],
)
def test_cli_user_errors_exit_2_with_one_line(tmp_path, capsys, argv, option):
    out = tmp_path / "study"
    assert main(["study", "noisy-sensor", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert option in err and err.count("\n") == 1
    assert not out.exists()


def test_cli_refuses_directory_with_foreign_files(tmp_path, capsys):
    out = tmp_path / "study"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert main(["study", "noisy-sensor", "--runs", "3", "--out", str(out)]) == 2
    assert "--out" in capsys.readouterr().err
    assert os.listdir(out) == ["notes.txt"]


def test_failed_write_leaves_no_output(tmp_path, monkeypatch):
    # Atomic output: an error while writing (here: the plot) leaves neither DIR nor temp dirs.
    def boom(*args, **kwargs):
        raise RuntimeError("plot failed")

    monkeypatch.setattr(ns, "plot_scatter", boom)
    with pytest.raises(RuntimeError, match="plot failed"):
        main(["study", "noisy-sensor", "--runs", "3", "--out", str(tmp_path / "study")])
    assert list(tmp_path.iterdir()) == []
