"""Failure-driver analysis: speed on a campaign, and the planted-truth recovery table.

Usage::

    python benchmarks/drivers.py speed CAMPAIGN_DIR      # time and peak memory of the analysis
    python benchmarks/drivers.py planted [--seeds 100]   # recovery rates for docs/drivers.md

``speed`` runs :func:`rcsim.analysis.results.drivers.pipeline.analyze` (what ``rcsim analyze`` does,
without
writing files) on a campaign directory and prints the time per step and the peak resident
memory.  The issue's target: the full Table 5 campaign (26 cases x 1,000 runs, 86 inputs,
3,655 pairs) in <= 30 s with < 2 GB on a 2-core machine.  ``planted`` prints the Markdown
table of :func:`rcsim.analysis.results.drivers.synthetic.recovery` over seeds 0..N-1 per scenario.
"""

from __future__ import annotations

import argparse
import resource
import time


def speed(path: str) -> None:
    from rcsim.analysis.results.drivers.inputs import load_runs
    from rcsim.analysis.results.drivers.pipeline import Settings, analyze

    t0 = time.perf_counter()
    rs = load_runs(path)
    t1 = time.perf_counter()
    res = analyze(rs, Settings())
    t2 = time.perf_counter()
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    n_pairs = len(res.pair_table) if res.pair_table is not None else 0
    print(f"runs {rs.y.size}, failed {int(rs.y.sum())}, inputs {rs.X.shape[1]}, pairs {n_pairs}")
    print(f"load + derived factors: {t1 - t0:.1f} s")
    for k, v in res.timings_s.items():
        print(f"  {k:10s} {v:6.1f} s")
    print(f"analysis total: {t2 - t1:.1f} s; peak RSS {peak_mb:.0f} MB")


def planted(n_seeds: int, n_permutations: int) -> None:
    from rcsim.analysis.results.drivers.synthetic import SCENARIOS, recovery

    keys = [
        "drivers_top",
        "drivers_significant",
        "pair_first",
        "false_positive",
        "ttest_drivers_top",
        "ttest_drivers_significant",
        "ttest_false_positive",
    ]
    print("| scenario | failures/run set | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 2) + "|")
    for sc in SCENARIOS:
        t = time.perf_counter()
        r = recovery(sc, range(n_seeds), n_permutations=n_permutations)
        cells = [str(r.get(k, "--")) for k in keys]
        print(
            f"| {sc} | | " + " | ".join(cells) + f" |   <!-- {time.perf_counter() - t:.0f} s -->",
            flush=True,
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    s = sub.add_parser("speed")
    s.add_argument("campaign")
    p = sub.add_parser("planted")
    p.add_argument("--seeds", type=int, default=100)
    p.add_argument("--permutations", type=int, default=200)
    args = ap.parse_args()
    if args.what == "speed":
        speed(args.campaign)
    else:
        planted(args.seeds, args.permutations)


if __name__ == "__main__":
    main()
