"""``rcsim analyze``: failure drivers of a campaign (or any table of runs) and its report.

Argument parsing and error reporting only; the work is :mod:`rcsim.analysis.results.drivers`.
"""

from __future__ import annotations

import sys


def register(subparsers) -> None:
    """Add the ``analyze`` command.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
    """
    parser = subparsers.add_parser(
        "analyze",
        help="find the dispersions that drive failures; write a report",
        description=(
            "Failure-driver analysis (TRAM-like): rank-scale kernel density comparison of "
            "failed and successful runs for every input and every pair, permutation p-values "
            "corrected for the number of tests, failure regions, half-sample stability, kNN "
            "failure maps and a random-forest ranking for comparison, per case and across cases; "
            "PRIM scenario boxes.  Failure probabilities (overall, per case, per failure "
            "region, per box) carry exact (Clopper-Pearson) 95 % intervals; the per-axis "
            "outcomes and a second threshold are analysed beside the pooled one.  One "
            "false-flag budget (5 %) covers every flag the report shows; the command prints "
            "them all, the findings on the failures before the outcome drivers; failure "
            "regions are shown for flagged drivers only.  Writes drivers.csv, pairs.csv, "
            "cases.csv, summary.csv, outcomes.csv, findings.csv, conclusions.json (what the "
            "report concludes, which the loop's report renders too), boxes.csv, box_limits.csv, "
            "trajectory.csv, driver_regions.csv, figures/ and report.html.  Beyond 250,000 "
            "runs (after --case) it reads and analyses a uniform random subsample of 250,000 "
            "drawn with --seed, and says so."
        ),
    )
    parser.add_argument(
        "path",
        metavar="PATH",
        help="campaign directory (from rcsim campaign run) or a .parquet/.csv "
        "table with one row per run",
    )
    parser.add_argument(
        "--inputs",
        metavar="A,B,...",
        help="comma-separated input columns (default: the campaign's recorded "
        "inputs plus physics-aware factors)",
    )
    parser.add_argument(
        "--outcome",
        default="failed",
        metavar="COLUMN",
        help="binary outcome column, true/1 = failed (default: failed)",
    )
    parser.add_argument("--case", metavar="CASE", help="analyse only this case (e.g. rate-13)")
    parser.add_argument(
        "--vehicle",
        metavar="FILE",
        help="the vehicle the runs flew (a packaged name or a vehicle file), for the "
        "physics-aware factors of a table file; a campaign directory's manifest names its own, "
        "and a table without --vehicle gets no physics-aware factors (never a guessed vehicle)",
    )
    # dest = the library's parameter names, so that its errors are shown under these flags.
    parser.add_argument(
        "--permutations",
        dest="n_permutations",
        type=int,
        default=200,
        metavar="B",
        help="label permutations for the p-values, >= 19 (default 200; below 199 the 1 %% "
        "shares of the 5 %% false-flag budget cannot be reached, and the command says which)",
    )
    parser.add_argument(
        "--seed",
        dest="random_state",
        type=int,
        default=0,
        metavar="S",
        help="seed of the permutations, resamples and of the subsample of a table of more "
        "than 250,000 runs, >= 0 (default 0)",
    )
    parser.add_argument(
        "--bound-p",
        dest="bound_p",
        type=float,
        default=0.01,
        metavar="P",
        help="failure probability the 'runs to bound' answers are for: how many runs bound "
        "each failure probability below P at 95 %% confidence (default 0.01)",
    )
    parser.add_argument(
        "--second-threshold",
        dest="second_threshold",
        type=float,
        default=0.06,
        metavar="DEG_S",
        help="rate threshold [deg/s] of the threshold sensitivity, analysed beside the "
        "campaign's own (default 0.06)",
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output directory (created; an earlier `rcsim analyze` output is "
        "replaced only with --overwrite)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace DIR if an earlier `rcsim analyze` wrote it",
    )
    parser.add_argument(
        "--yes",
        action="store_true",
        help="start even if the memory estimate is over half of this machine's memory",
    )
    parser.set_defaults(func=_run)


def _probability(res) -> str:
    """The overall failure probability, its exact interval and the runs that bound it."""
    from rcsim.analysis.results.drivers.probabilities import bound_words, overall_table, p_with_ci

    row = overall_table(res).iloc[0]
    p = p_with_ci(row["failure_probability"], row["cp95_low"], row["cp95_high"])
    bound = bound_words(row["runs_to_bound"], int(row["runs"]), float(row["bound_p"]))
    return f"{p}, Clopper-Pearson; {bound}"


def _run(args) -> int:
    from rcsim.analysis.results.drivers.findings import blind_families, findings, summary_lines
    from rcsim.analysis.results.drivers.pipeline import Settings, analyze
    from rcsim.models.errors import InputError

    # Settings checks its own values; built first so that a bad one costs nothing.
    settings = Settings(
        n_permutations=args.n_permutations,
        random_state=args.random_state,
        bound_p=args.bound_p,
        second_threshold=args.second_threshold,
    )
    inputs = None
    if args.inputs is not None:
        inputs = [s.strip() for s in args.inputs.split(",") if s.strip()]
        if not inputs:
            raise InputError(f"names no column: {args.inputs!r}", parameter="inputs")
    from rcsim.analysis.engine.output import check_out_dir
    from rcsim.analysis.results.drivers.inputs import load_runs
    from rcsim.analysis.results.drivers.outputs import COMMAND, write_analysis

    # Before minutes of work; never over its own input.
    check_out_dir(args.out, COMMAND, overwrite=args.overwrite, inputs={"PATH": args.path})
    runset = load_runs(
        args.path,
        inputs=inputs,
        outcome=args.outcome,
        case=args.case,
        vehicle=args.vehicle,
        seed=args.random_state,
        yes=args.yes,
    )
    res = analyze(runset, settings)
    report = write_analysis(res, args.out, overwrite=args.overwrite)
    n, nf = runset.y.size, int(runset.y.sum())
    if runset.subsampled:
        print(
            f"{n:,} of {runset.total_runs:,} runs analysed (a seeded uniform subsample), "
            f"{nf:,} failed of them ({runset.total_failed:,} of all); "
            f"{len(runset.X.columns)} inputs analysed"
        )
    else:
        print(f"{n} runs, {nf} failed; {len(runset.X.columns)} inputs analysed")
    if runset.conditional:
        print(
            f"failure fraction of these runs {_probability(res)} -- not the cases' P(fail): "
            "conditional samples of a rare-event estimation (note below)"
        )
    else:
        print(f"failure probability {_probability(res)}")
    for note in res.runset.notes:  # the analysis may add one (a subsample)
        print(f"note: {note}")
    if res.has_failures and res.drivers is not None:
        # Every flag the report shows, family by family (the same list as findings.csv and
        # the report's summary): none left out without saying how many.
        for line in summary_lines(findings(res), settings.alpha):
            print(line)
        blind = blind_families(res)
        if blind:
            print(f"note: with these permutations no flag is possible in: {'; '.join(blind)}")
    elif nf == n:
        print(
            "every run failed: no successful run to compare with, so no input can be a "
            "driver; the report says so"
        )
    else:
        print("no failures to analyse: the report says so")
    print(f"report: {report}", file=sys.stdout)
    return 0
