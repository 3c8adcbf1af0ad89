"""Nothing unflagged reads as a finding, in the analyze report and in the loop's drivers section.

Oracle: tables whose truth is planted.  A few-failure null table (26 cases x 200 runs, 30
noise inputs, 0.2 % Bernoulli failures: 13 failed runs, no input acts) showed the defect: the
summary said "No finding", then the failure-region caption said "Failures concentrate at high
noise_007 (3 of 13 failures, 23.1 %) ..." under panels shaded "failure region", the outcomes
table printed unflagged inputs' regions, and the loop's ranking copied every input's region.
Every sentence, caption and table is read here as a reader sees it; both reports render the
one :class:`~rcsim.analysis.results.drivers.conclusions.Conclusions` object.
"""

import html
import re

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.loop.report import _drivers
from rcsim.analysis.results.drivers import findings as F
from rcsim.analysis.results.drivers.conclusions import Conclusions, conclude
from rcsim.analysis.results.drivers.inputs import load_runs
from rcsim.analysis.results.drivers.outputs import write_analysis
from rcsim.analysis.results.drivers.pipeline import Settings, analyze
from rcsim.analysis.results.drivers.synthetic import stratified_campaign


def visible(page: str) -> str:
    """The report's text as a reader sees it (images, scripts and styles dropped)."""
    page = re.sub(r"<(script|style)\b.*?</\1>", " ", page, flags=re.S)
    page = re.sub(r"<[^>]+>", " ", page)
    return re.sub(r"\s+", " ", html.unescape(page)).replace("\u00a0", " ")


@pytest.fixture(scope="module")
def null_few(tmp_path_factory):
    """The few-failure null table analysed and written: (table, result, analysis dir)."""
    X, failed, case = stratified_campaign(
        "null", 1, runs_per_case=200, n_noise=30, failure_rate=0.002
    )
    df = X.assign(case=case, failed=failed)
    rs = load_runs(df, inputs=list(X.columns), derived=False)
    res = analyze(rs, Settings(n_permutations=199, forest=False, n_splits=2))
    out = tmp_path_factory.mktemp("loop") / "drivers"
    write_analysis(res, out)
    return df, res, out


def test_the_null_table_is_the_case_in_question(null_few):
    """The table: 13 failures, no flag, and inputs whose smoothed P(fail | x) passes twice the
    base rate somewhere by chance (the regions drivers.csv keeps)."""
    df, res, out = null_few
    assert int(df["failed"].sum()) == 13
    assert F.findings(res) == []
    d = pd.read_csv(out / "drivers.csv", keep_default_na=False)
    assert (d["failure_region"] != "").sum() >= 3  # the trap: chance regions exist


def test_no_unflagged_region_reads_as_where_failures_are(null_few):
    df, res, out = null_few
    text = visible((out / "report.html").read_text())
    assert "No finding: nothing is flagged" in text
    for words in ("concentrate", "the shaded part is the failure region", "strongest driver"):
        assert words not in text, words
    assert "No failure region is drawn: no input is a flagged single driver" in text
    # Every table cell that would give a region is blank: the ranking and the outcomes' tops.
    c = conclude(res)
    assert c.ranking and all(r["failure_region"] == "" for r in c.ranking)
    rank_table = text[text.index("Driver ranking (drivers.csv") :][:3000]
    assert not re.search(r"(>=|<=|\.\.) ?-?\d", rank_table)
    top = text[text.index("Top 3 drivers of each outcome") :][:1500]
    assert not re.search(r"(>=|<=|\.\.) ?-?\d", top)
    assert "No input is a flagged driver of the failures" in text


def test_the_loop_section_renders_the_same_conclusions(null_few):
    """Issue 36 item 5: the loop's section read drivers.csv back and concluded again (its
    ranking copied every input's failure region).  Now it renders conclusions.json, the
    object the analyze report renders."""
    df, res, out = null_few
    c = Conclusions.read(out)
    assert c is not None and c.summary == conclude(res).summary
    assert c.ranking == conclude(res).ranking
    section = visible("".join(_drivers(out.parent).blocks))
    assert "No finding: nothing is flagged" in section
    assert "concentrate" not in section and "strongest driver" not in section
    assert not re.search(r"(>=|<=|\.\.) ?-?\d", section[section.index("Driver ranking") :])


def test_smaller_points_on_the_null_table(null_few):
    """No vehicle: no "Physics-aware factors" paragraph.  No case with 5 failed runs: the
    per-case family has no share, and no "p < 5 %, this family's share" is printed.  Cases
    tied at the cut of "the 5 with the most" are said to tie (counted here)."""
    df, res, out = null_few
    text = visible((out / "report.html").read_text())
    assert "Physics-aware factors" not in text
    assert "per_case" not in res.levels
    assert "this family's share" not in text.split("Per case", 2)[-1].split("Outcomes")[0]
    assert "the per-case family is not tested and has no share" in text
    per = df.groupby("case")["failed"].sum().sort_values(ascending=False, kind="stable")
    per = per[per > 0]
    cut = int(per.iloc[4])
    above, tied = per[per > cut], per[per == cut]
    assert len(above) + len(tied) > 5  # the trap: the 5th place is a tie
    names = ", ".join(above.index)
    k = int(above.sum())
    share = f"{k} of 13 ({100 * k / 13:.3g} %)"
    each = f"{cut} failure{'s' if cut != 1 else ''} each"
    assert (
        f"the {len(above)} with the most ({names}) carry {share} of all failures; "
        f"{len(tied)} more tie at {each}."
    ) in text


def test_outcome_drivers_do_not_bury_the_failures():
    """The packaged example campaign's "31 findings" were all propellant / delta-v outcome
    drivers, and the head line did not say that none concerns the failures."""
    found = [
        F.Finding("outcomes", f"x{k}", 0.001, 0.01, outcome="propellant top 10 %") for k in range(3)
    ]
    found.append(F.Finding("outcomes", "y", 0.001, 0.01, outcome="delta-v top 10 %"))
    lines = F.summary_lines(found, 0.05)
    assert lines[0] == (
        "4 findings (report-wise false-flag rate 5 %), none on the failures: no input, pair or "
        "case is a flagged driver of the runs failing the criterion; all 4 are outcome drivers "
        "(3 on propellant top 10 %, 1 on delta-v top 10 %)"
    )
    found.insert(0, F.Finding("singles", "a", 0.001, 0.02))
    assert F.summary_lines(found, 0.05)[0] == (
        "5 findings (report-wise false-flag rate 5 %): on the failures 1 single driver; beside "
        "them 4 outcome drivers (3 on propellant top 10 %, 1 on delta-v top 10 %)"
    )
    assert F.summary_lines(found, 0.05)[1] == "  single drivers: a"  # the failures first


def test_conclusions_survive_the_file(null_few):
    df, res, out = null_few
    c = conclude(res)
    back = Conclusions.from_json(c.to_json())
    assert back == c
    assert np.isfinite([r["score"] for r in back.ranking]).all()


def test_outcome_drivers_of_a_table_come_after_the_failures(null_few, tmp_path):
    """The packaged example campaign at 26 x 200 runs: 10 failures, no failure driver, 31
    outcome drivers (propellant and delta-v top 10 %), and the head line read "31 findings:
    31 outcome drivers" above a 31-row table.  The null table with a propellant column driven
    by noise_001 has the same shape: the head line says none is on the failures, the outcome
    drivers' table comes after the failures per case, and "How the runs fail" says they
    concern other outcomes."""
    df, _, _ = null_few
    rng = np.random.default_rng(11)
    df = df.assign(propellant_kg=1.0 + 0.1 * df["noise_001"] + 0.02 * rng.standard_normal(len(df)))
    inputs = [c for c in df.columns if c.startswith("noise_")]
    res = analyze(
        load_runs(df, inputs=inputs, derived=False),
        Settings(n_permutations=199, forest=False, n_splits=1),
    )
    found = F.findings(res)
    assert found and {f.family for f in found} == {"outcomes"}
    n = len(found)
    write_analysis(res, tmp_path / "an")
    text = visible((tmp_path / "an" / "report.html").read_text())
    every = "it is an outcome driver" if n == 1 else f"all {n} are outcome drivers"
    assert (
        f"{n} finding{'s' if n > 1 else ''} (report-wise false-flag rate 5 %), none on the "
        f"failures: no input, pair or case is a flagged driver of the runs failing the "
        f"criterion; {every} ({n} on propellant top 10 %)"
    ) in text
    assert text.index("Failures per case") < text.index("Outcome drivers: per axis")
    assert "concern other outcomes" in text


def test_loop_map_captions_name_the_scope_and_pair():
    from rcsim.analysis.apps.loop.report import _map_words

    assert _map_words("map_1_all_izz_kg_m2__thrust_yaw_fire_n.png") == (
        "all cases: izz_kg_m2 vs thrust_yaw_fire_n"
    )
    assert _map_words("map_2_rate-19_a__noise_01.png") == "rate-19: a vs noise_01"
