"""The whole report's false-flag rate on null tables, and its power on planted ones (issue 29).

For each scenario of :func:`rcsim.analysis.results.drivers.synthetic.stratified_campaign` (26 cases
x 1,000 runs, 100 noise inputs, 5 % failures at random, plus the planted mechanism; per-axis
final rate errors so that the outcome family is analysed too), ``--tables`` seeded tables are
analysed by :func:`rcsim.analysis.results.drivers.pipeline.analyze` with the default
permutations (200 for inputs, 100 for the pairs' joint test) and the default report-wise budget
(5 %, split over the families by :mod:`rcsim.analysis.results.drivers.findings`).  The random
forest, the stability splits and the maps raise no flag and are left out
(:func:`~rcsim.analysis.results.drivers.synthetic.calibration_settings`).

Printed per scenario: the share of tables with a false flag in *any* family -- the report-wise
error, on ``null`` the share of tables with any flag at all -- with its 95 % Clopper-Pearson
interval and, for the budget's 5 %, the Binomial(n, 0.05) 0.99 quantile and the upper tail
P(X >= k); the same per family (singles, interactions, per case, outcomes); and the power: the
share of tables in which each planted driver (pooled, per case, interaction) is flagged.

Every table's result is appended to ``--tables-csv`` (``STEM_<scenario>.csv``) as soon as it
is done, so a run stopped early still leaves every finished table (``--first-seed`` resumes
after them).

Usage::

    python benchmarks/null_calibration.py --scenarios null --tables 100 --tables-csv t.csv
    python benchmarks/null_calibration.py --scenarios single two-cases ratio-band pair tail \\
        --tables 20 --tables-csv t.csv
    python benchmarks/null_calibration.py --summarise t_null.csv t_tail.csv   # counts only
    # few failures (about 10 in 26 x 200 runs), where chance regions are most tempting:
    python benchmarks/null_calibration.py --scenarios null --runs-per-case 200 --noise 30 \
        --failure-rate 0.002 --tables 60 --tables-csv few.csv
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

ALPHA = 0.05
FAMILIES = (
    "false_any",
    "false_single",
    "false_pair",
    "false_case",
    "false_outcome",
    "unflagged_region_said",
)


def summarise(frame) -> None:
    """Print the counts of a per-table frame (one row per scenario and seed)."""
    from scipy.stats import binom

    from rcsim.analysis.results.proportions import clopper_pearson

    for sc, g in frame.groupby("scenario", sort=False):
        n = len(g)
        seeds = f"seeds {int(g['seed'].min())}-{int(g['seed'].max())}"
        rate = (
            f", {100 * float(g['failure_rate'].iloc[0]):g} % failing at random"
            if "failure_rate" in g
            else ""
        )
        print(f"{sc}: {n} tables ({seeds}), 26 x {int(g['runs_per_case'].iloc[0])} runs{rate}")
        for key in [*FAMILIES, *sorted(c for c in g.columns if c.startswith("found "))]:
            if key not in g or g[key].isna().all():
                continue
            k = int(g[key].fillna(False).astype(bool).sum())
            lo, hi = clopper_pearson(k, n)
            line = f"  {key:24s} {k:3d}/{n}  {k / n:6.1%}  95 % CI {float(lo):.3f}-{float(hi):.3f}"
            if key.startswith("false_"):  # (unflagged_region_said: must be 0, no budget)
                bound = int(binom.ppf(0.99, n, ALPHA))
                tail = float(binom.sf(k - 1, n, ALPHA)) if k else 1.0
                line += f"  (Binomial({n}, {ALPHA}) 0.99 quantile {bound}; P(X >= {k}) {tail:.3g})"
            print(line)
        print(f"  flags per table: mean {g['flags'].mean():.2f}, max {int(g['flags'].max())}")
        print(f"  seconds per table: median {g['seconds'].median():.1f}")


def main() -> None:
    import pandas as pd

    from rcsim.analysis.results.drivers.synthetic import STRATIFIED, calibration_settings, flags

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first .. first + tables - 1")
    ap.add_argument("--scenarios", nargs="+", default=list(STRATIFIED), choices=STRATIFIED)
    ap.add_argument("--runs-per-case", type=int, default=1000)
    ap.add_argument("--noise", type=int, default=100)
    ap.add_argument(
        "--failure-rate",
        type=float,
        default=0.05,
        help="share of runs failing at random in every scenario (0.002: the few-failure "
        "tables, about 10 failed runs in 26 x 200)",
    )
    ap.add_argument("--permutations", type=int, default=200)
    ap.add_argument("--tables-csv", type=Path, default=None, help="append each table's row")
    ap.add_argument("--summarise", nargs="+", type=Path, default=None, help="only count CSVs")
    args = ap.parse_args()
    if args.summarise:
        # keep_default_na=False: pandas reads the scenario name "null" as a missing value.
        frames = [pd.read_csv(p, keep_default_na=False, na_values=[""]) for p in args.summarise]
        summarise(pd.concat(frames, ignore_index=True))
        return
    settings = calibration_settings(n_permutations=args.permutations)
    rows = []
    tty = sys.stderr.isatty()
    for sc in args.scenarios:
        for seed in range(args.first_seed, args.first_seed + args.tables):
            t0 = time.perf_counter()
            got = flags(
                sc,
                seed,
                settings,
                runs_per_case=args.runs_per_case,
                n_noise=args.noise,
                failure_rate=args.failure_rate,
            )
            row = {
                "scenario": sc,
                "seed": seed,
                "runs_per_case": args.runs_per_case,
                "noise_inputs": args.noise,
                "failure_rate": args.failure_rate,
                "permutations": args.permutations,
                **got,
                "seconds": round(time.perf_counter() - t0, 1),
            }
            rows.append(row)
            if args.tables_csv is not None:  # one file per scenario: their columns differ
                path = args.tables_csv.with_name(
                    f"{args.tables_csv.stem}_{sc}{args.tables_csv.suffix}"
                )
                new = not path.exists()
                pd.DataFrame([row]).to_csv(path, mode="a", header=new, index=False)
            done = seed - args.first_seed + 1
            if tty or done % 10 == 0 or done == args.tables:
                print(
                    f"{sc} seed {seed}: {got['flags']} flags, false any {got['false_any']} "
                    f"({done}/{args.tables}, {row['seconds']} s)",
                    file=sys.stderr,
                    flush=True,
                )
    summarise(pd.DataFrame(rows))


if __name__ == "__main__":
    main()
