"""The pair interaction test alone on many full-size null tables (issue 16, pairs family).

Each table: 26 cases x ``--runs-per-case`` runs, ``--noise`` standard-normal inputs, failures at
random (5 %), so every pair is a null pair.  Printed: the share of tables in which some pair is
flagged (Holm-adjusted exact p < 0.05) with its 95 % Clopper-Pearson interval, and how the raw
p-values of all pairs of all tables compare with their nominal levels.

Usage::

    python benchmarks/interaction_null.py                 # 200 tables, 26 x 1,000, 100 inputs
    python benchmarks/interaction_null.py --tables 40 --first-seed 200
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> None:
    import numpy as np

    from rcsim.analysis.results.drivers.interaction import interaction_test
    from rcsim.analysis.results.proportions import clopper_pearson

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", type=int, default=200)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--runs-per-case", type=int, default=1000)
    ap.add_argument("--noise", type=int, default=100)
    args = ap.parse_args()
    n_cases, alpha = 26, 0.05
    levels = (1e-2, 1e-3, 1e-4, 1e-5)
    below = dict.fromkeys(levels, 0)
    flagged = tests = 0
    t0 = time.perf_counter()
    for seed in range(args.first_seed, args.first_seed + args.tables):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 778]))
        n = n_cases * args.runs_per_case
        X = rng.standard_normal((n, args.noise))
        strata = np.repeat(np.arange(n_cases), args.runs_per_case)
        failed = rng.random(n) < 0.05
        ia, ib = np.triu_indices(args.noise, 1)
        res = interaction_test(X, failed, strata, np.column_stack([ia, ib]))
        flagged += bool((res.p_holm < alpha).any())
        tests += res.p_raw.size
        for level in levels:
            below[level] += int((res.p_raw < level).sum())
    lo, hi = clopper_pearson(flagged, args.tables)
    print(
        f"{flagged} of {args.tables} null tables flag a pair ({100 * flagged / args.tables:.1f} %, "
        f"95 % CI {100 * lo:.1f}-{100 * hi:.1f} %); nominal {100 * alpha:g} %"
    )
    for level in levels:
        print(
            f"raw p < {level:g}: {below[level]:,} of {tests:,} pair tests "
            f"({level * tests:,.1f} expected)"
        )
    print(f"{(time.perf_counter() - t0) / args.tables:.2f} s per table")


if __name__ == "__main__":
    main()
