"""The DAI study (rcsim.analysis.apps.studies.dai): smoke run, reproducibility, Table 9 arithmetic,
CLI.

Fast: the smoke run flies two scenarios with the periods shortened 10x (``period_scale``).
"""

import argparse

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli.study_dai import SCENARIO_NAMES, register_dai
from rcsim.analysis.apps.studies.dai import (
    SCENARIOS,
    SUMMARY_COLUMNS,
    improvement_table,
    run_dai_study,
    run_method,
)
from rcsim.models.errors import InputError


def test_smoke_study_writes_every_output(tmp_path):
    out = tmp_path / "dai"
    summary = run_dai_study(
        out, scenarios=("wilt_yaw30", "smeresky_yaw30_coarse"), runs=2, period_scale=0.1
    )
    assert tuple(summary.columns) == SUMMARY_COLUMNS
    assert list(summary["method"]) == [
        "ffd+fb",
        "ffd+fb+dai",
        "ffd+fb+dai-total",
        "ffd+fb+dai-integral",
        "ffd+fb",
    ]
    assert (summary["mc_runs"] == 2).all()
    for name in (
        "summary.csv",
        "improvement.csv",
        "montecarlo.csv",
        "wilt_yaw30.png",
        "wilt_yaw30_theta_hat.png",
        "smeresky_yaw30_coarse.png",
    ):
        assert (out / name).stat().st_size > 0, name
    on_disk = pd.read_csv(out / "summary.csv")
    assert list(on_disk["scenario"]) == list(summary["scenario"])
    assert len(pd.read_csv(out / "montecarlo.csv")) == 5 * 3  # nominal + 2 runs per method
    improvement = pd.read_csv(out / "improvement.csv")
    assert list(improvement["method"]) == ["ffd+fb+dai", "ffd+fb+dai-total", "ffd+fb+dai-integral"]
    # Each reading states what it learns and its gain or memory, as flown (parameters.csv).
    laws = improvement.set_index("method")["learning_law"]
    assert laws["ffd+fb+dai-integral"].endswith("g = 100 s^3")
    assert "Theta_dot" in laws["ffd+fb+dai-integral"]
    assert laws["ffd+fb+dai"].endswith("memory 5 s")
    # wilt_yaw30 is the floor scenario itself: its baseline is the floor, so both rows are
    # marked and say why.
    assert improvement["baseline_at_noise_floor"].all()
    assert improvement["note"].str.contains("rounding").all()
    assert (improvement["paper_table"] == 6).all()
    # A tracking controller on a 3 deg/s-scale maneuver stays within a degree (sanity bound,
    # far above the 1e-3 deg the full-length run reaches).
    assert (summary["max_error_deg"] < 1.0).all()


def test_same_seed_same_runs_and_draws_by_run_index():
    a = run_method("smeresky_yaw30_coarse", "ffd+fb", runs=3, seed=7, period_scale=0.1)
    b = run_method("smeresky_yaw30_coarse", "ffd+fb", runs=2, seed=7, period_scale=0.1)
    cols = ["inertia_scale_x", "inertia_scale_y", "inertia_scale_z", "mean_tracking_error_deg"]
    # Run i depends on (seed, i) only: the first runs agree whatever the run count.
    pd.testing.assert_frame_equal(
        a.runs[cols].iloc[:3].reset_index(drop=True), b.runs[cols].reset_index(drop=True)
    )
    scales = a.runs[["inertia_scale_x", "inertia_scale_y", "inertia_scale_z"]].to_numpy()
    np.testing.assert_array_equal(scales[0], 1.0)  # row -1: the nominal vehicle
    assert (np.abs(scales[1:] - 1.0) <= 0.1).all() and (scales[1:] != 1.0).all()


def test_improvement_table_reproduces_table_9_from_table_8():
    # 001 Table 8 (FFD+FB vs DAI) -> Table 9: 91.24 %, 97.10 %, 13.10 %, computed by the same
    # function for our rows and for the paper's (paper_*_pct).
    summary = pd.DataFrame(
        {
            "scenario": ["wilt_yaw100_damage"] * 2,
            "method": ["ffd+fb", "ffd+fb+dai"],
            "mean_tracking_error_deg": [6.2142e-5, 5.4427e-6],
            "tracking_error_std_deg": [1.40e-3, 4.0650e-5],
            "control_effort_n_m_s": [22.9, 19.9],
        }
    )
    row = improvement_table(summary).iloc[0]
    for col in ("mean_tracking_error_pct", "paper_mean_pct"):
        assert row[col] == pytest.approx(91.24, abs=0.005)
    for col in ("tracking_error_std_pct", "paper_std_pct"):
        assert row[col] == pytest.approx(97.10, abs=0.005)
    for col in ("control_effort_pct", "paper_effort_pct"):
        assert row[col] == pytest.approx(13.10, abs=0.005)
    assert row["paper_table"] == 8
    assert not row["baseline_at_noise_floor"]  # no floor scenario flown: nothing to mark


def test_a_baseline_at_the_floor_is_marked_and_one_above_it_is_not():
    """The issue's example: the nominal case's 2.7e-9 deg baseline against 1.5e-8 deg reads
    -463 %, a comparison of rounding; the disturbed case (1.7e-4 deg) is a measurement."""
    summary = pd.DataFrame(
        {
            "scenario": ["wilt_yaw30"] * 2 + ["wilt_yaw30_disturbed"] * 2,
            "method": ["ffd+fb", "ffd+fb+dai"] * 2,
            "mean_tracking_error_deg": [-1.1e-9, -1.2e-9, 4.7e-4, 3.8e-4],
            "tracking_error_std_deg": [2.7e-9, 1.5e-8, 1.7e-4, 4.3e-3],
            "control_effort_n_m_s": [7.4, 7.4, 8.0, 10.8],
        }
    )
    table = improvement_table(summary).set_index("scenario")
    assert table.loc["wilt_yaw30", "baseline_at_noise_floor"]
    assert table.loc["wilt_yaw30", "tracking_error_std_pct"] == pytest.approx(-455.6, abs=0.1)
    assert not table.loc["wilt_yaw30_disturbed", "baseline_at_noise_floor"]
    assert table.loc["wilt_yaw30", "noise_floor_deg"] == pytest.approx(2.7e-9)


def test_bad_parameters_name_themselves(tmp_path):
    with pytest.raises(InputError, match="^runs must be an integer >= 0"):
        run_dai_study(tmp_path / "x", runs=-1)
    with pytest.raises(InputError, match="^scenarios must be among"):
        run_dai_study(tmp_path / "x", scenarios=("nope",))
    assert not (tmp_path / "x").exists()


def test_cli_parser_matches_library():
    assert SCENARIO_NAMES == tuple(SCENARIOS)
    parser = argparse.ArgumentParser()
    register_dai(parser.add_subparsers())
    args = parser.parse_args(["dai", "--out", "d", "--scenario", "wilt_yaw30", "--runs", "4"])
    assert (args.scenarios, args.runs, args.seed, args.overwrite) == (["wilt_yaw30"], 4, 0, False)
