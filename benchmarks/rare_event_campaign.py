"""Benchmark: ``rcsim campaign rare`` (the campaign adapter) on one rate case, repeated over seeds.

Each repeat is one estimation by :func:`rcsim.analysis.apps.rare.estimate.estimate_cases` --
what the command runs -- on a spec of one rate case of the paper's vehicle (Table 5
dispersions x ``--scale``, ``--table``, the failure threshold ``--threshold-deg-s``) with seed
``first-seed + r``: its estimate, interval, CoV, runs and wall time.  Then their mean, the
empirical CoV, and, with ``--reference P LO HI`` (a plain Monte Carlo estimate and its interval),
how many intervals hold ``P``.  Used for ``docs/rare_events.md`` ("Through the command"): the
agreement with plain Monte Carlo at P ~ 5e-3, and the cost at P ~ 1e-5.

Several criteria (``docs/rare_events.md``, "Several criteria"): ``--attitude-deg A`` adds the
attitude criterion (the estimation is then a series system, each criterion on its own margin),
``--duration-s`` sets the scenario's length, and ``--plain-mc RUNS`` flies that many campaign
runs of the same spec on seed 1,000,000 (independent of the estimations' seeds) as the
reference, printing its count per criterion and its exact interval; each estimation's line then
gives every criterion's own figures and whether its interval holds the reference.

Usage: ``python benchmarks/rare_event_campaign.py [--case 2] [--threshold-deg-s 0.04]
[--repeat 5] [--repeats 4] [--runs-per-level 500] [--budget 20000] [--workers W]
[--reference P LO HI] [--attitude-deg A] [--duration-s T] [--plain-mc RUNS] [--out DIR]``
(``--repeat``: estimations, one per seed; ``--repeats``: the
independent subset simulations each estimation combines, as the command's flag)
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rcsim.analysis.apps.rare.estimate import estimate_cases
from rcsim.analysis.apps.rare.settings import RareSettings
from rcsim.analysis.engine.campaign.spec import parse_dict


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", type=int, default=2)
    parser.add_argument("--table", default="table6")
    parser.add_argument("--scale", type=float, default=1.0)
    parser.add_argument("--threshold-deg-s", type=float, default=0.04)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--runs-per-level", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=4)
    parser.add_argument("--budget", type=int, default=20_000)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--reference", type=float, nargs=3, metavar=("P", "LO", "HI"))
    parser.add_argument("--out", help="keep the estimations here (default: a temporary folder)")
    parser.add_argument("--attitude-deg", type=float, default=None)
    parser.add_argument("--duration-s", type=float, default=None)
    parser.add_argument("--plain-mc", type=int, default=0, metavar="RUNS")
    args = parser.parse_args(argv)
    root = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="rare-bench-"))
    settings = RareSettings(
        n_per_level=args.runs_per_level, budget=args.budget, repeats=args.repeats
    )
    print(
        f"case {args.case}, {args.table}, Table 5 x {args.scale:g}, threshold "
        f"{args.threshold_deg_s:g} deg/s, {args.repeats} repeats of N = {args.runs_per_level}, "
        f"budget {args.budget}, {args.workers} workers",
        flush=True,
    )

    def spec_of(seed: int, runs_per_case: int):
        scenario: dict = {"kind": "rate-cases", "cases": [args.case]}
        if args.duration_s is not None:
            scenario["duration_s"] = args.duration_s
        failure: dict = {"rate_error_deg_s": args.threshold_deg_s}
        if args.attitude_deg is not None:
            failure["attitude_error_deg"] = args.attitude_deg
        return parse_dict(
            {
                "seed": seed,
                "runs_per_case": runs_per_case,
                "scenario": scenario,
                "controller": {"name": "lookup", "table": args.table},
                "dispersions": {"scale": args.scale},
                "failure": failure,
                "output": {"histories": "none", "plots": False},
            }
        )

    if args.plain_mc:
        args.reference = plain_monte_carlo(spec_of(1_000_000, args.plain_mc), args.workers)
    estimates, runs, walls, covers = [], [], [], 0
    for r in range(args.repeat):
        seed = args.first_seed + r
        spec = spec_of(seed, args.repeats * args.runs_per_level)
        start = time.perf_counter()
        rec = next(
            iter(
                estimate_cases(
                    spec, [0], settings, root / f"seed-{seed}", workers=args.workers
                ).values()
            )
        )
        wall = time.perf_counter() - start
        runs.append(rec["runs"])
        walls.append(wall)
        if rec["probability"] is None:
            print(f"  seed {seed}: {rec['status']}, bound {rec['upper_bound']:.3g}", flush=True)
            continue
        estimates.append(rec["probability"])
        lo, hi = rec["interval"]
        held = ""
        if args.reference is not None:
            covers += lo <= args.reference[0] <= hi
            held = " holds the reference" if lo <= args.reference[0] <= hi else " MISSES it"
        cf = rec["closest_failure"]
        top = ", ".join(f"{n} {v:+.1f}" for n, v in cf["largest"])
        cov = "" if rec["cov"] is None else f", CoV {rec['cov']:.2f}"
        print(
            f"  seed {seed}: {rec['status']} P = {rec['probability']:.4g} ({lo:.3g} - {hi:.3g}"
            f"{cov}){held} in {rec['runs']:,} runs, {wall:.0f} s; closest failure "
            f"{cf['sigma_active']:.2f} sigma ({top})",
            flush=True,
        )
        for name, c in (rec.get("criteria") or {}).items():
            own = (
                f"P < {c['upper_bound']:.3g}"
                if c["interval"] is None
                else f"P = {c['probability']:.4g} ({c['interval'][0]:.3g} - {c['interval'][1]:.3g})"
            )
            print(
                f"    {name}: {c['status']} {own}, {c['failures_found']} failure runs of its "
                f"own chains, {c['runs']:,} runs counted",
                flush=True,
            )
    e = np.asarray(estimates)
    line = f"{e.size} estimates: mean P = {e.mean():.4g}" if e.size else "no estimate"
    if e.size > 1:
        line += f", empirical CoV {e.std(ddof=1) / e.mean():.3f}"
    if args.reference is not None and e.size:
        line += f", {covers} of {e.size} intervals hold the reference {args.reference[0]:.4g}"
    line += (
        f"; runs {np.mean(runs):,.0f} mean ({min(runs):,}-{max(runs):,}); wall "
        f"{np.mean(walls):.0f} s mean ({min(walls):.0f}-{max(walls):.0f} s)"
    )
    print(line, flush=True)
    return 0


def plain_monte_carlo(spec, workers: int) -> list[float]:
    """The spec's campaign runs of its one case, flown in chunks: P, its exact 95 % interval;
    the count per criterion printed."""
    from rcsim.analysis.engine.campaign.chunk import Chunk, simulate_chunk
    from rcsim.analysis.engine.rare.intervals import clopper_pearson

    start = time.perf_counter()
    n = spec.runs_per_case
    size = 2000
    frames = [simulate_chunk(spec, Chunk(lo, min(n, lo + size))).runs for lo in range(0, n, size)]
    failed = np.concatenate([f["failed"].to_numpy(bool) for f in frames])
    by = [v for f in frames for v in f["failed_by"]]
    k = int(failed.sum())
    lo, hi = clopper_pearson(k, n)
    counts: dict[str, int] = {}
    for v in by:
        for name in filter(None, str(v).split("+")):
            counts[name] = counts.get(name, 0) + 1
    print(
        f"plain Monte Carlo: {k} of {n:,} runs failed, P = {k / n:.4g} (95 % {lo:.3g} - "
        f"{hi:.3g}); by criterion {counts}; {time.perf_counter() - start:.0f} s",
        flush=True,
    )
    return [k / n, lo, hi]


if __name__ == "__main__":
    sys.exit(main())
