"""``rcsim campaign rare`` end to end on a tiny spec (case 13, 3 s, Table 5 x 3), where the
thresholds make failures common enough to check against plain counting (issue 30).

Oracles: the runs table's own ``failed`` column (a run fails exactly when its margin is not
>= 0); the campaign's seeded runs (level 0 is the campaign's first N runs of the case, the same
rows); plain counting of level 0 when failures are not rare (the estimator's ``monte_carlo``
status is ``k / N`` exactly); an uninterrupted estimation (a resumed one gives the same result,
bit for bit, and flies no finished level again).
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.apps.rare import estimate as rare_estimate
from rcsim.analysis.apps.rare.estimate import estimate_cases
from rcsim.analysis.apps.rare.flights import CaseLimitState
from rcsim.analysis.apps.rare.settings import RareSettings
from rcsim.analysis.apps.rare.words import case_sentence
from rcsim.analysis.engine.campaign.chunk import Chunk, simulate_chunk
from rcsim.analysis.engine.campaign.cluster import close, connect
from rcsim.analysis.engine.campaign.spec import load_spec

SPEC = """
seed = 3
runs_per_case = 200
[scenario]
kind = "rate-cases"
cases = [13]
duration_s = 3.0
[controller]
name = "lookup"
[dispersions]
scale = 3.0
[failure]
rate_error_deg_s = {thr}
[output]
histories = "none"
plots = false
"""


def _spec(tmp_path: Path, thr: float) -> Path:
    path = tmp_path / f"spec-{thr:g}.toml"
    path.write_text(SPEC.format(thr=thr))
    return path


def _rare(spec: Path, out: Path, *extra: str, repeats: str = "1") -> int:
    return main(
        [
            "campaign",
            "rare",
            str(spec),
            "--out",
            str(out),
            "--runs-per-level",
            "100",
            "--repeats",
            repeats,
            "--workers",
            "1",
            *extra,
        ]
    )


def test_common_failures_give_plain_counting_of_the_campaigns_runs(tmp_path, capsys):
    """At 0.02 deg/s about half the runs fail: level 0 holds more than p0 N = 10 failures, so
    the estimate is plain Monte Carlo of level 0, k / 100 exactly; level 0's rows are the
    campaign's runs 0-99 of the case, column for column; failed == ~(margin >= 0) on every
    row; the printed line is the one built from rare.json's figures."""
    spec_path = _spec(tmp_path, 0.02)
    out = tmp_path / "out"
    assert _rare(spec_path, out, "--budget", "1000") == 0
    printed = capsys.readouterr().out
    record = json.loads((out / "rare.json").read_text())["cases"]["rate-13"]
    runs = pd.read_parquet(out / "runs.parquet")
    assert record["status"] == "monte_carlo" and record["runs"] == 100 == len(runs)
    k = int(runs["failed"].sum())
    assert 10 <= k < 100
    assert record["probability"] == k / 100
    assert case_sentence("rate-13", record) in printed
    np.testing.assert_array_equal(runs["failed"], ~(runs["margin"] >= 0))
    campaign = simulate_chunk(load_spec(spec_path), Chunk(0, 100)).runs
    pd.testing.assert_frame_equal(runs[campaign.columns], campaign)
    failures = pd.read_parquet(out / "failures.parquet")
    assert len(failures) == k and failures["failed"].all()


@pytest.fixture(scope="module")
def rarer(tmp_path_factory) -> Path:
    """One estimation at 0.05 deg/s (about 5 % fail), one repeat, budget 1000: its DIR."""
    tmp = tmp_path_factory.mktemp("rarer")
    out = tmp / "out"
    assert _rare(_spec(tmp, 0.05), out, "--budget", "1000") == 0
    return out


def test_rarer_failures_go_through_levels(rarer):
    """At 0.05 deg/s about 5 % fail: level 0 finds fewer than 10, a second level is flown
    (chain runs outside the campaign's range of ids), the estimate converges with an interval
    holding it, and every row still satisfies failed == ~(margin >= 0)."""
    out = rarer
    record = json.loads((out / "rare.json").read_text())["cases"]["rate-13"]
    runs = pd.read_parquet(out / "runs.parquet")
    assert record["status"] == "converged" and record["levels"] >= 2
    assert record["interval"][0] < record["probability"] < record["interval"][1]
    assert len(runs) == record["runs"] and runs["rare_eval_id"].is_unique
    assert set(runs["rare_level"]) == set(range(record["levels"]))
    assert (runs.loc[runs["rare_level"] > 0, "run_id"] >= 2**31).all()
    np.testing.assert_array_equal(runs["failed"], ~(runs["margin"] >= 0))
    assert record["failures_found"] == int(runs["failed"].sum())


class _Killed(Exception):
    pass


def _killed_then_resumed(spec, tmp_path: Path, monkeypatch) -> None:
    """Estimate case 0 whole, then killed after level 0 and resumed: the same record and rows,
    and only the runs after level 0's 100 flown again."""
    settings = RareSettings(n_per_level=100, budget=1000, repeats=1)
    whole = estimate_cases(spec, [0], settings, tmp_path / "whole")

    def die(line: str) -> None:
        raise _Killed(line)

    out = tmp_path / "killed"
    with pytest.raises(_Killed):
        estimate_cases(spec, [0], settings, out, progress=die)
    flown = []
    real = CaseLimitState.criterion_margins

    def counting(self, u, ids):
        flown.append(u.shape[0])
        return real(self, u, ids)

    monkeypatch.setattr(CaseLimitState, "criterion_margins", counting)
    resumed = estimate_cases(spec, [0], settings, out)
    assert resumed == whole
    assert sum(flown) == whole["rate-13"]["runs"] - 100
    whole_runs = pd.read_parquet(tmp_path / "whole" / rare_estimate.RUNS)
    pd.testing.assert_frame_equal(pd.read_parquet(out / rare_estimate.RUNS), whole_runs)


def test_killed_estimation_resumes_at_its_last_level(tmp_path, monkeypatch):
    """Killed after level 0, the estimation resumes from the state file: the same record as an
    uninterrupted run's, and level 0's 100 runs are not flown again."""
    spec = load_spec(_spec(tmp_path, 0.05))
    _killed_then_resumed(spec, tmp_path, monkeypatch)


def test_never_reached_is_a_stated_bound(tmp_path, capsys):
    """A threshold no run reaches in a budget of level 0 alone: exit 0, no estimate, the
    one-sided 95 % bound for 0 failures in 100 runs (1 - 0.05^(1/100) = 0.0295)."""
    out = tmp_path / "out"
    assert _rare(_spec(tmp_path, 100.0), out, "--budget", "100") == 0
    record = json.loads((out / "rare.json").read_text())["cases"]["rate-13"]
    assert record["status"] == "not_resolved" and record["probability"] is None
    assert record["upper_bound"] == pytest.approx(1 - 0.05 ** (1 / 100), rel=1e-9)
    assert "not resolved" in capsys.readouterr().out


def test_always_failing_case_is_a_stated_result(tmp_path, capsys):
    """A threshold every run misses: P = 1 by plain counting, said in words."""
    out = tmp_path / "out"
    assert _rare(_spec(tmp_path, 1e-6), out, "--budget", "100") == 0
    record = json.loads((out / "rare.json").read_text())["cases"]["rate-13"]
    assert record["status"] == "monte_carlo" and record["probability"] == 1.0
    assert "every one of the first 100 runs failed" in capsys.readouterr().out


def test_repeats_are_the_campaigns_runs_then_combined_the_same_on_any_worker_count(tmp_path):
    """Two repeats of 100 at 0.05 deg/s (about 5 % fail): level 0 of repeat k is the
    campaign's runs 100 k .. 100 k + 99 of the case (K N = 200 <= runs_per_case), row for row;
    the record's probability is the mean of the repeats' and its CoV their spread,
    s / (sqrt(2) mean), or Au & Beck's for that mean if larger (rcsim.analysis.engine.rare.
    repeats); flown on two worker processes the
    record and every row are the same, bit for bit, as in this process, and on a Dask
    cluster's two workers."""
    spec_path = _spec(tmp_path, 0.05)
    spec = load_spec(spec_path)
    settings = RareSettings(n_per_level=100, budget=560, repeats=2)  # levels 0-2 of each
    one = estimate_cases(spec, [0], settings, tmp_path / "one", workers=1)["rate-13"]
    two = estimate_cases(spec, [0], settings, tmp_path / "two", workers=2)["rate-13"]
    client, cluster = connect(2, None)  # a local Dask cluster, as `--scheduler` would reach
    try:
        dask = estimate_cases(spec, [0], settings, tmp_path / "dask", client=client)["rate-13"]
    finally:
        close(client, cluster)
    assert one == two == dask
    runs = pd.read_parquet(tmp_path / "one" / rare_estimate.RUNS)
    for other in ("two", "dask"):
        pd.testing.assert_frame_equal(runs, pd.read_parquet(tmp_path / other / rare_estimate.RUNS))
    parts = [r["probability"] for r in one["repeats"]]
    assert one["method"] == "subset simulation, 2 independent repeats"
    assert one["probability"] == pytest.approx(np.mean(parts), rel=1e-12)
    measured = np.std(parts, ddof=1) / (np.sqrt(2) * np.mean(parts))
    model = np.sqrt(sum(r["cov_model"] ** 2 for r in one["repeats"])) / 2
    assert one["cov"] == pytest.approx(max(measured, model))
    assert one["runs"] == sum(r["runs"] for r in one["repeats"]) == len(runs)
    campaign = simulate_chunk(spec, Chunk(0, 200)).runs
    level0 = runs[runs["rare_level"] == 0].sort_values("run_id").reset_index(drop=True)
    assert list(level0["rare_repeat"]) == [0] * 100 + [1] * 100
    pd.testing.assert_frame_equal(level0[campaign.columns], campaign)
    np.testing.assert_array_equal(runs["failed"], ~(runs["margin"] >= 0))
    assert runs["rare_eval_id"].is_unique and runs["run_id"].is_unique


def test_analyze_says_a_rare_runs_table_is_not_a_monte_carlo_sample(rarer, tmp_path, capsys):
    """`rcsim analyze` on the command's runs.parquet: its first note and its probability line
    say the fraction failed is that of conditional samples, not the case's P(fail)."""
    from rcsim.analysis.results.drivers.inputs import RARE_NOTE, load_runs

    out = rarer
    runset = load_runs(out / rare_estimate.RUNS, vehicle="paper")
    assert runset.conditional and runset.notes[0] == RARE_NOTE
    capsys.readouterr()
    argv = ["analyze", str(out / rare_estimate.RUNS), "--vehicle", "paper", "--inputs"]
    # Two inputs and 19 permutations: what is tested is what the command says, not the drivers.
    assert (
        main(
            [
                *argv,
                "iyy_kg_m2,jet_11_thrust_n",
                "--permutations",
                "19",
                "--out",
                str(tmp_path / "a"),
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "failure fraction of these runs" in printed and "not the cases' P(fail)" in printed
    assert f"note: {RARE_NOTE}" in printed
    assert "\nfailure probability" not in "\n" + printed


#: Case 13 with a rate and an attitude criterion.  Measured on the campaign's first 4,000 runs
#: of this spec (seed 3): the worst final rate error reaches 0.0595 deg/s in about 0.1 % of
#: runs, the final attitude error exceeds 0.21 deg in about 1.5 %: the attitude criterion
#: dominates P(fail) (benchmarks/rare_event_criteria.py compares with plain Monte Carlo).
SPEC_TWO = SPEC.replace(
    "rate_error_deg_s = {thr}", "rate_error_deg_s = 0.0595\nattitude_error_deg = 0.21"
)


def test_two_criteria_each_estimated_on_its_own_margin(tmp_path, capsys):
    """A spec with a rate and an attitude criterion: each is estimated on its own margin from
    the shared level 0, the attitude one -- the more frequent failure -- is explored (its own
    chains found failures of it) and the record combines them by series-system bounds, every
    figure recomputed from the criteria's; each row's criterion margins carry the row's own
    verdicts (failed_by), and a run fails exactly when one of them is below 0."""
    from rcsim.analysis.apps.rare.flights import criterion_margins

    spec_path = tmp_path / "two.toml"
    spec_path.write_text(SPEC_TWO)
    out = tmp_path / "out"
    assert _rare(spec_path, out, "--budget", "1000") == 0
    printed = capsys.readouterr().out
    record = json.loads((out / "rare.json").read_text())["cases"]["rate-13"]
    crit = record["criteria"]
    assert list(crit) == ["rate", "attitude"]
    att, rate = crit["attitude"], crit["rate"]
    assert att["status"] != "not_resolved" and att["failures_found"] > 0
    assert record["status"] in ("converged", "budget", "partial")
    ends = [c["interval"] or [0.0, c["upper_bound"]] for c in (rate, att)]
    assert record["interval"][0] == max(e[0] for e in ends)
    assert record["interval"][1] == pytest.approx(min(1.0, sum(e[1] for e in ends)))
    assert record["criterion_confidence"] == pytest.approx(0.975)
    assert att["probability"] > (rate["probability"] or rate["upper_bound"] / 10)
    assert record["runs"] <= 1000
    spec = load_spec(spec_path)
    runs = pd.read_parquet(out / rare_estimate.RUNS)
    assert runs["rare_eval_id"].is_unique and len(runs) == record["runs"]
    assert set(runs["rare_criterion"]) == {"", "rate", "attitude"}
    m = criterion_margins(spec, runs)
    np.testing.assert_array_equal(runs["failed"], np.any(~(m >= 0), axis=1))
    for i, name in enumerate(["rate", "attitude"]):
        flagged = np.array([name in str(v).split("+") for v in runs["failed_by"]])
        np.testing.assert_array_equal(flagged, m[:, i] < 0)
    lo, hi = record["interval"]
    assert f"{lo:.3g} - {hi:.3g}" in printed and "series-system bounds over 2 criteria" in printed


def _series_record(status, interval, bound, rate, attitude, unexplored=()):
    def crit(c):
        p, lo, hi, ub = c
        return {
            "status": "not_resolved" if p is None else "converged",
            "probability": p,
            "interval": None if p is None else [lo, hi],
            "upper_bound": ub,
        }

    return {
        "method": "subset simulation per criterion (2 criteria), series-system bounds",
        "status": status,
        "probability": None if interval is None else interval[0] * 2,
        "cov": None,
        "interval": interval,
        "upper_bound": bound,
        "confidence": 0.95,
        "criterion_confidence": 0.975,
        "runs": 5000,
        "failures_found": 0,
        "reason": "the region of criterion 'attitude' (its own chains saw no failure of it; 7 "
        "of the points flown for the other criteria failed it) was not explored, so no bound "
        "or interval on P(fail) can be stated; to resolve it: more runs per level "
        "(--runs-per-level) or a larger budget (--budget)",
        "plain_mc_runs_same_cov": None,
        "closest_failure": None,
        "criteria": {"rate": crit(rate), "attitude": crit(attitude)},
        "unexplored": list(unexplored),
    }


def test_words_of_a_case_of_several_criteria():
    """The line and the loop's table cell say what the record holds: the series interval and
    each criterion's figures; for a criterion not explored, its name and what would resolve it,
    and no figure of P at all (no bound, no interval)."""
    from rcsim.analysis.apps.loop.rare import rare_rows
    from rcsim.analysis.apps.rare.words import interval_text

    rec = _series_record(
        "partial", [1e-5, 3e-5], None, (2e-5, 1e-5, 2.5e-5, None), (None, 0, 0, 5e-6)
    )
    text = case_sentence("rate-13", rec)
    assert "P(fail) = 2e-05 (95% interval 1e-05 - 3e-05)" in text
    assert "rate P = 2e-05 (1e-05 - 2.5e-05), attitude no failure, P < 5e-06" in text
    assert "their bounds enter the upper end" in text
    bad = _series_record(
        "not_explored", None, None, (2e-5, 1e-5, 2.5e-5, None), (None, 0, 0, 5e-6), ["attitude"]
    )
    text = case_sentence("rate-13", bad)
    assert "'attitude'" in text and "--runs-per-level" in text and "--budget" in text
    assert "P =" not in text and "P <" not in text and "P(fail) =" not in text
    assert interval_text(bad) == "none: attitude not explored"
    selection = pd.DataFrame({"case": ["rate-13"], "failed": [0], "runs": [200]})
    row = rare_rows({"cases": {"rate-13": bad}}, selection).iloc[0]
    assert row["95 % interval"] == "none: attitude not explored" and row["P(fail)"] == "-"
    assert "not explored: no bound, no interval" in row["method"]


def test_two_criteria_resume_the_same_without_flying_a_run_again(tmp_path, monkeypatch):
    """Killed after level 0, an estimation of two criteria resumes: the same record and rows
    as an uninterrupted one, and no run already flown is flown again (the criteria's margins of
    the runs flown are read back from the batch files)."""
    spec_path = tmp_path / "two.toml"
    spec_path.write_text(SPEC_TWO)
    spec = load_spec(spec_path)
    _killed_then_resumed(spec, tmp_path, monkeypatch)
