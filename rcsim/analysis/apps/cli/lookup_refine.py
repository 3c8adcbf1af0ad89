"""``rcsim lookup refine``: make a lookup table robust to the dispersions (its parser and its
run; :mod:`rcsim.analysis.apps.cli.lookup` registers it)."""

from __future__ import annotations

import argparse
import shlex
import sys

from rcsim.analysis.apps.cli.vehicle_args import add_vehicle_args, flown_vehicle
from rcsim.models.errors import InputError


def register_refine(cmds) -> None:
    """Add ``refine`` to the ``rcsim lookup`` actions ``cmds``."""
    ref = cmds.add_parser(
        "refine",
        help="make a lookup table robust to the Table 5 dispersions (automated Table 7)",
        description="Fly the dispersed runs of every rate case (Table 5 dispersions, the "
        "campaign's failure threshold), and where runs fail or need repeated firings, search "
        "the firing times (whole control cycles per axis of the entry, 40 ms for the paper's "
        "profile) that minimise failures "
        "first and repeated firings second, over the same dispersed runs for every candidate. "
        "A row changes only on evidence: the candidate's gain must be significant on those "
        "paired runs (exact one-sided McNemar test, alpha 0.05, on failed runs, or on failed-"
        "or-repeated runs when failures do not rise), and must hold again on all N runs of a "
        "confirmation seed the search never saw (the same test, Holm over the changed rows at "
        "0.05); a row that does not goes back to the original.  On the packaged (symmetric) "
        "vehicle a change is offered to the mirror case too (every rate command negated), "
        "through the same confirmation; the changelog says for every case what became of its "
        "mirror.  Then the old and refined tables (and Table 7, when refining Table 6) are "
        "flown on a held-out seed no decision used.  Writes OUT.csv (a table for --table), "
        "OUT_changelog.csv (per case: times, counts, discordant runs, p-values, decision, "
        "Clopper-Pearson 95 % intervals) and OUT_plots/.",
    )
    ref.add_argument(
        "--table",
        required=True,
        metavar="IN.csv",
        help="table to refine: a CSV (rcsim or paper layout) or table6 / table7",
    )
    add_vehicle_args(
        ref,
        vehicle_help="vehicle to fly the table on (a name or a vehicle file); default the "
        "paper's for a jet table, the vehicle a channel table's recipe was solved for",
    )
    ref.add_argument(
        "--controller",
        metavar="NAME",
        help="flight software that flies every candidate table instead of rcsim's lookup "
        "controller: a plug-in that declares its table parameter (plugin:package.module:factory, "
        "plugin:path/to/fsw.py:factory, library:path/to/libfsw.so, or a registered name; "
        "docs/flight_software.md, 'Refining your table'); each candidate is written to a file "
        "and passed under that parameter",
    )
    ref.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a --controller plug-in's other parameters (repeatable; VALUE read as TOML)",
    )
    ref.add_argument(
        "--runs",
        dest="runs_per_case",
        type=int,
        default=200,
        metavar="N",
        help="dispersed runs per case (default 200)",
    )
    ref.add_argument(
        "--seed",
        type=int,
        default=1,
        metavar="S",
        help="search seed: run i of case c draws from SeedSequence(S, "
        "spawn_key=(c*N+i,)), as in `rcsim campaign run` (default 1)",
    )
    ref.add_argument(
        "--fresh-seed",
        type=int,
        metavar="S2",
        help="held-out seed for the before/after check (default S + 1)",
    )
    ref.add_argument(
        "--confirm-seed",
        type=int,
        metavar="S3",
        help="confirmation seed: every changed row is flown before and after on its N runs "
        "and kept only if the gain holds there (default: one past the larger of S and S2)",
    )
    ref.add_argument(
        "--cases",
        type=int,
        nargs="+",
        metavar="CASE",
        help="rate cases (1-26) to refine (default: all)",
    )
    ref.add_argument(
        "--duration-s",
        type=float,
        default=20.0,
        help="simulated time of every run [s] (default 20, as campaigns)",
    )
    ref.add_argument(
        "--max-iterations",
        type=int,
        default=8,
        metavar="K",
        help="most rounds of candidates (default 8)",
    )
    ref.add_argument(
        "--search-runs",
        dest="search_runs_per_case",
        type=int,
        default=200,
        metavar="M",
        help="runs per case the search flies: the first M of the N "
        "(the same draws); the confirmation and the held-out check fly all N (default 200)",
    )
    ref.add_argument(
        "--max-propellant-rise-pct",
        type=float,
        default=10.0,
        metavar="P",
        help="a change raising a case's mean propellant by more than P %% must pay for it: the "
        "95 %% lower bound of its failure reduction at least 1 %% of runs per 10 %% of rise; "
        "with failures only equal it is refused (default 10)",
    )
    ref.add_argument(
        "--out",
        required=True,
        metavar="OUT.csv",
        help="refined table to write (missing parent directories are created)",
    )
    ref.add_argument(
        "--overwrite",
        action="store_true",
        help="replace OUT.csv, its changelog and plots if they exist",
    )
    ref.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bars on stderr (default: only on a terminal)",
    )
    ref.add_argument(
        "--yes",
        action="store_true",
        help="start even if the estimate is over 30 minutes (the estimate is printed first)",
    )
    ref.add_argument(
        "--resume",
        action="store_true",
        help="continue a refinement that was stopped, from its last finished round (the same "
        "arguments; without --resume a stopped refinement's rounds are discarded)",
    )
    ref.set_defaults(func=run_refine, resume_hint=_refine_resume_hint)


def _refine_resume_hint(args: argparse.Namespace) -> str:
    argv = [a for a in sys.argv[1:] if a != "--resume"]
    return shlex.join(["rcsim", *argv, "--resume"])


def run_refine(args: argparse.Namespace) -> int:
    from rcsim.analysis.apps.refinement.outputs import (
        check_outputs,
        run_refinement,
        write_refinement,
    )
    from rcsim.analysis.apps.refinement.parameters import (
        check_parameters,
        confirmation_seed,
        held_out_seed,
        load_refinable_table,
    )

    table = load_refinable_table(args.table)
    vehicle = None if args.vehicle is None and not args.control else flown_vehicle(args)
    plugin = _table_plugin(args, table, vehicle)
    # OUT.csv, OUT_changelog.csv and OUT_plots/ are checked before any flight; --overwrite
    # replaces all three.
    paths = check_outputs(
        args.out,
        overwrite=args.overwrite,
        channels=table.is_channel,
        inputs={"--table": args.table},
    )
    out, checkpoint = paths["table"], paths["checkpoint"]
    if not args.resume:
        checkpoint.unlink(missing_ok=True)  # a fresh search; a stopped one's rounds go
    fresh = held_out_seed(args.seed) if args.fresh_seed is None else args.fresh_seed
    confirm_seed = (
        confirmation_seed(args.seed, fresh) if args.confirm_seed is None else args.confirm_seed
    )
    cases = None
    if args.cases is not None:
        bad = [c for c in args.cases if c not in set(int(c) for c in table.case)]
        if bad:
            raise InputError(f"--cases {bad[0]}: no such rate case; cases are 1..{len(table.case)}")
        cases = [list(table.case).index(c) for c in args.cases]
    # Every parameter is checked before the estimate: a bad one is the one line on stderr.
    check_parameters(
        runs_per_case=args.runs_per_case,
        seed=args.seed,
        fresh_seed=fresh,
        duration_s=args.duration_s,
        max_iterations=args.max_iterations,
        search_runs_per_case=args.search_runs_per_case,
        confirm_seed=confirm_seed,
        vehicle=vehicle,
        max_propellant_rise_pct=args.max_propellant_rise_pct,
    )
    from rcsim.analysis.apps.estimates import REFINE_BYTES_PER_RUN as PER_RUN
    from rcsim.analysis.apps.estimates import check_memory, confirm, flying_seconds

    # The search (a few rounds) on its subset, the confirmation of the changed rows, then the
    # old and new tables (and Table 7) at full size; what cannot fit is refused first.
    n_cases = len(table.case) if cases is None else len(cases)
    check_memory(
        "the refinement", PER_RUN * n_cases * args.runs_per_case, parameter="runs_per_case",
        value=args.runs_per_case, advice="fewer runs per case",
    )  # fmt: skip
    search = min(args.search_runs_per_case, args.runs_per_case)
    simulated = args.duration_s * n_cases * (3 * search + 4 * args.runs_per_case)
    confirm(
        "the refinement",
        flying_seconds(simulated, runs=n_cases * args.runs_per_case),
        yes=args.yes,
        parameter="runs_per_case",
        value=args.runs_per_case,
    )
    ref = run_refinement(
        table,
        runs_per_case=args.runs_per_case,
        seed=args.seed,
        fresh_seed=fresh,
        cases=cases,
        duration_s=args.duration_s,
        max_iterations=args.max_iterations,
        search_runs_per_case=args.search_runs_per_case,
        progress=args.progress,
        checkpoint=checkpoint,
        confirm_seed=confirm_seed,
        vehicle=vehicle,
        max_propellant_rise=args.max_propellant_rise_pct / 100.0,
        plugin=plugin,
    )
    paths = write_refinement(ref, out, overwrite=args.overwrite)
    log = ref.changelog
    flown_by = "" if plugin is None else f", every table flown by {plugin.describe()}"
    print(
        f"refined {args.table}{flown_by}: {int(log['changed'].sum())} of {len(log)} cases changed "
        f"({ref.result.runs_flown} runs flown in the search and confirmation, "
        f"{args.runs_per_case} per case)"
    )
    for _, row in log[log["changed"]].iterrows():
        moves = ", ".join(
            f"{_axis_label(table, int(row['case']), a)} "
            f"{row[f'{axis}_old_s']:.2f}->{row[f'{axis}_new_s']:.2f} s"
            for a, axis in enumerate(("roll", "pitch", "yaw"))
            if row[f"{axis}_change_cycles"]
        )
        fuel = ""
        if "propellant_fresh_before_kg" in row:
            fuel = (
                f"; held-out seed propellant {1e3 * row['propellant_fresh_before_kg']:.4g} -> "
                f"{1e3 * row['propellant_fresh_after_kg']:.4g} g per run "
                f"({row['propellant_fresh_change_pct']:+.1f} %), failed "
                f"{int(row['failed_fresh_before'])} -> {int(row['failed_fresh_after'])}: "
                f"{row['held_out']}"
            )
        print(f"  case {int(row['case']):2d}: {moves}{fuel}")
    if "decision" in log:
        print(
            f"evidence (search seed {args.seed}: first {search} runs; confirmation seed "
            f"{confirm_seed}: {args.runs_per_case} runs; one-sided exact McNemar, p):"
        )
        for _, row in log[log["decision"] != "unchanged"].iterrows():
            print(
                f"  case {int(row['case']):2d}: {row['decision']}; on {row['decided_on']}: "
                f"search {int(row['search_b'])}:{int(row['search_c'])} p={row['search_p']:.2g}, "
                f"confirmation {int(row['confirm_b'])}:{int(row['confirm_c'])} "
                f"p={float(row['confirm_p']):.2g}; mirror: {row['mirror_decision']}"
            )
    if "refused" in log:
        refused = log[log["refused"].astype(object).fillna("").astype(str) != ""]
        if not refused.empty:
            print(
                "strictly better, but refused by the search gate (not significant, or "
                "propellant not paid for):"
            )
            for _, row in refused.iterrows():
                print(f"  case {int(row['case']):2d}: {row['refused']}")
    if ref.comparison is not None:
        print(f"held-out seed {fresh}, all searched cases (failure %, Clopper-Pearson 95 %):")
        for _, row in ref.comparison.iterrows():
            print(
                f"  {row['table']}: {int(row['failed'])} of {int(row['runs'])} failed "
                f"({row['failed_pct']:.2f} %, {row['failed_ci_lo_pct']:.2f}-"
                f"{row['failed_ci_hi_pct']:.2f}), {int(row['repeated'])} repeated"
            )
    # Each line compares the same runs with the original and the refined table.
    for seed_name, seed, what in (
        ("search", args.seed, f"search seed, its first {search} runs per case, the search's own"),
        ("fresh", fresh, f"held-out seed, {args.runs_per_case} runs per case"),
    ):
        print(
            f"seed {seed} ({what}): failed runs {int(log[f'failed_{seed_name}_before'].sum())}"
            f" -> {int(log[f'failed_{seed_name}_after'].sum())}, repeated-firing runs "
            f"{int(log[f'repeated_{seed_name}_before'].sum())} -> "
            f"{int(log[f'repeated_{seed_name}_after'].sum())}"
        )
    # The held-out check of every case (original and refined table on the same runs).
    print(
        f"held-out seed {fresh}, every case (exact one-sided McNemar, Holm over the cases): "
        + (f"REGRESSION: {ref.regressions}" if ref.regressions else "no case significantly worse")
    )
    print("wrote " + ", ".join(str(p) for p in paths.values()))
    return 0


def _table_plugin(args: argparse.Namespace, table, vehicle):
    """The ``--controller`` plug-in that flies the candidates, checked on ``table`` (None:
    rcsim's lookup controller); ``--param`` only with one."""
    from rcsim.analysis.apps.cli.maneuver import plugin_params
    from rcsim.analysis.apps.refinement.parameters import refinement_vehicle
    from rcsim.lookup.registry import is_plugin
    from rcsim.lookup.table_plugins import TablePlugin

    if args.controller is None:
        if args.param:
            raise InputError("--param is only for a --controller plug-in")
        return None
    if args.controller == "lookup":
        if args.param:
            raise InputError("--param is only for a --controller plug-in, not 'lookup'")
        return None
    if not is_plugin(args.controller):
        raise InputError(
            f"--controller {args.controller!r}: a refinement flies a lookup table: rcsim's "
            "lookup controller (the default) or a plug-in that declares its table parameter"
        )
    flown = refinement_vehicle(table, vehicle)[0]
    try:
        return TablePlugin.for_refinement(args.controller, plugin_params(args.param), flown, table)
    except InputError as exc:
        raise InputError(f"--controller: {exc}") from None


def _axis_label(table, case: int, axis: int) -> str:
    """``yaw``, or for a channel table the channel the case fires on that axis
    (``+yaw channel``)."""
    name = ("roll", "pitch", "yaw")[axis]
    if table.recipe is None:
        return name
    row = list(table.case).index(case)
    return f"{'+' if table.rate_cmd[row, axis] > 0 else '-'}{name} channel"
