"""The loop's one report: before/after of the refinement, the drivers behind the failures.

Built from the files the stages wrote (nothing is recomputed), so it can be rebuilt at any
time from ``DIR``: the campaigns' ``cases.csv`` and plots, the driver analysis's CSV files and
figures, the refinement's changelog and plots, and ``loop.json`` (settings, seeds, times, code
version).
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.loop.files import GENERATE, GENERATED_TABLE, table_file
from rcsim.analysis.apps.loop.propellant_section import propellant_section
from rcsim.analysis.apps.loop.rare import rare_section
from rcsim.analysis.apps.refinement.evidence import changed_cells
from rcsim.analysis.apps.refinement.plots import most_improved_case
from rcsim.analysis.engine import runs_table
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.analysis.results.drivers.conclusions import Conclusions
from rcsim.analysis.results.drivers.probabilities import rate_text
from rcsim.analysis.results.report.html import (
    Section,
    figure_block,
    table_block,
    text_block,
    write_report,
)
from rcsim.models.errors import InputError
from rcsim.models.tables import AXES, PAPER_LOOKUP_TABLES, load_lookup_table, recipe_path


def _flown_by(resolved: dict) -> str:
    """Which flight software flew every campaign and candidate: rcsim's lookup controller, or
    the plug-in with its version or source digest (the spec's record of it)."""
    record = (resolved.get("controller") or {}).get("plugin_record")
    if not record:
        return "rcsim's lookup controller"
    what = record.get("version") or f"sha256 {record.get('source_sha256')}"
    return f"{record.get('name')} ({what}), a plug-in (docs/flight_software.md)"


def _table_file(out: Path, settings) -> str:
    """The table refined as the loop's campaigns name it."""
    return table_file(out, settings.table)


def _table_label(out: Path, settings) -> str:
    """What the table refined is, in words: the paper's, a file, or the loop's generated one
    (a channel table: six axis channels and their jet recipe)."""
    file = _table_file(out, settings)
    table = load_lookup_table(file)
    if settings.table == GENERATE:
        what = f"{GENERATED_TABLE}, generated for {_vehicle_name(settings)} by the loop"
    else:
        what = settings.table
    if table.recipe is None:
        return what
    return (
        f"{what}: a channel table (six axis channels, +roll -roll +pitch -pitch +yaw -yaw, "
        f"each firing the jets by its recipe {recipe_path(file).name}, solved for "
        f"{table.recipe.vehicle}, sha256 {table.recipe.vehicle_sha256[:12]}...)"
    )


def _vehicle_name(settings) -> str:
    """The loop's vehicle file by its ``[vehicle] name`` (its file's stem if it no longer
    loads: the report is rebuilt from the stages' files)."""
    from rcsim.spacecraft.vehicle import load_vehicle

    try:
        return load_vehicle(settings.vehicle).name
    except (InputError, OSError):
        return Path(str(settings.vehicle)).stem


def _img(path: Path, caption: str) -> str:
    """A PNG file a stage wrote, inlined with its caption; a note if the file is missing."""
    if not path.is_file():
        return text_block(f"(figure not written: {path.name})")
    return figure_block(path.read_bytes(), caption)


def _side_by_side(*blocks: str) -> str:
    return (
        "<div style='display:grid;grid-template-columns:1fr 1fr;gap:1em'>"
        + "".join(f"<div>{b}</div>" for b in blocks)
        + "</div>"
    )


def fresh_seed_change(log: pd.DataFrame) -> str:
    """The loop's headline figures: failed runs on the fresh seed, the table before refinement
    against the refined table -- the same dispersed runs, so the one contrast that could only
    differ by the table -- each with its Clopper-Pearson 95 % interval."""
    n = int(log["fresh_runs"].sum())
    before, after = int(log["failed_fresh_before"].sum()), int(log["failed_fresh_after"].sum())
    return (
        f"{before:,} of {n:,} runs failed with the original table, {rate_text(before, n)}; "
        f"{after:,} of {n:,} with the refined table, {rate_text(after, n)}"
    )


def regression_sentence(log: pd.DataFrame, check: dict, n_cases: int) -> str:
    """The held-out check of every case in words (the summary's first paragraph): the cases
    significantly worse with the rows that cause them, what the loop dropped and its check on
    the further seed; or that no case is worse."""
    test = (
        "exact one-sided McNemar test per case on the same held-out runs, Holm over the "
        f"{n_cases} cases"
    )
    if "held_out_regression" not in log or not log["held_out_regression"].astype(bool).any():
        return f"No case is significantly worse with the refined table ({test})."
    text = f"REGRESSION: {check.get('regressions', '')} ({test})."
    if "further_seed" in check:
        dropped = ", ".join(str(r) for r in check["dropped_rows"])
        text += (
            f" The loop dropped the change of case {dropped} (its row is the original table's "
            f"again) and checked again on further seed {check['further_seed']}, every case: "
            f"{check['failed_further']}; "
            + (
                "no case is significantly worse there."
                if check.get("regressions_further", "none") == "none"
                else f"still worse: {check['regressions_further']}."
            )
            + " The held-out figures here are the table as searched, before the drop."
        )
    return text


def _counts(campaign: Path) -> pd.DataFrame:
    cases = pd.read_csv(campaign / "cases.csv")
    return cases[["case", "case_index", "runs", "failed", "one_firing_pct", "firings_per_run_mean"]]


def _summary(
    out: Path, settings, state: dict, log: pd.DataFrame, before: pd.DataFrame, after: pd.DataFrame
) -> Section:
    """The loop's summary.  ``before`` / ``after``: per case on the held-out seed, the original
    table's campaign (``campaign_check``) and the refined table's (``campaign_after``), the
    same runs.  Search-seed figures (the search's own runs, not an estimate) are in rows of
    their own, named by their seed, never beside the held-out ones."""
    s = state["settings"]
    fresh = settings.held_out_seed
    spec = load_spec(out / "spec_before.toml")
    threshold = np.degrees(spec.rate_threshold_rad_s)
    dispersions = runs_table.dispersions_source(spec.resolved)
    if dispersions.startswith("Gambone Table 5"):
        dispersions = "Table 5 dispersions"
    n_changed = int(log["changed"].sum())
    fb, fa = int(before["failed"].sum()), int(after["failed"].sum())
    n_fresh = int(before["runs"].sum())
    sb, sa = int(log["failed_search_before"].sum()), int(log["failed_search_after"].sum())
    n_search = int(log["runs"].sum())
    search_runs = int(log["runs"].max()) if len(log) else 0
    label = _table_label(out, settings)
    channels = "channels" in log
    vehicle = spec.vehicle
    rows = [
        ("table refined", label),
        ("vehicle", f"{vehicle.name!r}, {vehicle.ref}, sha256 {vehicle.sha256}"),
        ("flight-software profile", vehicle.control.describe()),
        ("flown by", _flown_by(spec.resolved)),
        ("runs per case", f"{s['runs_per_case']} (26 rate cases of Table 3, {dispersions})"),
        (
            "held-out seed",
            f"{fresh} (no decision used it: the original table, campaign_check, and the "
            "refined table, campaign_after, flown on the same runs)",
        ),
        (
            "failure criterion",
            f"any axis ends with |rate error| >= {threshold:g} deg/s, or the "
            "simulation fails (Gambone sec. III)",
        ),
        (
            f"failed runs, held-out seed {fresh}: original -> refined table",
            f"{fb:,} of {n_fresh:,}, {rate_text(fb, n_fresh)} -> "
            f"{fa:,} of {n_fresh:,}, {rate_text(fa, n_fresh)}",
        ),
        (
            f"repeated-firing runs, held-out seed {fresh}: original -> refined table",
            f"{int(log['repeated_fresh_before'].sum())} -> "
            f"{int(log['repeated_fresh_after'].sum())} of {n_fresh:,}",
        ),
        ("cases changed", f"{n_changed} of {len(log)}"),
        (
            "search seed",
            f"{s['seed']} (the 'before' campaign and the refinement search: its figures are "
            "the search's own runs, which chose the changes, not an estimate)",
        ),
        (
            f"failed runs, search seed {s['seed']} (first {search_runs} runs per case): "
            "original -> refined table",
            f"{sb:,} -> {sa:,} of {n_search:,}",
        ),
        (
            f"repeated-firing runs, search seed {s['seed']} (first {search_runs} runs per "
            "case): original -> refined table",
            f"{int(log['repeated_search_before'].sum())} -> "
            f"{int(log['repeated_search_after'].sum())} of {n_search:,}",
        ),
        ("stage times [s]", ", ".join(f"{k} {v['seconds']:.1f}" for k, v in state["done"].items())),
        ("code version", ", ".join(f"{k} {v}" for k, v in state.get("code_version", {}).items())),
    ]
    name = "the generated channel table" if channels else f"the lookup table {s['table']}"
    fly = (
        "Fly the refined table (refined_table.csv with its recipe refined_table_recipe.csv "
        f"beside it) as a campaign spec's `controller.table` with `vehicle = "
        f'"{settings.vehicle}"`'
        if channels
        else "Fly the refined table with `--table refined_table.csv` (`rcsim maneuver`, "
        "`rcsim scenario run`) or as a campaign spec's `controller.table`"
    )
    if s.get("controller"):
        # The plug-in that flew the loop takes the table as its own (declared) parameter.
        from rcsim.lookup.table_plugins import declared_table_param

        key = declared_table_param(s["controller"])
        fly = (
            f"Fly the refined table with your flight software: `--controller {s['controller']}"
            f" --param {key}=refined_table.csv`, or as spec_after.toml's [controller] does"
        )
    check = state["done"].get("check", {})
    blocks = [
        text_block(
            f"On a seed no decision used (held-out seed {fresh}, {s['runs_per_case']} dispersed "
            f"runs of each of the 26 rate cases, flown with both tables), "
            f"{fresh_seed_change(log)}. The refinement "
            f"changed {n_changed} of {len(log)} cases; it searched {name} on seed {s['seed']}. "
            + regression_sentence(log, check, len(log))
        ),
        table_block(pd.DataFrame(rows, columns=["", "value"]), "The loop"),
        text_block(
            f"{fly}, or gate a "
            "change in CI with `rcsim campaign run spec_after.toml --out DIR "
            "--max-failed-pct P`. Replay any run with `rcsim campaign replay "
            "campaign_before RUN_ID`."
        ),
    ]
    return Section("Summary", blocks, "summary")


def _before_after(
    out: Path, settings, log: pd.DataFrame, before: pd.DataFrame, after: pd.DataFrame
) -> Section:
    """Per case, the original and the refined table on the same held-out runs (``before`` /
    ``after``: campaign_check's and campaign_after's cases.csv)."""
    plots = out / "refined_table_plots"
    fresh = settings.held_out_seed
    merged = before.merge(after, on="case", suffixes=("_original", "_refined"))
    merged = merged[
        [
            "case",
            "runs_original",
            "failed_original",
            "failed_refined",
            "one_firing_pct_original",
            "one_firing_pct_refined",
        ]
    ].rename(columns={"runs_original": "runs"})
    if "held_out_regression" in log:
        worse = log[["case", "held_out_worse_runs", "held_out_better_runs"]].copy()
        worse["significantly worse (Holm)"] = [
            f"yes: caused by {r}'s row" if flag and r else ("yes" if flag else "")
            for flag, r in zip(
                log["held_out_regression"].astype(bool),
                log["held_out_regression_rows"].astype(object).fillna("").astype(str),
            )
        ]
        # cases.csv names its cases (rate-03) and numbers them from 0 (case_index).
        worse = worse.assign(case_index=worse["case"] - 1).drop(columns="case")
        index = before[["case", "case_index"]]
        merged = merged.merge(index, on="case").merge(worse, on="case_index", how="left")
        merged = merged.drop(columns="case_index")
    blocks = [
        _img(
            plots / "failures_by_case.png",
            f"On held-out seed {fresh}, {fresh_seed_change(log)} ({int(log['changed'].sum())} "
            "cases changed). Failed runs (top) and runs that needed more than one firing to "
            "reach the commanded rate (bottom), per rate case, with the original (red) and "
            f"the refined table (blue): left, the search seed {settings.seed}'s runs the "
            f"search flew (its own evidence); right, the held-out seed {fresh}'s runs. Each "
            "panel compares the same runs. * marks the cases whose firing times changed.",
        ),
        table_block(
            merged,
            f"Held-out seed {fresh}, the same runs flown with the original table "
            "(campaign_check) and the refined table (campaign_after): failed runs and the "
            "share of runs reaching the rate in one firing, per case",
            max_rows=30,
            float_format="{:.1f}",
        ),
    ]
    return Section("Failures per case, before and after", blocks, "before-after")


def _figs_9_10(out: Path, settings, log: pd.DataFrame) -> Section:
    best = most_improved_case(log)
    if best is None:
        return Section(
            "Figs 9-10: one case before and after",
            [
                text_block(
                    "No case changed: the table was already robust."
                    if int(log["failed_search_before"].sum() + log["repeated_search_before"].sum())
                    == 0
                    else "No case changed: no candidate's gain was significant on the paired "
                    "runs (the evidence rule, docs/refinement.md); more runs per case can show it."
                )
            ],
            "figs-9-10",
        )
    case = int(best["case"])
    name = f"case-rate-{case:02d}.png"
    fresh = settings.held_out_seed
    blocks = [
        text_block(
            f"Rate case {case}, the case the refinement helped most on the held-out seed: "
            f"every dispersed run of held-out seed {fresh}, the same runs flown with each "
            "table, as Gambone Figs 9 (before) and 10 (after)."
        ),
        _side_by_side(
            _img(
                out / "campaign_check" / "plots" / name,
                f"Before: case {case} with the original table (held-out seed {fresh})",
            ),
            _img(
                out / "campaign_after" / "plots" / name,
                f"After: case {case} with the refined table (held-out seed {fresh})",
            ),
        ),
        _img(
            out / "refined_table_plots" / f"case_{case:02d}_before_after.png",
            f"Case {case}: the changed axis's rate of the same search-seed {settings.seed} runs "
            "with each table (the search's own runs), failed runs red.",
        ),
    ]
    return Section("Figs 9-10: one case before and after", blocks, "figs-9-10")


def _drivers(out: Path) -> Section:
    """The driver analysis's conclusions as it stated them (``drivers/conclusions.json``, the
    object its own report renders), with its figures: nothing is concluded again here."""
    d = out / "drivers"
    blocks = [
        text_block(
            "Which dispersions make the original table's runs fail (the full "
            "analysis, with methods and pair maps, is drivers/report.html)."
        )
    ]
    c = Conclusions.read(d)
    if c is None:
        blocks.append(text_block("(drivers/conclusions.json not written: run the drivers stage)"))
    elif not c.ranking:
        blocks.append(text_block("No failures to analyse."))
    else:
        blocks.append(text_block(*c.summary_sentences()))
        blocks.append(
            _img(
                d / "figures" / "ranking.png",
                c.strongest + "Single-factor drivers: score, corrected p-value and stability; red "
                f"bars are flagged (within the report's {100 * c.alpha:g} % false-flag budget).",
            )
        )
        blocks.append(
            table_block(
                c.ranking_frame(),
                "Driver ranking (drivers/drivers.csv; failure regions of the flagged drivers only)",
                max_rows=12,
            )
        )
        maps = c.maps[:2]
        if maps:
            blocks.append(
                _side_by_side(
                    *[
                        _img(d / "figures" / name, f"kNN failure map ({why}), " + _map_words(name))
                        for name, why in maps
                    ]
                )
            )
    return Section("Failure drivers", blocks, "drivers")


def _map_words(name: str) -> str:
    """``map_1_rate-19_a__b.png`` as "rate-19: a vs b" (``all``: "all cases")."""
    scope, pair = Path(name).stem.split("_", 2)[2].split("_", 1)
    return f"{'all cases' if scope == 'all' else scope}: {pair.replace('__', ' vs ')}"


def _changelog(log: pd.DataFrame, table: str, refined: Path, settings) -> Section:
    # A channel table's rows fire channels: say which (``-roll, +yaw``) beside the times.
    cols = (
        ["case"]
        + (["channels"] if "channels" in log else [])
        + [f"{a}_{w}" for a in AXES for w in ("old_s", "new_s")]
        + [
            "failed_fresh_before",
            "failed_fresh_after",
            "repeated_fresh_before",
            "repeated_fresh_after",
        ]
        + [c for c in ("propellant_fresh_change_pct", "held_out") if c in log]
    )
    fresh = settings.held_out_seed
    blocks = [
        table_block(
            log[log["changed"]][cols],
            f"Changed entries (refined_table_changelog.csv): firing times, and failed and "
            f"repeated-firing runs with the original (before) and the refined table (after) "
            f"on the same runs of held-out seed {fresh}",
            max_rows=30,
            float_format="{:.2f}",
        )
    ]
    if "decision" in log:
        # Every row the search proposed to change, kept or reverted, with its evidence: the
        # exact one-sided McNemar test on the search runs and on the confirmation seed.
        ev_cols = [
            "case",
            "decision",
            "decided_on",
            "failed_search_before",
            "failed_search_after",
            "search_b",
            "search_c",
            "search_p",
            "confirm_failed_before",
            "confirm_failed_after",
            "confirm_b",
            "confirm_c",
            "confirm_p",
            "mirror_case",
            "mirror_decision",
        ]
        blocks.append(
            table_block(
                log[log["decision"] != "unchanged"][ev_cols],
                f"Evidence of each proposed change: search seed {settings.seed} (search_*: the "
                "search's runs of the case, original row against the proposed one) and "
                f"confirmation seed {settings.confirm_seed} (confirm_*: the same runs flown "
                "before and after); b / c: runs better / worse after; p: exact one-sided "
                "McNemar; a change is kept when p <= 0.05 on the search runs and, Holm over "
                "the rows, on the confirmation seed",
                max_rows=40,
                float_format="{:.3g}",
            )
        )
        if "refused" in log:
            refused = log[log["refused"].astype(object).fillna("").astype(str) != ""]
            if not refused.empty:
                blocks.append(
                    table_block(
                        refused[["case", "refused"]],
                        "Strictly better candidates the search gate refused (not significant "
                        "on the paired search runs)",
                        max_rows=30,
                    )
                )
    heldout = refined.with_name(f"{refined.stem}_heldout.csv")
    if heldout.is_file():
        blocks.append(
            table_block(
                pd.read_csv(heldout),
                f"Held-out seed {fresh} (no decision used it), all cases, every table on the "
                "same runs: failed runs and the failure probability's Clopper-Pearson 95 % "
                "interval [%]",
                float_format="{:.2f}",
            )
        )
    t6, t7 = load_lookup_table("table6"), load_lookup_table("table7")
    # The paper's refinement is comparable when the table refined is Table 6 (by name or copy).
    if table in PAPER_LOOKUP_TABLES or load_lookup_table(table).recipe is None:
        is_t6 = np.array_equal(load_lookup_table(table).firing_time_s, t6.firing_time_s)
    else:
        is_t6 = False  # a channel table: not the paper's jets
    if is_t6:
        cycle_s = load_spec(refined.parent / "spec_before.toml").cycle_s
        ours = changed_cells(t6, load_lookup_table(refined), cycle_s)
        paper = changed_cells(t6, t7, cycle_s)
        both = ours.merge(
            paper, on=["case", "axis", "old_cycles"], how="outer", suffixes=("_rcsim", "_table7")
        )
        same = int((both["new_cycles_rcsim"] == both["new_cycles_table7"]).sum())
        blocks.append(
            text_block(
                f"Against the paper's Table 7 (the authors' hand refinement of Table 6): "
                f"{same} of {len(both)} changed cells agree."
            )
        )
        blocks.append(
            table_block(
                both,
                "Changed cells, rcsim vs Table 7 (firing time in 40 ms cycles; blank: not changed)",
                max_rows=40,
                float_format="{:.0f}",
            )
        )
    return Section("Changelog", blocks, "changelog")


def write_loop_report(out: Path, settings, state: dict) -> Path:
    """Write ``DIR/report.html`` from the stages' files; returns its path."""
    log = pd.read_csv(out / "refined_table_changelog.csv")
    # Like for like: the original table's and the refined table's campaigns on the held-out
    # seed (the same dispersed runs), never the search seed's beside the held-out seed's.
    before, after = _counts(out / "campaign_check"), _counts(out / "campaign_after")
    sections = [
        _summary(out, settings, state, log, before, after),
        _before_after(out, settings, log, before, after),
        _figs_9_10(out, settings, log),
        propellant_section(out, log, settings, settings.held_out_seed),
        _drivers(out),
        _changelog(log, _table_file(out, settings), out / "refined_table.csv", settings),
        rare_section(out),
        Section(
            "Traceability",
            [
                text_block(
                    "Settings, seeds, stage times and code version: loop.json. Campaign specs: "
                    "spec_before.toml, spec_after.toml; each campaign's manifest.json records "
                    "its spec, seed, table checksum (a channel table's recipe checksum too; the "
                    "recipe records the vehicle file's) and code version."
                ),
                "<pre>" + html.escape(json.dumps(state, indent=2)) + "</pre>",
            ],
            "traceability",
        ),
    ]
    return write_report(
        out / "report.html",
        "Lookup-table robustness: "
        + (
            f"channel table for {_vehicle_name(settings)}"
            if load_lookup_table(_table_file(out, settings)).recipe is not None
            else settings.table
        ),
        sections,
        "rcsim loop: campaign, failure drivers, refined table, fresh campaign",
    )
