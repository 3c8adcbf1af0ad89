"""``rcsim campaign rare``: the failure probability of a spec's cases when failures are rare.

Subset simulation (default) flies each case's runs level by level into ever rarer regions of
the dispersed inputs (``docs/rare_events.md``); the output directory resumes after a kill.
Exit status: 0 done (an unresolved case is a stated result: its bound is printed); 2 bad
input, nothing written; 130 interrupted, 143 terminated: DIR resumes with ``--resume``.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from rcsim.models.errors import InputError


def register(csub) -> None:
    """Add ``rare`` to ``rcsim campaign``'s actions."""
    from rcsim.analysis.apps.rare.settings import METHODS, REPEATS

    rare = csub.add_parser(
        "rare",
        help="estimate P(fail) of rare failures per case (subset simulation), resumable",
        description="Estimate each case's failure probability on the spec's vehicle when it is "
        "too small for plain Monte Carlo: subset simulation flies level after level of runs "
        "into the region where the failure margin (runs.parquet's margin column) is smallest, "
        "K times independently (--repeats), side by side on worker processes; the estimate is "
        "the mean of the K, its CoV and interval from their spread (never below Au & Beck's "
        "figure for their mean). A spec with several failure criteria (an attitude "
        "threshold, tracked propellant, a [failure] budget) is estimated as a series system: "
        "each criterion on its own margin from a shared first level, combined by series-system "
        "bounds (the largest lower end, the sum of the upper ends); a criterion whose region "
        "was not explored gets no bound or interval, and the line says which and what would "
        "resolve it. "
        "Prints per case the estimate with its CoV and 95 % interval (or, when no failure is "
        "found within the budget, an upper bound), the runs spent and the closest failure in "
        "sigmas; writes DIR/rare.json, DIR/runs.parquet (every run flown; conditional samples, "
        "not a Monte Carlo sample), DIR/failures.parquet.  Jet faults are not continuous and "
        "are refused.  See docs/rare_events.md.",
        epilog="exit status: 0 done (an unresolved case is a stated bound, not an error); 2 "
        "bad input, nothing written; 130 interrupted (Ctrl-C), 143 terminated: DIR resumes "
        "with --resume at the last finished level.",
    )
    rare.add_argument("spec", metavar="SPEC.toml")
    rare.add_argument("--out", required=True, metavar="DIR", help="output directory (new)")
    rare.add_argument(
        "--cases",
        metavar="NAMES",
        help="comma-separated case names of the spec (e.g. rate-02,rate-13); default: all",
    )
    rare.add_argument(
        "--method",
        choices=METHODS,
        default="subset",
        help="subset simulation (the one method offered: cross-entropy importance sampling "
        "was measured to report wrong probabilities with small CoVs in these dimensions, "
        "docs/rare_events.md)",
    )
    rare.add_argument(
        "--repeats",
        type=int,
        default=REPEATS,
        metavar="K",
        help=f"independent subset simulations per case (default {REPEATS}); the estimate is "
        "their mean, its CoV and interval from their spread, never below Au & Beck's figure "
        "for their mean; 1: one estimation "
        "with Au & Beck's conservative CoV (levels fully correlated)",
    )
    rare.add_argument(
        "--runs-per-level",
        type=int,
        default=500,
        metavar="N",
        help="runs per level of each repeat (a multiple of 10; default 500); level 0 of the "
        "repeats is the campaign's first K*N runs of the case when K*N <= runs_per_case",
    )
    rare.add_argument(
        "--budget",
        type=int,
        default=20_000,
        metavar="RUNS",
        help="most runs per case, all repeats and criteria together (default 20000; with "
        "one criterion each repeat gets RUNS/K; with C criteria the K first levels are flown "
        "once and the rest split into C*K equal shares); a level is started only if it fits",
    )
    rare.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="W",
        help="worker processes flying repeats side by side (default: one per CPU, at most "
        "K); the result does not depend on it",
    )
    rare.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="fly the repeats on an existing Dask cluster instead, e.g. tcp://host:8786 (its "
        "workers write into DIR: it must be on a filesystem they share); the result does "
        "not depend on it",
    )
    rare.add_argument(
        "--resume", action="store_true", help="continue an interrupted estimation in DIR"
    )
    rare.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="a line per finished level on stderr (default: when stderr is a terminal)",
    )
    rare.set_defaults(func=_rare, resume_hint=_resume_hint)


def _resume_hint(args) -> str:
    extra = f" --cases {shlex.quote(args.cases)}" if args.cases else ""
    if args.scheduler:
        extra += f" --scheduler {shlex.quote(args.scheduler)}"
    return (
        f"rcsim campaign rare {shlex.quote(args.spec)} --out {shlex.quote(args.out)}{extra} "
        f"--method {args.method} --repeats {args.repeats} --runs-per-level "
        f"{args.runs_per_level} --budget {args.budget} --resume"
    )


def case_indices(spec, names: str | None) -> list[int]:
    """Indices of the cases ``names`` (comma-separated) names, all when None."""
    if names is None:
        return list(range(len(spec.cases)))
    known = [c.name for c in spec.cases]
    wanted = [n.strip() for n in names.split(",")]
    for n in wanted:
        if n not in known:
            raise InputError(
                f"{n!r} is not a case of the spec (its cases: {', '.join(known[:8])}"
                f"{' ...' if len(known) > 8 else ''})",
                parameter="cases",
                value=n,
            )
    return [known.index(n) for n in dict.fromkeys(wanted)]


def settings_of(args):
    """The :class:`~rcsim.analysis.apps.rare.estimate.RareSettings` of the flags, checked."""
    from rcsim.analysis.apps.rare.settings import RareSettings

    n = args.runs_per_level
    if n < 10 or n % 10:
        raise InputError(
            f"--runs-per-level must be a multiple of 10 (p0 = 0.1: N/10 chains of 10 states), "
            f"at least 10, got {n}"
        )
    k = args.repeats
    if k < 1:
        raise InputError(f"must be at least 1, got {k}", parameter="repeats", value=k)
    if args.budget < k * n:
        raise InputError(
            f"--budget must allow level 0 of every repeat (--repeats {k} x --runs-per-level "
            f"{n} = {k * n} runs), got {args.budget}"
        )
    if args.workers is not None and args.scheduler is not None:
        raise InputError(
            "and --scheduler are exclusive: --workers runs the repeats on this "
            "machine's processes, --scheduler on an existing Dask cluster",
            parameter="workers",
            value=args.workers,
        )
    if args.workers is not None and args.workers < 1:
        raise InputError(
            f"must be at least 1, got {args.workers}",
            parameter="workers",
            value=args.workers,
        )
    return RareSettings(method=args.method, n_per_level=n, budget=args.budget, repeats=k)


def _rare(args) -> int:
    from rcsim.analysis.apps.cli.vehicle_args import warn_vehicle
    from rcsim.analysis.apps.rare.estimate import COMMAND, RECORD, check_resumable, estimate_cases
    from rcsim.analysis.apps.rare.flights import check_continuous
    from rcsim.analysis.engine.campaign.spec import load_spec
    from rcsim.analysis.engine.output import check_out_dir
    from rcsim.analysis.engine.output_records import write_marker

    spec = load_spec(args.spec)
    warn_vehicle(spec.vehicle)
    check_continuous(spec, args.spec)
    cases = case_indices(spec, args.cases)
    settings = settings_of(args)
    out = Path(args.out)
    if args.resume:
        if not (out / RECORD).is_file():
            raise InputError(
                f"{out}: --resume needs the directory of an interrupted `rcsim campaign rare` "
                f"(no {RECORD} there)",
                parameter="out",
                value=str(out),
            )
        out = check_out_dir(out, COMMAND, overwrite=True)
        check_resumable(out, spec, settings)
    else:
        out = check_out_dir(out, COMMAND)
    progress = sys.stderr.isatty() if args.progress is None else args.progress

    def echo(line: str) -> None:
        if progress:
            print(line, file=sys.stderr, flush=True)

    import os

    from rcsim.analysis.apps.rare.words import case_sentence
    from rcsim.analysis.engine.campaign.cluster import close, connect

    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    # Connected before DIR is made: an unreachable scheduler leaves nothing behind.
    client = None if args.scheduler is None else connect(None, args.scheduler)[0]
    try:
        out.mkdir(parents=True, exist_ok=True)
        write_marker(out, COMMAND)
        records = estimate_cases(
            spec, cases, settings, out, progress=echo, workers=workers, client=client
        )
    finally:
        if client is not None:
            close(client, None)
    for name, rec in records.items():
        print(case_sentence(name, rec))
    print(
        f"every run in {out}/runs.parquet, the failed ones in failures.parquet (`rcsim analyze "
        f"{out}/runs.parquet --vehicle ...` reads them: conditional samples, not a Monte "
        "Carlo sample, so the failure rate it prints is not the case's P(fail))"
    )
    return 0
