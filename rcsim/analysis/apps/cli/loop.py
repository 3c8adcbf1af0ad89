"""``rcsim loop``: the analyst's loop -- campaign, failure drivers, refined table, report."""

from __future__ import annotations

import argparse
import os
import shlex

from rcsim.analysis.apps.cli.maneuver import plugin_params
from rcsim.analysis.apps.cli.vehicle_args import (
    add_vehicle_args,
    control_overrides,
    warn_vehicle,
)
from rcsim.models.errors import InputError


def register(sub) -> None:
    p = sub.add_parser(
        "loop",
        help="the whole loop: campaign -> failure drivers -> refined table -> report",
        description="Fly a Table 5 campaign of the 26 rate cases with a lookup table (default: "
        "the paper's Table 6), find the dispersions that drive its failures, refine the table, "
        "fly the refined table on a fresh seed, and write DIR/report.html with the before and "
        "after.  Each stage is kept as it finishes (DIR/loop.json): --resume finishes a loop "
        "that was stopped.  Defaults take about 50 s on 2 cores; --runs-per-case 1000 is "
        "the paper-size study (about 3 minutes).",
    )
    p.add_argument(
        "--table",
        help="table to refine: table6, table7, a CSV path, or generate (generated for the "
        "vehicle first; default table6, or generate with a --vehicle whose jets torque "
        "several axes: its channel table)",
    )
    p.add_argument(
        "--runs-per-case",
        type=int,
        metavar="N",
        help="dispersed runs per rate case (default 100)",
    )
    p.add_argument("--seed", type=int, metavar="S", help="campaign and search seed (default 1)")
    p.add_argument(
        "--fresh-seed",
        type=int,
        metavar="S2",
        help="held-out seed for the refined table (default S + 1)",
    )
    p.add_argument(
        "--search-runs-per-case",
        type=int,
        metavar="M",
        help="runs per case the refinement search flies: the first M of each "
        "case's N (the same draws); the refined table is then checked on all N "
        "runs of the held-out seed (default 200)",
    )
    p.add_argument(
        "--max-propellant-rise-pct",
        type=float,
        metavar="P",
        help="a change raising a case's mean propellant by more than P %% must pay for it: the "
        "95 %% lower bound of its failure reduction at least 1 %% of runs per 10 %% of rise; "
        "with failures only equal it is refused (default 10)",
    )
    add_vehicle_args(
        p,
        vehicle_help="fly your own vehicle (a vehicle TOML file or a packaged name; "
        "docs/vehicles.md) instead of the paper's; a vehicle whose jets torque several axes "
        "(e.g. canted16) gets its channel table generated first (stage generate)",
    )
    p.add_argument(
        "--controller",
        metavar="NAME",
        help="your flight software flies the table instead of rcsim's lookup controller: a "
        "plug-in that declares its table parameter (plugin:package.module:factory, "
        "plugin:path/to/fsw.py:factory, library:path/to/libfsw.so or a registered name; "
        "docs/flight_software.md, 'Refining your table'); every campaign and every candidate "
        "of the refinement is flown by it",
    )
    p.add_argument(
        "--param",
        dest="controller_params",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a --controller plug-in's other parameters (repeatable; VALUE read as TOML)",
    )
    p.add_argument(
        "--plots",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the campaigns' per-case plots, about 4.5 s per campaign (default: on)",
    )
    p.add_argument(
        "--drop-regressions",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="a changed row that makes some case significantly worse on the held-out seed "
        "(exact one-sided McNemar per case, Holm over the cases) goes back to the original "
        "row, and both tables are flown again on a further seed (default: on; "
        "--no-drop-regressions reports the regression and keeps the table)",
    )
    p.add_argument(
        "--rare-budget",
        type=int,
        metavar="RUNS",
        help="after the held-out check, estimate P(fail) of the refined table by 4 "
        "independent subset simulations, at most RUNS runs a case (at least 2000), for the "
        "cases whose held-out campaign failed at most 2 runs (default 0: off; docs/rare_events.md)",
    )
    p.add_argument(
        "--rare-cases",
        type=int,
        metavar="K",
        help="with --rare-budget (refused without it): at most K cases, those whose runs came "
        "closest to failing (default 3)",
    )
    p.add_argument(
        "--yes",
        action="store_true",
        help="start even if the estimate is over 30 minutes (the estimate is printed first)",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="loop directory (new, or --resume)")
    p.add_argument(
        "--resume",
        action="store_true",
        help="finish the loop in DIR from its last finished stage, with the settings it was "
        "started with (DIR/loop.json); a setting given again must equal them",
    )
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bars on stderr (default: only on a terminal)",
    )
    p.set_defaults(func=run, resume_hint=_resume_hint)


def _absolute_controller(name: str | None) -> str | None:
    """A plug-in file or library named by its absolute path: a resumed loop, and every
    worker process, finds the same file from anywhere."""
    from rcsim.lookup.c_library import LIBRARY_PREFIX
    from rcsim.lookup.plugins import PLUGIN_PREFIX

    if name is None:
        return None
    if name.startswith(LIBRARY_PREFIX):
        return LIBRARY_PREFIX + os.path.abspath(os.path.expanduser(name[len(LIBRARY_PREFIX) :]))
    if name.startswith(PLUGIN_PREFIX):
        module, sep, attr = name[len(PLUGIN_PREFIX) :].rpartition(":")
        if sep and module.endswith(".py"):
            return f"{PLUGIN_PREFIX}{os.path.abspath(os.path.expanduser(module))}:{attr}"
    return name


def _resume_hint(args: argparse.Namespace) -> str:
    return f"rcsim loop --out {shlex.quote(args.out)} --resume"


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from rcsim.analysis.apps.loop.files import GENERATE
    from rcsim.analysis.apps.loop.run import STATE, LoopSettings, resumed_settings, run_loop
    from rcsim.models.tables import PAPER_LOOKUP_TABLES

    given = {
        "table": args.table,
        "runs_per_case": args.runs_per_case,
        "seed": args.seed,
        "fresh_seed": args.fresh_seed,
        "search_runs_per_case": args.search_runs_per_case,
        "max_propellant_rise_pct": args.max_propellant_rise_pct,
        "plots": args.plots,
        "vehicle": args.vehicle,
        "control": control_overrides(args) or None,
        "rare_budget": args.rare_budget,
        "rare_cases": args.rare_cases,
        "drop_regressions": args.drop_regressions,
        "controller": _absolute_controller(args.controller),
        "controller_params": plugin_params(args.controller_params) or None,
    }
    given = {k: v for k, v in given.items() if v is not None}
    if "vehicle" in given and Path(given["vehicle"]).suffix:  # a file, not a packaged name
        given["vehicle"] = os.path.abspath(given["vehicle"])
    if "table" in given and given["table"] not in (*PAPER_LOOKUP_TABLES, GENERATE):
        # A CSV path is kept absolute: a resumed loop re-reads the same file from anywhere.
        given["table"] = os.path.abspath(given["table"])
    if args.resume and (Path(args.out) / STATE).is_file():
        settings = resumed_settings(args.out, given)
    else:
        settings = LoopSettings(**given)
    if args.rare_cases is not None and settings.rare_budget == 0:
        # The stage is off without a budget: K cases of nothing would be flown silently.
        raise InputError(
            f"--rare-cases {args.rare_cases} needs --rare-budget RUNS: with a budget of 0 (the "
            "default) the rare-event stage is off and estimates no case; give --rare-budget as "
            "well, or leave --rare-cases out"
        )
    from rcsim.analysis.apps.estimates import confirm, flying_seconds

    warn_vehicle(settings.flown_vehicle())

    # Two campaigns and the check at full size, the confirmation of the changed rows (about
    # half the cases, twice) and Table 7 on the held-out seed, the search (a few rounds) on
    # its subset.
    cases = 26
    campaigns = (
        settings.duration_s
        * cases
        * (
            5 * settings.runs_per_case
            + 3 * min(settings.search_runs_per_case, settings.runs_per_case)
        )
    )
    # The rare-event stage (opt-in): at most its budget on each of its cases.
    rare = settings.duration_s * settings.rare_budget * min(settings.rare_cases, cases)
    # A refusal names the setting that makes the loop long.
    parameter, value = (
        ("rare_budget", settings.rare_budget)
        if rare > campaigns
        else ("runs_per_case", settings.runs_per_case)
    )
    confirm(
        "the loop",
        flying_seconds(campaigns + rare, runs=cases * settings.runs_per_case),
        yes=args.yes,
        parameter=parameter,
        value=value,
    )
    result = run_loop(settings, args.out, resume=args.resume, progress=args.progress)
    total = sum(result.stage_s.values())
    print(f"loop finished in {total:.0f} s; report: {result.report}")
    return 0
