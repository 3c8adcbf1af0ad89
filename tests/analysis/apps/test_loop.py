"""The analyst's loop (``rcsim loop``; issue 10's flagship): stages, resume, the report.

Oracles: the loop is the composition of commands tested on their own (campaign, analyze,
refine), so these tests check the composition: every stage's output exists and agrees with the
others (the search baseline *is* the "before" campaign: same seed, same runs, same failure
count; the held-out "after" numbers *are* the "after" campaign's), a stopped loop resumes, and
the report renders in a real browser with every section.  Small settings (6 runs of 6 s per
case, 19 permutations) keep it near 20 s.
"""

import html
import json
from pathlib import Path

import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.apps.loop.run import STAGES, LoopSettings, run_loop
from rcsim.models.errors import InputError
from rcsim.models.tables import load_lookup_table

# The rare-event stage on one case, level 0 of its 4 repeats (2,000 runs of 6 s: a few seconds).
SMALL = LoopSettings(
    runs_per_case=6,
    duration_s=6.0,
    permutations=19,
    max_iterations=3,
    rare_budget=2000,
    rare_cases=1,
)
SECTIONS = (
    "summary",
    "before-after",
    "figs-9-10",
    "propellant",
    "drivers",
    "changelog",
    "rare",
    "traceability",
)


@pytest.fixture(scope="module")
def loop_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("loop") / "L"
    run_loop(SMALL, out, progress=False, echo=lambda line: None)
    return out


def test_every_stage_done_and_consistent(loop_dir):
    state = json.loads((loop_dir / "loop.json").read_text())
    assert list(state["done"]) == list(STAGES)
    log = pd.read_csv(loop_dir / "refined_table_changelog.csv")
    before = pd.read_csv(loop_dir / "campaign_before" / "cases.csv")
    after = pd.read_csv(loop_dir / "campaign_after" / "cases.csv")
    # The search's "before" is the campaign with the table; the check's "after" on the fresh
    # seed is the campaign with the refined table.
    assert log["failed_search_before"].tolist() == before["failed"].tolist()
    assert log["failed_fresh_after"].tolist() == after["failed"].tolist()
    refined = load_lookup_table(loop_dir / "refined_table.csv")
    assert refined.case.tolist() == list(range(1, 27))
    assert (loop_dir / "drivers" / "report.html").is_file()


def test_resume_skips_finished_stages_and_refuses_other_settings(loop_dir):
    lines = []
    record = (loop_dir / "loop.json").read_bytes()
    run_loop(SMALL, loop_dir, resume=True, progress=False, echo=lines.append)
    assert lines == [f"{stage}: already done" for stage in STAGES]
    # A resume that did nothing left the record as it was: finished_utc is when it finished.
    assert (loop_dir / "loop.json").read_bytes() == record
    with pytest.raises(InputError, match="other settings"):
        run_loop(
            LoopSettings(runs_per_case=9, duration_s=6.0),
            loop_dir,
            resume=True,
            progress=False,
            echo=lambda line: None,
        )


def test_report_renders_with_every_section(loop_dir, render_page, tmp_path):
    dom = render_page(loop_dir / "report.html", tmp_path / "loop_report.png")
    assert 'data-loaded="yes"' in dom
    assert '<pre id="js-errors"></pre>' in dom  # no JavaScript error
    for anchor in SECTIONS:
        assert f'id="{anchor}"' in dom
    assert "Table 7" in dom  # the cell-by-cell comparison with the paper's refinement
    assert (tmp_path / "loop_report.png").stat().st_size > 10_000


def test_cli_refuses_an_existing_loop_without_resume(loop_dir, capsys):
    assert main(["loop", "--out", str(loop_dir)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(loop_dir) in err


@pytest.mark.slow
def test_sigterm_after_the_campaign_stops_with_143_one_line_and_resumes(tmp_path):
    """Issue 17, defect 5: SIGTERM to `rcsim loop` outside a campaign stage killed it with no
    message, and inside one exited 130.  Sent once the first campaign is done (the drivers or
    refine stage is running): one line naming the signal and the command that resumes, exit
    143 = 128 + SIGTERM, and that command finishes the loop."""
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "L"
    cmd = [sys.executable, "-m", "rcsim", "loop", "--runs-per-case", "30", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None:
            state = out / "loop.json"
            if state.is_file() and "campaign_before" in json.loads(state.read_text())["done"]:
                break
            time.sleep(0.02)
        assert proc.poll() is None, "the loop ended before it could be stopped"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    assert err == f"rcsim: terminated; resume with: rcsim loop --out {out} --resume\n", err
    done = json.loads((out / "loop.json").read_text())["done"]
    assert "report" not in done
    rc = main(["loop", "--out", str(out), "--resume"])
    assert rc == 0
    assert set(json.loads((out / "loop.json").read_text())["done"]) == set(STAGES)


@pytest.mark.slow
def test_loop_with_the_paper_vehicle_file_flies_the_same_loop(tmp_path):
    """Issue 18: `rcsim loop --vehicle FILE`.  The paper's vehicle as a file (the packaged
    `paper` vehicle) gives the loop of the packaged MJCF: the same runs in every campaign and
    the same refined table (the vehicle file is the paper's model, array for array)."""
    base = dict(runs_per_case=6, duration_s=8.0, plots=False, search_runs_per_case=6)
    a = run_loop(LoopSettings(**base), tmp_path / "a", echo=lambda _: None)
    b = run_loop(LoopSettings(**base, vehicle="paper"), tmp_path / "b", echo=lambda _: None)
    for name in ("campaign_before", "campaign_after", "campaign_check"):
        pd.testing.assert_frame_equal(
            pd.read_parquet(a.out / name / "runs.parquet"),
            pd.read_parquet(b.out / name / "runs.parquet"),
        )
    assert (a.out / "refined_table.csv").read_text() == (b.out / "refined_table.csv").read_text()
    assert 'vehicle = "paper"' in (b.out / "spec_before.toml").read_text()
    # Issue 18 review: the report names the vehicle file (its [vehicle] name and SHA-256) and
    # says its own [dispersions] flew, not Table 5's (the same values for this file, but the
    # vehicle file's table is what the spec flies: rcsim/analysis/engine/campaign/spec.py).
    import hashlib
    import html

    from rcsim.spacecraft.vehicle import load_vehicle, resolve_vehicle

    report = html.unescape((b.out / "report.html").read_text())
    digest = hashlib.sha256(resolve_vehicle("paper").read_bytes()).hexdigest()
    assert repr(load_vehicle("paper").name) in report and digest in report
    assert "26 rate cases of Table 3, the vehicle file's [dispersions]" in report
    packaged = html.unescape((a.out / "report.html").read_text())
    assert "26 rate cases of Table 3, Table 5 dispersions" in packaged


def test_report_prints_to_pdf_with_nothing_cut(loop_dir, print_report):
    """Issue 16: printed to PDF, the changelog and driver tables lost their columns and the
    summary values were cut off.  Headless Chromium prints the page; every character and every
    table row (header row included: each changelog and driver column; each summary value) is
    in the PDF's text (the fixture's oracle)."""
    pdf, captions, problems = print_report(loop_dir / "report.html")
    assert problems == []
    for table in ("The loop", "Driver ranking", "Changed entries"):
        assert any(c.startswith(table) for c in captions), (table, captions)


def test_report_tables_fit_a_1400_px_screen(loop_dir, screen_tables):
    """Issue 16: on screen the changelog was cut at 1,400 px.  Laid out 1,400 px wide, no
    table is wider than its box (cells and column names wrap first)."""
    tables = screen_tables(loop_dir / "report.html")
    assert tables
    assert [t for t in tables if t[1] > t[2]] == []


def test_vehicle_refusal_names_the_file_once(tmp_path, capsys):
    """Issue 18 review: `rcsim loop --vehicle FILE` on a layout that cannot fly a rate case
    said "--vehicle FILE: vehicle: FILE cannot fly ...": the file once, no key repeated.
    The vehicle is the corpus's 10-jet bus without its forward yaw jets and with one aft jet
    of every pod: no jet combination turns it toward -roll (``rcsim vehicle check``)."""
    text = (Path(__file__).parent / "cli" / "corpus" / "files" / "mybus10.toml").read_text()
    head, *jets = text.split("\n[[jet]]\n")
    vehicle = tmp_path / "fourjets.toml"
    vehicle.write_text("\n[[jet]]\n".join([head, *jets[0:8:2]]) + "\n")
    assert main(["loop", "--vehicle", str(vehicle), "--out", str(tmp_path / "L")]) == 2
    err = capsys.readouterr().err
    assert err.count("fourjets.toml") == 1 and "vehicle: " not in err
    assert "cannot fly case 'rate-01'" in err and "together" in err


def test_headline_compares_the_same_fresh_seed_with_intervals(loop_dir):
    """Issue 29: the headline set the refined table's failures on the fresh seed against the
    original's on the search seed (different runs).  It now states both tables' failures on
    the same fresh seed -- the original table's campaign_check and the refined table's
    campaign_after, counted again here from their runs -- each with its Clopper-Pearson 95 %
    interval (scipy's Beta quantiles)."""
    import html

    from scipy import stats

    from rcsim.analysis.results.drivers.probabilities import pct

    def rate(k, n):
        lo = stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
        hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
        return f"{pct(k / n)} % (95 % CI {pct(lo)}-{pct(hi)} %)"

    old = pd.read_parquet(loop_dir / "campaign_check" / "runs.parquet")
    new = pd.read_parquet(loop_dir / "campaign_after" / "runs.parquet")
    n = len(old)
    assert len(new) == n
    kb, ka = int(old["failed"].sum()), int(new["failed"].sum())
    want = (
        f"{kb:,} of {n:,} runs failed with the original table, {rate(kb, n)}; "
        f"{ka:,} of {n:,} with the refined table, {rate(ka, n)}"
    )
    report = html.unescape((loop_dir / "report.html").read_text())
    assert f"On a seed no decision used (held-out seed {SMALL.held_out_seed}" in report
    assert want in report
    state = json.loads((loop_dir / "loop.json").read_text())
    assert state["done"]["check"]["failed_fresh"] == want
    assert state["done"]["check"]["held_out_seed"] == SMALL.held_out_seed
    assert state["done"]["refine"]["search_seed"] == SMALL.seed


def _report_table(report: str, caption_start: str) -> pd.DataFrame:
    """The report's table whose caption starts with ``caption_start``, as text cells."""
    import re

    for m in re.finditer(r"<table><caption>(.*?)</caption>(.*?)</table>", report, re.S):
        if html.unescape(m.group(1)).startswith(caption_start):
            head = [
                html.unescape(re.sub("<wbr>", "", h))
                for h in re.findall(r"<th>(.*?)</th>", m.group(2))
            ]
            rows = [
                [html.unescape(c) for c in re.findall(r"<td>(.*?)</td>", r)]
                for r in re.findall(r"<tr>(.*?)</tr>", m.group(2).split("</thead>")[1])
            ]
            return pd.DataFrame(rows, columns=head)
    raise AssertionError(f"no table captioned {caption_start!r}")


def test_every_before_after_compares_the_same_runs_and_names_its_seed(loop_dir):
    """Issue 36, item 4: "Failures per case, before and after" set the search seed's "before"
    beside the held-out seed's "after" (case 6 read 7 -> 33 where the held-out change was
    10 -> 33).  Its per-case table is now the original table's and the refined table's
    campaigns on the same held-out runs (counted again here from their runs.parquet), its
    caption names the seed, and the figures beside it are both held-out campaigns' plots."""
    fresh = SMALL.held_out_seed
    report = (loop_dir / "report.html").read_text()
    table = _report_table(report, f"Held-out seed {fresh}, the same runs flown with")
    old = pd.read_parquet(loop_dir / "campaign_check" / "runs.parquet")
    new = pd.read_parquet(loop_dir / "campaign_after" / "runs.parquet")
    assert (old["run_id"].to_numpy() == new["run_id"].to_numpy()).all()  # the same runs
    want_old = old.groupby("case_index")["failed"].sum().astype(int).tolist()
    want_new = new.groupby("case_index")["failed"].sum().astype(int).tolist()
    assert table["failed_original"].astype(int).tolist() == want_old
    assert table["failed_refined"].astype(int).tolist() == want_new
    # No column of a held-out table carries a search-seed figure.
    changed = _report_table(report, "Changed entries")
    assert not [c for c in changed.columns if "search" in c]
    text = html.unescape(report)
    assert "Before: case" in text or "No case changed" in text
    if "Before: case" in text:
        assert f"with the original table (held-out seed {fresh})" in text
        assert f"with the refined table (held-out seed {fresh})" in text
        assert "(search seed)" not in text
    # The held-out check of every case, in the summary's first paragraph.
    log = pd.read_csv(loop_dir / "refined_table_changelog.csv")
    state = json.loads((loop_dir / "loop.json").read_text())
    if log["held_out_regression"].any():
        assert f"REGRESSION: {state['done']['check']['regressions']}" in text
    else:
        assert state["done"]["check"]["regressions"] == "none"
        assert "No case is significantly worse with the refined table" in text
    summary = _report_table(report, "The loop")
    labels = summary.iloc[:, 0].tolist()
    assert f"failed runs, held-out seed {fresh}: original -> refined table" in labels
    for label in labels:
        if "failed runs" in label or "repeated-firing runs" in label:
            assert (f"held-out seed {fresh}" in label) != (f"search seed {SMALL.seed}" in label)


def test_loop_json_lists_every_finding(loop_dir):
    """Issue 29: loop.json said "significant A, B, C" for 3 of 8 drivers.  Its drivers line is
    the analysis's full list (drivers/findings.csv), each family named or "N more"."""
    from rcsim.analysis.results.drivers.findings import LISTED

    found = pd.read_csv(loop_dir / "drivers" / "findings.csv", keep_default_na=False)
    line = json.loads((loop_dir / "loop.json").read_text())["done"]["drivers"]["findings"]
    if found.empty:
        assert line.startswith("no finding: nothing is flagged")
    else:
        assert line.startswith(f"{len(found)} finding")
        for _, group in found.groupby("family", sort=False):
            for finding in group["finding"].head(LISTED):
                assert finding in line
            if len(group) > LISTED:
                assert f"and {len(group) - LISTED} more" in line


def test_rare_stage_estimates_the_closest_case_with_few_failures(loop_dir):
    """The rare-event stage chose, among the held-out campaign's cases with the fewest failed
    runs (at most 2), the one whose runs came closest to failing (recomputed here from
    campaign_after's runs.parquet), and the report's section shows its record's figures."""
    from rcsim.analysis.apps.loop.rare import FEW_FAILURES, rare_rows

    runs = pd.read_parquet(loop_dir / "campaign_after" / "runs.parquet")
    per_case = runs.groupby("case").agg(failed=("failed", "sum"), low=("margin", "min"))
    few = per_case[per_case["failed"] <= FEW_FAILURES]
    fewest = few[few["failed"] == few["failed"].min()]
    record = json.loads((loop_dir / "rare" / "rare.json").read_text())
    assert list(record["cases"]) == [fewest["low"].idxmin()]
    rec = next(iter(record["cases"].values()))
    assert rec["runs"] == 2000  # the budget: level 0 of each of the 4 repeats
    selection = pd.read_csv(loop_dir / "rare" / "selection.csv")
    html_text = (loop_dir / "report.html").read_text()
    for cell in rare_rows(record, selection).iloc[0]:
        assert html.escape(str(cell)) in html_text
