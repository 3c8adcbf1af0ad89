"""The loop's rare-event stage and its report section: after the held-out check,
``P(fail)`` of the refined table for the cases where plain Monte Carlo saw few or no failures.

Opt-in (``rcsim loop --rare-budget RUNS``; off by default): an estimation flies at least level 0
of :data:`REPEATS` independent repeats of :data:`LEVEL_RUNS` runs per case, more than the whole
default loop gives a case (100 runs on each of five campaigns), so ``make run`` stays as
affordable as it was.

Which cases: those whose held-out campaign of the refined table (``campaign_after``) failed at
most :data:`FEW_FAILURES` runs -- where its interval says least -- the ``rare_cases`` of them with
the fewest failures and, among equals, whose runs came closest to failing (the smallest
``margin`` of the runs table), each estimated on that
campaign's spec (the refined table, the held-out seed: level 0 is a fresh draw of the same
dispersions) by :data:`REPEATS` independent subset simulations with ``rare_budget`` runs at most
in all, side by side on one worker process per CPU.  ``DIR/rare/`` holds the
estimations (``rcsim campaign rare``'s layout, :mod:`rcsim.analysis.apps.rare.estimate`) and
``selection.csv``, the selection's figures; a loop stopped in this stage resumes each case at its
last finished level.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.results.report.html import Section, table_block, text_block
from rcsim.models.errors import InputError

#: Runs per level of each repeat of the loop's estimations, and the repeats: the command's
#: defaults (on the paper's vehicle at P ~ 7e-4, four repeats of 250 spread 2.1x more than
#: four of 500 for half the runs -- subset simulation loses efficiency at small N;
#: docs/rare_events.md).  A level of the four is 2,000 runs.
LEVEL_RUNS = 500
REPEATS = 4
#: A case is a candidate when its held-out campaign failed at most this many runs.
FEW_FAILURES = 2
RARE_DIR = "rare"
SELECTION = "selection.csv"


def check_rare_settings(budget: int, cases: int) -> None:
    """``rare_budget`` is 0 (off) or at least a level; ``rare_cases`` at least 1."""
    if budget != 0 and budget < LEVEL_RUNS * REPEATS:
        raise InputError(
            f"must be 0 (off) or at least level 0 of {REPEATS} repeats of {LEVEL_RUNS} runs "
            f"({LEVEL_RUNS * REPEATS}), got {budget}",
            parameter="rare_budget",
            value=budget,
        )
    if cases < 1:
        raise InputError(f"must be at least 1, got {cases}", parameter="rare_cases", value=cases)


def select_cases(runs: pd.DataFrame, n_cases: int) -> pd.DataFrame:
    """Per case of a campaign's runs (columns ``case``, ``case_index``, ``failed`` and, when
    recorded, ``margin``): runs, failed, the smallest margin, and ``chosen`` (module
    docstring); fewest failures first, and among equals closest to failing first."""
    grouped = runs.groupby(["case_index", "case"], sort=True)
    table = grouped["failed"].agg(runs="size", failed="sum").reset_index()
    if "margin" in runs.columns:
        table["min_margin"] = grouped["margin"].min().to_numpy()
    else:  # a campaign flown before the margin column: none is closer than another
        table["min_margin"] = np.nan
    table = table.sort_values(
        ["failed", "min_margin", "case_index"], na_position="last", kind="stable"
    )
    few = table["failed"] <= FEW_FAILURES
    table["chosen"] = few & (few.cumsum() <= n_cases)
    return table.reset_index(drop=True)


def rare_stage(out: Path, settings, progress: bool | None) -> dict:
    """The stage: select, estimate, write ``DIR/rare/``; the facts for ``loop.json``."""
    if settings.rare_budget == 0:
        return {"rare": "off (rcsim loop --rare-budget RUNS turns it on)"}
    import os
    import sys

    from rcsim.analysis.apps.rare.estimate import estimate_cases
    from rcsim.analysis.apps.rare.settings import RareSettings
    from rcsim.analysis.engine.campaign.spec import load_spec

    runs = pd.read_parquet(out / "campaign_after" / "runs.parquet")
    keep = [c for c in ("case", "case_index", "failed", "margin") if c in runs.columns]
    table = select_cases(runs[keep], settings.rare_cases)
    target = out / RARE_DIR
    target.mkdir(exist_ok=True)
    table.to_csv(target / SELECTION, index=False)
    chosen = [int(c) for c in table.loc[table["chosen"], "case_index"]]
    if not chosen:
        return {"rare": f"no case with at most {FEW_FAILURES} failed runs"}
    show = sys.stderr.isatty() if progress is None else progress

    def echo(line: str) -> None:
        if show:
            print(line, file=sys.stderr, flush=True)

    records = estimate_cases(
        load_spec(out / "spec_after.toml"),
        chosen,
        RareSettings(n_per_level=LEVEL_RUNS, budget=settings.rare_budget, repeats=REPEATS),
        target,
        progress=echo,
        workers=os.cpu_count() or 1,
    )
    return {"rare_cases": len(records), "rare_runs": sum(r["runs"] for r in records.values())}


def _interval(rec: dict) -> str:
    from rcsim.analysis.apps.rare.words import interval_text

    return interval_text(rec)


#: What a status other than ``converged`` means, in the method column.
STATUS_NOTES = {
    "monte_carlo": " (first level only: not rare, plain Monte Carlo's exact interval)",
    "budget": " (budget ended before the failure level: rough)",
    "not_resolved": " (no failure within the budget: a bound)",
    "partial": " (some criteria saw no failure: their bounds enter the upper end)",
    "not_explored": " (a criterion's region was not explored: no bound, no interval)",
}


def _status_note(status: str) -> str:
    return STATUS_NOTES.get(status, "")


def rare_rows(record: dict, selection: pd.DataFrame) -> pd.DataFrame:
    """The section's table: one row per estimated case, every figure from ``rare.json`` and
    ``selection.csv``."""
    rows = []
    for name, rec in record["cases"].items():
        sel = selection[selection["case"] == name].iloc[0]
        cf = rec["closest_failure"]
        rows.append(
            {
                "case": name,
                "plain MC failed": f"{int(sel['failed'])} of {int(sel['runs'])}",
                "P(fail)": "-" if rec["probability"] is None else f"{rec['probability']:.2g}",
                "95 % interval": _interval(rec),
                "CoV": "-" if rec["cov"] is None else f"{rec['cov']:.2f}",
                "runs": rec["runs"],
                "closest failure [sigma]": "-" if cf is None else f"{cf['sigma_active']:.1f}",
                "its largest inputs [sigma]": "-"
                if cf is None
                else ", ".join(f"{n} {v:+.1f}" for n, v in cf["largest"]),
                "method": rec["method"] + _status_note(rec["status"]),
            }
        )
    return pd.DataFrame(rows)


def rare_section(out: Path) -> Section:
    """The loop report's section: each estimated case's estimate, interval, runs, closest
    failure and method; or why there is none."""
    path = out / RARE_DIR / "rare.json"
    if not path.is_file():
        return Section(
            "Rare failures",
            [
                text_block(
                    "Not estimated: the rare-event stage is opt-in (rcsim loop --rare-budget "
                    "RUNS; docs/rare_events.md), or no case of the held-out campaign had few "
                    f"enough failures (at most {FEW_FAILURES})."
                )
            ],
            "rare",
        )
    record = json.loads(path.read_text())
    selection = pd.read_csv(out / RARE_DIR / SELECTION)
    settings = record["settings"]
    repeats = settings.get("repeats", 1)
    how = (
        f"the mean of {repeats} independent subset simulations on the same spec, its CoV and "
        f"interval from their spread, never below Au & Beck's figure for their mean"
        if repeats > 1
        else "subset simulation on the same spec (its CoV the conservative bound)"
    )
    blocks = [
        text_block(
            f"Cases of the held-out campaign of the refined table with at most {FEW_FAILURES} "
            "failed runs, the fewest failures first and, among equals, those whose runs came "
            "closest to failing (smallest margin): their "
            f"failure probability by {how}, at most {settings['budget']:,} runs each "
            f"({settings['n_per_level']} a level of each). The closest "
            "failure is the failed run nearest the nominal vehicle that the estimation found, "
            "its distance in sigmas over the dispersed inputs: an upper bound on the most "
            "probable failure point's."
        ),
        table_block(rare_rows(record, selection), "Rare-event estimates", float_format="{:.0f}"),
        text_block(
            f"Every run flown: {RARE_DIR}/runs.parquet (conditional samples, not a Monte Carlo "
            f"sample); settings and code version: {RARE_DIR}/rare.json."
        ),
    ]
    return Section("Rare failures", blocks, "rare")
