"""``rcsim campaign example | run | replay | rare``: Monte Carlo dispersion campaigns.

Exit status of ``campaign run``: 0 done (and the failure gate, if any, passed); 2 bad input;
:data:`GATE_FAILED` (3) everything written, but more than ``max_failed_pct`` percent of the
runs failed; 130 Ctrl-C; 143 SIGTERM (128 + 15, as a shell reports a process the signal
killed).  The campaign directory is resumable after 130 and 143.
"""

from __future__ import annotations

import argparse
import shlex
import signal
import sys
from pathlib import Path

from rcsim.models.errors import InputError

#: Exit status of ``campaign run`` when the failure gate fails (2: user errors, 130: Ctrl-C).
GATE_FAILED = 3
#: Exit status after SIGTERM: 128 + the signal's number, the shell's convention.
TERMINATED = 128 + int(signal.SIGTERM)

_EXIT_STATUS = (
    f"exit status: 0 done (and the failure gate passed, if there is one); 2 bad input, "
    f"nothing written; {GATE_FAILED} every output written, but more than P % of the runs "
    f"failed (--max-failed-pct P, or failure.max_failed_pct in SPEC.toml); 130 interrupted "
    f"(Ctrl-C), {TERMINATED} terminated (SIGTERM): DIR is left resumable with --resume."
)


def register(sub) -> None:
    p = sub.add_parser(
        "campaign",
        help="Monte Carlo dispersion campaigns (Table 5): example spec, run, replay a run",
        description="Dispersed Monte Carlo campaigns of the 26 rate cases, maneuvers or attitude "
        "holds with either controller.  See `rcsim campaign example` and docs/campaigns.md.",
    )
    csub = p.add_subparsers(dest="campaign_command", metavar="ACTION", parser_class=type(p))
    csub.required = True

    ex = csub.add_parser("example", help="print a commented campaign spec (TOML)")
    ex.set_defaults(func=_example)

    run = csub.add_parser(
        "run",
        help="run (or --resume) a campaign into DIR",
        description="Fly every run of SPEC.toml and write DIR/runs.parquet (one row per run), "
        "DIR/cases.csv, DIR/envelopes.parquet, DIR/manifest.json, DIR/histories/ and DIR/plots/.  "
        "Results do not depend on --workers, --scheduler or chunk size.",
        epilog=_EXIT_STATUS,
    )
    run.add_argument("spec", metavar="SPEC.toml")
    run.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="campaign directory: new or empty, or with --resume the directory of "
        "an interrupted campaign of the same spec; a campaign is never "
        "replaced, and a directory another command wrote is refused",
    )
    run.add_argument(
        "--runs-per-case", type=int, metavar="N", help="override the spec's runs_per_case"
    )
    where = run.add_mutually_exclusive_group()  # argparse names both flags when both are given
    where.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="start a local Dask cluster with N single-threaded workers",
    )
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="send chunks to an existing Dask scheduler, e.g. tcp://host:8786",
    )
    run.add_argument(
        "--resume",
        action="store_true",
        help="finish the campaign in DIR without redoing finished chunks",
    )
    run.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )
    run.add_argument(
        "--max-failed-pct",
        type=float,
        metavar="P",
        help="failure gate for CI: after writing everything, exit with status "
        f"{GATE_FAILED} if more than P %% (0..100) of the campaign's runs "
        "failed; overrides the spec's failure.max_failed_pct.  Applies to "
        "a resumed or already complete campaign too",
    )
    run.add_argument(
        "--yes",
        action="store_true",
        help="start even if the estimate is over 30 minutes (the estimate is printed first)",
    )
    run.set_defaults(func=_run, resume_hint=_resume_hint)

    rp = csub.add_parser(
        "replay", help="re-fly one run of a campaign with its full history and plots"
    )
    rp.add_argument("campaign", metavar="DIR", help="the campaign directory (`campaign run --out`)")
    rp.add_argument(
        "run_id",
        metavar="RUN_ID",
        type=int,
        help="run to re-fly, 0 .. runs-1 (the run_id column of runs.parquet)",
    )
    rp.add_argument(
        "--out",
        metavar="OUT",
        help="output directory (default DIR/replays/run-NNNNNNN); an existing one is "
        "refused unless it holds an earlier replay and --overwrite is given",
    )
    rp.add_argument(
        "--overwrite",
        action="store_true",
        help="replace OUT if it holds an earlier `rcsim campaign replay`'s outputs",
    )
    rp.set_defaults(func=_replay)

    from rcsim.analysis.apps.cli.campaign_rare import register as register_rare

    register_rare(csub)


def _example(args) -> int:
    from rcsim.analysis.engine.campaign.spec import EXAMPLE_SPEC

    sys.stdout.write(EXAMPLE_SPEC)
    return 0


def _resume_hint(args) -> str:
    workers = f" --workers {args.workers}" if args.workers else ""
    spec, out = shlex.quote(args.spec), shlex.quote(args.out)
    return f"rcsim campaign run {spec} --out {out}{workers} --resume"


def _run(args) -> int:
    from rcsim.analysis.engine.campaign.runner import run_campaign, summary_text
    from rcsim.analysis.engine.campaign.spec import load_spec

    spec = load_spec(args.spec)
    from rcsim.analysis.apps.cli.vehicle_args import warn_vehicle

    warn_vehicle(spec.vehicle)
    if args.runs_per_case is not None:
        if args.runs_per_case < 1:
            raise InputError(f"--runs-per-case must be >= 1, got {args.runs_per_case}")
        spec = spec.with_runs_per_case(args.runs_per_case)
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be >= 1, got {args.workers}")
    if args.max_failed_pct is not None:
        spec = spec.with_max_failed_pct(args.max_failed_pct)  # InputError under the flag's name
    from rcsim.analysis.apps.estimates import confirm, flying_seconds
    from rcsim.analysis.engine.campaign.runner import check_fits

    if not args.resume:  # a new campaign: the path's and the disk's verdicts before the clock's
        from rcsim.analysis.engine.output import check_out_dir

        check_fits(spec, check_out_dir(args.out, "campaign run", overwrite=True))
    simulated = sum(case.duration_s for case in spec.cases) * spec.runs_per_case
    confirm(
        f"the campaign ({spec.n_runs:,} runs)",
        flying_seconds(simulated, runs=spec.n_runs),
        yes=args.yes,
        parameter="runs_per_case" if args.runs_per_case is not None else None,
        value=spec.runs_per_case,
        source=""
        if args.runs_per_case is not None
        else f"{args.spec}: runs_per_case = {spec.runs_per_case}",
    )
    report = run_campaign(
        spec,
        args.out,
        workers=args.workers,
        scheduler=args.scheduler,
        resume=args.resume,
        progress=args.progress,
        spec_file=args.spec,
    )
    print(summary_text(report, spec))
    gate = report.gate
    if gate is None:
        return 0
    source = (
        "--max-failed-pct"
        if args.max_failed_pct is not None
        else f"{args.spec}: failure.max_failed_pct"
    )
    if gate.passed:
        print(f"{gate.text()} (from {source})", flush=True)
        return 0
    sys.stdout.flush()  # the summary before the verdict, also when both go to one file
    print(
        f"rcsim: {gate.text()} (from {source}); every output is in {report.out}/", file=sys.stderr
    )
    return GATE_FAILED


def _replay(args) -> int:

    from rcsim.analysis.engine.campaign.replay import COMMAND, load_campaign_spec, replay
    from rcsim.analysis.engine.output import check_out_dir

    load_campaign_spec(Path(args.campaign))  # "not a campaign" before anything about OUT

    # The default of replay()'s `out`, spelled out so that it is checked before the flight.
    out = (
        Path(args.out)
        if args.out is not None
        else Path(args.campaign) / "replays" / f"run-{args.run_id:07d}"
    )
    out = check_out_dir(out, COMMAND, overwrite=args.overwrite)
    result = replay(Path(args.campaign), args.run_id, out, overwrite=args.overwrite)
    row = result["row"]
    rates = ", ".join(f"{row[f'final_rate_err_{a}_deg_s']:.4f}" for a in ("roll", "pitch", "yaw"))
    print(
        f"run {args.run_id} ({result['case']}): final rate error [{rates}] deg/s, "
        f"{int(row['firings_total']) if row['firings_total'] == row['firings_total'] else 'n/a'} "
        f"firings, failed={row['failed']}" + (f" ({row['reason']})" if row["reason"] else "")
    )
    if result["matches"] is True:
        print("replay matches the campaign's runs.parquet row exactly")
    elif result["matches"] is False:
        print(
            "WARNING: replay differs from the campaign's runs.parquet row "
            "(code or data changed since the campaign ran?)",
            file=sys.stderr,
        )
    print(f"history and plots in {result['out']}/")
    return 0
