"""The sensor, timing and fault draws of a campaign are driver inputs by default (issue 17).

Before, ``rcsim analyze`` left them out unless named, and refused ``fault_time_s`` because runs
without a fault hold NaN there.  The claims: by default every recorded effect column is an
input; a "does not apply" NaN becomes a place on the scale beyond every run that had the event
(``runs_table.EFFECT_NOT_APPLICABLE``), with a note; a planted fault-time driver is found.
"""

import numpy as np
import pandas as pd

from rcsim.analysis.engine import runs_table
from rcsim.analysis.results.drivers.inputs import load_runs
from rcsim.analysis.results.drivers.pipeline import Settings, analyze


def _fault_runs(n: int = 400, seed: int = 3) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    frame = pd.DataFrame({c: rng.normal(1.0, 0.1, n) for c in runs_table.input_names(16)})
    frame.insert(0, "run_id", np.arange(n))
    frame["case"] = "rate-13"
    has_fault = rng.uniform(size=n) < 0.5
    frame["fault_jet"] = np.where(has_fault, 13, 0)
    frame["fault_time_s"] = np.where(has_fault, rng.uniform(0.0, 20.0, n), np.nan)
    frame["fault_stuck_for_s"] = np.nan
    frame["fault_thrust_factor"] = 1.0
    # Planted truth: a fault in the first 4 s fails the run; nothing else does.
    frame["failed"] = has_fault & (frame["fault_time_s"] < 4.0)
    return frame


def test_fault_columns_are_inputs_and_their_nan_means_never():
    runset = load_runs(_fault_runs(), derived=False)
    assert "fault_time_s" in runset.X.columns and "fault_jet" in runset.X.columns
    assert np.isfinite(runset.X["fault_time_s"]).all()
    latest = _fault_runs()["fault_time_s"].max()
    no_fault = _fault_runs()["fault_time_s"].isna().to_numpy()
    assert (runset.X["fault_time_s"].to_numpy()[no_fault] > latest).all()
    assert any(n.startswith("fault_time_s:") for n in runset.notes)
    # Never-applicable columns are constant and left out, with the usual note.
    assert "fault_stuck_for_s" not in runset.X.columns


def test_a_planted_fault_time_driver_ranks_first():
    res = analyze(load_runs(_fault_runs(), derived=False), Settings(n_permutations=99))
    top = res.drivers.sort_values("rank").iloc[0]
    assert top["factor"] == "fault_time_s" and bool(top["significant"])


def test_a_table_beyond_the_ceiling_is_subsampled_and_says_so(monkeypatch):
    """Issue 17: 10^6 runs needed 8 GB.  Beyond MAX_ANALYSED_RUNS the analysis reads a seeded
    uniform subsample of that size and adds a note naming both counts; the same seed gives the
    same subsample (the result is reproducible)."""
    from rcsim.analysis.results.drivers import reading

    monkeypatch.setattr(reading, "MAX_ANALYSED_RUNS", 300)
    runs = _fault_runs(n=400)
    a = analyze(load_runs(runs, derived=False), Settings(n_permutations=19))
    b = analyze(load_runs(runs, derived=False), Settings(n_permutations=19))
    assert a.runset.y.size == 300
    note = next(n for n in a.runset.notes if "subsample" in n)
    assert "300 of the 400 runs" in note
    pd.testing.assert_frame_equal(a.drivers, b.drivers)
    assert a.runset.runs["run_id"].is_monotonic_increasing


def test_named_nan_input_says_which_runs_lack_it(tmp_path, capsys):
    """Issue 38: ``rcsim analyze --inputs fault_time_s`` (NaN for runs without a fault) must
    not analyse the input without a word.  The command prints, and the report's summary
    states, how many runs lack it (counted here) and where they were placed: none left out."""
    import re

    from rcsim.analysis.apps.cli import main

    frame = _fault_runs()
    path = tmp_path / "runs.csv"
    frame.to_csv(path, index=False)
    out = tmp_path / "an"
    args = ["analyze", str(path), "--inputs", "fault_time_s,fault_jet"]
    assert main([*args, "--permutations", "19", "--out", str(out)]) == 0
    k, n = int(frame["fault_time_s"].isna().sum()), len(frame)
    printed = capsys.readouterr().out
    assert f"note: fault_time_s: {k} run(s) without it; a run without a fault" in printed
    page = re.sub(r"<[^>]+>", " ", (out / "report.html").read_text())
    page = re.sub(r"\s+", " ", page)
    assert f"runs without fault_time_s {k:,} of {n:,}: none left out; a run without a fault" in (
        page
    )
