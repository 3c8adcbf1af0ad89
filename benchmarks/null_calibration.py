"""Null calibration of every flag `rcsim analyze` raises, at full campaign size (issue 16).

For each scenario of :func:`rcsim.analysis.results.drivers.synthetic.stratified_campaign` (26 cases
x 1,000 runs, 100 noise inputs, 5 % failures at random, plus the planted mechanism), ``--tables``
seeded tables are analysed by :func:`rcsim.analysis.results.drivers.pipeline.analyze` with the
default permutations (200 for inputs, 100 for pairs, alpha 0.05; the random forest, the
stability splits and the maps raise no flag and are left out: see
:func:`~rcsim.analysis.results.drivers.synthetic.calibration_settings`).  Printed per scenario and
flag family (singles, pairs, per case): the share of tables with at least one false flag, with
its 95 % Clopper-Pearson interval, and the recovery of the planted truth.

``null`` is the pure null (every flag false); ``single`` (one strong driver in every case, no
interaction) and ``two-cases`` (two drivers in two different cases) are nulls for the pair
interaction test; ``ratio-band`` and ``pair`` plant an interaction.

Usage::

    python benchmarks/null_calibration.py                        # 20 tables per scenario
    python benchmarks/null_calibration.py --tables 40 --scenarios null single
    python benchmarks/null_calibration.py --csv out.csv          # also the counts as CSV
    python benchmarks/null_calibration.py --tables 10 --first-seed 10   # seeds 10..19
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

FAMILIES = ("false_single", "false_pair", "false_case")
RECOVERY = ("true_singles", "true_case", "true_interaction", "interaction_first")


def main() -> None:
    import pandas as pd

    from rcsim.analysis.results.drivers.synthetic import STRATIFIED, calibration_settings, flags
    from rcsim.analysis.results.proportions import clopper_pearson

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first .. first + tables - 1")
    ap.add_argument("--scenarios", nargs="+", default=list(STRATIFIED), choices=STRATIFIED)
    ap.add_argument("--runs-per-case", type=int, default=1000)
    ap.add_argument("--noise", type=int, default=100)
    ap.add_argument("--csv", type=Path, default=None)
    args = ap.parse_args()
    settings = calibration_settings()
    rows = []
    for sc in args.scenarios:
        t0 = time.perf_counter()
        counts: dict = {}
        for seed in range(args.first_seed, args.first_seed + args.tables):
            for key, hit in flags(
                sc, seed, settings, runs_per_case=args.runs_per_case, n_noise=args.noise
            ).items():
                counts[key] = counts.get(key, 0) + int(bool(hit))
        dt = time.perf_counter() - t0
        n = args.tables
        print(f"{sc}: {n} tables of 26 x {args.runs_per_case} runs, {dt:.0f} s", flush=True)
        for key in FAMILIES + RECOVERY:
            if key not in counts:
                continue
            k = counts[key]
            lo, hi = clopper_pearson(k, n)
            print(f"  {key:18s} {k:3d}/{n}  {k / n:6.1%}  95 % CI {float(lo):.3f}-{float(hi):.3f}")
            rows.append(
                {
                    "scenario": sc,
                    "criterion": key,
                    "tables": n,
                    "first_seed": args.first_seed,
                    "count": k,
                    "rate": k / n,
                    "ci95_lo": float(lo),
                    "ci95_hi": float(hi),
                    "runs_per_case": args.runs_per_case,
                    "noise_inputs": args.noise,
                    "seconds": round(dt, 1),
                }
            )
    if args.csv is not None:
        pd.DataFrame(rows).to_csv(args.csv, index=False)
        print(f"wrote {args.csv}")


if __name__ == "__main__":
    main()
