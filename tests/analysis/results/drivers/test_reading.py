"""Reading a large runs table: only the runs analysed, the same runs, the same results (issue 31).

Issue 17 drew the subsample of a table beyond ``MAX_ANALYSED_RUNS`` after reading the whole
table and deriving every run's factors (10^6 runs: 4.5 GB, a traceback under a 4 GiB limit).
Now the rows are chosen from the row count and only they are read.  Oracles:

* the rows a reader returns are the whole file's rows at those positions (``pd.read_parquet``
  / ``pd.read_csv`` and ``iloc``), to the last bit;
* the run set read as a subsample equals the one issue 17's order gives -- read everything,
  derive the factors, then draw the subsample (``pipeline._bounded``, the same draw) -- in
  every row, input, factor, outcome, case and note: the analysis of the subsample cannot
  differ from before;
* the reader never reads the whole table and reads exactly the rows analysed;
* the memory estimate refuses before anything is read, and ``yes`` lifts it.

Tables are small and the ceiling is lowered with ``monkeypatch``: what is tested is which
rows are read, not the size (memory and time are measured in benchmarks/analyze_scale.py).
"""

import json

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.results.drivers import factors, pipeline, reading
from rcsim.analysis.results.drivers.inputs import load_runs
from rcsim.analysis.results.drivers.reading import CsvReader, ParquetReader
from rcsim.models.errors import InputError

N_PER_CASE = 150
CASES = ("rate-13", "rate-14")


@pytest.fixture(scope="module")
def runs_frame(paper) -> pd.DataFrame:
    """Two yaw cases of recorded inputs drawn by the simulator's dispersion code (3x Table 5),
    a planted outcome (high yaw authority in the firing direction fails) and per-axis rate
    errors, as in test_cli_report."""
    from rcsim.analysis.engine.runs_table import input_frame
    from rcsim.models.tables import load_dispersions
    from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs

    n = len(CASES) * N_PER_CASE
    sigmas = DispersionSigmas.from_table(load_dispersions(), scale=3.0)
    frame = input_frame(draw_runs(paper.nominal(1), sigmas, 3, np.arange(n)))
    case = np.repeat(CASES, N_PER_CASE)
    auth = factors.physics_factors(frame, paper, factors.fire_signs(case))[
        "authority_yaw_fire_rad_s2"
    ]
    failed = auth.to_numpy() > np.quantile(auth, 0.8)
    rng = np.random.default_rng(0)
    err = np.where(failed, 0.06, 0.01) * rng.choice([-1, 1], n)
    ids = pd.DataFrame({"run_id": np.arange(n), "case": case, "case_index": n // N_PER_CASE})
    outcomes = pd.DataFrame(
        {
            "final_rate_err_roll_deg_s": 0.001,
            "final_rate_err_pitch_deg_s": 0.002,
            "final_rate_err_yaw_deg_s": err,
            "sim_failed": False,
            "failed": failed,
            "reason": np.where(failed, "rate error", ""),
        }
    )
    return pd.concat([ids, frame, outcomes], axis=1)


@pytest.fixture(scope="module")
def campaign(runs_frame, tmp_path_factory):
    """A campaign directory whose runs.parquet has row groups of 64 runs (a campaign writes
    one per chunk)."""
    root = tmp_path_factory.mktemp("campaign")
    runs_frame.to_parquet(root / "runs.parquet", row_group_size=64)
    manifest = {
        "spec": {"seed": 3, "runs_per_case": N_PER_CASE},
        "thresholds": {"rate_error_deg_s": 0.04, "attitude_error_deg": None},
    }
    (root / "manifest.json").write_text(json.dumps(manifest))
    return root


ROWS = np.array([0, 1, 63, 64, 65, 127, 128, 200, 299])  # across row-group boundaries


@pytest.mark.parametrize("group", [64, 1_000, 7])
def test_parquet_rows_are_the_files_rows_at_those_positions(runs_frame, tmp_path, group):
    path = tmp_path / "runs.parquet"
    runs_frame.to_parquet(path, row_group_size=group)
    expected = pd.read_parquet(path).iloc[ROWS].reset_index(drop=True)
    pd.testing.assert_frame_equal(ParquetReader(path).read_rows(ROWS), expected, check_exact=True)


def test_a_stored_index_does_not_number_the_rows_read(runs_frame, tmp_path):
    path = tmp_path / "runs.parquet"
    runs_frame.set_index(runs_frame.index * 3 + 5).to_parquet(path, row_group_size=64)
    expected = pd.read_parquet(path).iloc[ROWS].reset_index(drop=True)
    pd.testing.assert_frame_equal(ParquetReader(path).read_rows(ROWS), expected, check_exact=True)


def test_csv_rows_are_the_files_rows_at_those_positions(runs_frame, tmp_path):
    path = tmp_path / "runs.csv"
    runs_frame.to_csv(path, index=False)
    reader = CsvReader(path)
    assert reader.n_rows == len(runs_frame)
    expected = pd.read_csv(path).iloc[ROWS].reset_index(drop=True)
    pd.testing.assert_frame_equal(reader.read_rows(ROWS), expected, check_exact=True)


def _issue17(source, seed, monkeypatch, case=None, limit=200):
    """The run set issue 17's order gave: every run read and derived, then the subsample."""
    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", 10**9)
    whole = load_runs(source, case=case)
    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", limit)
    return pipeline._bounded(whole, seed)


def _assert_same_runset(a, b):
    pd.testing.assert_frame_equal(a.X, b.X, check_exact=True)
    pd.testing.assert_frame_equal(a.runs, b.runs, check_exact=True)
    np.testing.assert_array_equal(a.y, b.y)
    np.testing.assert_array_equal(a.strata, b.strata)
    assert a.notes == b.notes
    assert (a.raw_inputs, a.derived_inputs) == (b.raw_inputs, b.derived_inputs)
    assert (a.total_runs, a.total_failed) == (b.total_runs, b.total_failed)


@pytest.mark.parametrize(("case", "limit"), [(None, 200), ("rate-14", 100)])
def test_the_subsample_read_is_the_subsample_drawn_after_reading(
    campaign, monkeypatch, case, limit
):
    before = _issue17(campaign, 5, monkeypatch, case=case, limit=limit)
    now = load_runs(campaign, case=case, seed=5)
    assert now.y.size == limit and now.subsampled
    assert now.total_runs == (N_PER_CASE if case else len(CASES) * N_PER_CASE)
    _assert_same_runset(now, before)
    note = now.notes[-1]
    assert f"{limit:,} of the {now.total_runs:,} runs" in note and "seed 5" in note


def test_a_dataframe_is_subsampled_before_its_factors(runs_frame, monkeypatch):
    before = _issue17(runs_frame, 2, monkeypatch)
    _assert_same_runset(load_runs(runs_frame, seed=2), before)


def test_a_case_that_fits_is_read_alone_and_whole(campaign, monkeypatch):
    """A table beyond the ceiling whose case fits: that case's runs, all of them, as the
    whole table filtered gives them (nothing is subsampled, no note)."""
    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", 10**9)
    whole = load_runs(campaign, case="rate-13")
    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", 200)
    now = load_runs(campaign, case="rate-13")
    assert now.total_runs is None and not now.subsampled and now.y.size == N_PER_CASE
    _assert_same_runset(now, whole)


def test_only_the_runs_analysed_are_read(campaign, monkeypatch):
    """The whole table is never read: the outcome column of every run, then the rows
    analysed, every column of them."""
    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", 120)
    calls = []

    def refuse(self):
        raise AssertionError("the whole table was read")

    real_columns, real_rows = ParquetReader.read_columns, ParquetReader.read_rows
    monkeypatch.setattr(ParquetReader, "read_all", refuse)
    monkeypatch.setattr(
        ParquetReader,
        "read_columns",
        lambda self, cols: calls.append(("columns", cols)) or real_columns(self, cols),
    )
    monkeypatch.setattr(
        ParquetReader,
        "read_rows",
        lambda self, rows: calls.append(("rows", len(rows))) or real_rows(self, rows),
    )
    load_runs(campaign, seed=1)
    assert calls == [("columns", ["failed"]), ("rows", 120)]


def test_the_same_seed_draws_the_same_runs_and_another_seed_others(monkeypatch):
    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", 1_000)
    a, b, c = (reading.analysed_rows(50_000, s) for s in (4, 4, 5))
    np.testing.assert_array_equal(a, b)
    assert a.size == np.unique(a).size == 1_000 and (np.diff(a) > 0).all()
    assert not np.array_equal(a, c)
    assert reading.analysed_rows(1_000, 4) is None  # a table that fits: every run
    # Issue 17's draw, unchanged: a table analysed before this change gets the same runs.
    rng = np.random.default_rng(np.random.SeedSequence([4, 0x5AB5]))
    np.testing.assert_array_equal(a, np.sort(rng.choice(50_000, 1_000, replace=False)))


def test_factors_in_blocks_are_the_factors_at_once(runs_frame, paper, monkeypatch):
    """Each run's factors are its own arithmetic: blocks of 7 runs give the same bits as one
    block of all."""
    signs = factors.fire_signs(runs_frame["case"])
    once = factors.physics_factors(runs_frame, paper, signs)
    monkeypatch.setattr(factors, "FACTOR_BLOCK_RUNS", 7)
    pd.testing.assert_frame_equal(
        factors.physics_factors(runs_frame, paper, signs), once, check_exact=True
    )


def test_fire_signs_of_many_runs_are_each_runs_case():
    names = ["rate-13", "damp-13", "rate-01", "rate-13"]
    np.testing.assert_array_equal(
        factors.fire_signs(names), np.stack([factors.fire_signs([n])[0] for n in names])
    )
    assert factors.fire_signs(["rate-13", None]) is None  # a missing case is no rate case


def test_the_memory_estimate_refuses_before_reading(campaign, monkeypatch):
    monkeypatch.setattr(reading, "memory_budget_bytes", lambda: 2**20)
    monkeypatch.setattr(ParquetReader, "read_all", lambda self: pytest.fail("read"))
    with pytest.raises(InputError) as err:
        load_runs(campaign)
    assert err.value.parameter == "yes"
    assert f"{len(CASES) * N_PER_CASE:,} runs" in str(err.value)
    assert "1 MiB allowed" in str(err.value)


def test_yes_reads_a_table_over_the_estimate(campaign, monkeypatch):
    monkeypatch.setattr(reading, "memory_budget_bytes", lambda: 2**20)
    assert load_runs(campaign, yes=True).y.size == len(CASES) * N_PER_CASE


def test_the_estimate_grows_with_runs_up_to_the_subsample_and_with_columns():
    """Beyond the ceiling only the first pass grows with the runs; the rest with the runs
    analysed times the columns (the module's constants)."""
    a = reading.analysis_bytes(10**6, 100)
    b = reading.analysis_bytes(2 * 10**6, 100)
    assert b - a == 10**6 * reading.FIRST_PASS_BYTES_PER_RUN
    c = reading.analysis_bytes(10**6, 200)
    assert c - a == reading.MAX_ANALYSED_RUNS * 100 * reading.BYTES_PER_CELL


def test_cli_refuses_without_yes_in_one_line_and_writes_nothing(
    campaign, tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr(reading, "memory_budget_bytes", lambda: 2**20)
    out = tmp_path / "drivers"
    assert main(["analyze", str(campaign), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rcsim: error: --yes not given")
    assert "runs.parquet" in err[0] and not out.exists()


def test_cli_and_report_say_how_many_runs_were_analysed_of_how_many(
    campaign, tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", 200)
    out = tmp_path / "drivers"
    argv = ["analyze", str(campaign), "--permutations", "19", "--seed", "3", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    rs = load_runs(campaign, seed=3)
    total = len(CASES) * N_PER_CASE
    assert f"200 of {total} runs analysed" in printed
    assert f"{int(rs.y.sum())} failed of them ({rs.total_failed} of all)" in printed
    html = (out / "report.html").read_text()
    assert f"200 analysed of {total}" in html
    assert f"{rs.total_failed} of {total} (" in html and "of all" in html
    # The "all runs" probability counts every run of the table, not the subsample (the
    # reading counted them all): summary.csv's row is the whole table's count.
    row = pd.read_csv(out / "summary.csv").iloc[0]
    assert row["scope"] == "all runs"
    assert (int(row["runs"]), int(row["failed"])) == (total, rs.total_failed)


def test_cli_help_names_the_ceiling():
    from rcsim.analysis.apps.cli import build_parser

    helps = build_parser()._subparsers._group_actions[0].choices["analyze"].format_help()
    assert f"{reading.MAX_ANALYSED_RUNS:,}" in " ".join(helps.split())
