"""Benchmark: a failure with several criteria, by one margin and as a series system.

For each two-criterion limit state (``rcsim.analysis.engine.rare.limit_states``: the far
criterion -- ``min(0.3 (1 - u_1 / 10), 1 - u_2 / 4.5)`` in d = 10, P = 3.4e-6 -- and two
criteria within reach in d = 86, P = 1.12e-5; truth ``1 - prod (1 - p_i)``) it runs
``--repeat`` estimations (seeds 0 .. R-1) by two methods with the same settings (K repeats of
N per level, a budget of evaluations):

* ``single margin`` -- ``repeated_subset_simulation`` on ``min_i g_i`` (what the campaign's
  ``margin`` column gives);
* ``series`` -- ``series_subset_simulation`` on the criteria's own margins, combined with
  series-system bounds (``rcsim.analysis.engine.rare.series``);

and prints one row per method and state: the statuses, how many printed a bound or an interval
that misses the truth (a bound below it, an interval not holding it), how many covered it, the
mean estimate over the truth, the median interval width (upper / lower end) and the mean
evaluations.  A result that states neither (``not_explored``) is counted apart: it is not a
wrong answer.

Usage: ``python benchmarks/rare_event_series.py [--repeat R] [--n-per-level N] [--repeats K]
[--budget B] [--json FILE]``; ``docs/rare_events.md`` records the printed table.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from collections import Counter

import numpy as np

from rcsim.analysis.engine.rare import SubsetConfig, limit_states, repeated_subset_simulation
from rcsim.analysis.engine.rare.intervals import clopper_pearson
from rcsim.analysis.engine.rare.series import series_subset_simulation


def cases(budget: int) -> list[tuple]:
    """(limit state, total budget): the d = 86 state needs more levels for its 1e-6 criterion."""
    return [(limit_states.far_criterion(10), budget), (limit_states.two_criteria(86), budget)]


def judge(truth: float, status: str, interval, bound) -> str:
    """``covered``, ``missed`` (a stated interval or bound the truth is outside), ``silent``
    (nothing stated)."""
    if interval is not None:
        return "covered" if interval[0] <= truth <= interval[1] else "missed"
    if bound is not None:
        return "covered" if truth <= bound else "missed"
    return "silent"


def measure(method: str, limit, repeat: int, n: int, k: int, budget: int) -> dict:
    start = time.perf_counter()
    config = SubsetConfig(n_per_level=n, max_evaluations=budget)
    verdicts: Counter = Counter()
    statuses: Counter = Counter()
    est, widths, evals = [], [], []
    for seed in range(repeat):
        if method == "series":
            res = series_subset_simulation(
                limit.margins, limit.dim, config, k, seed=seed, names=limit.names
            )
        else:
            res = repeated_subset_simulation(limit, limit.dim, config, k, seed=seed)
        statuses[res.status] += 1
        verdicts[judge(limit.probability, res.status, res.interval, res.upper_bound)] += 1
        evals.append(res.n_evaluations)
        if res.probability is not None:
            est.append(res.probability)
        if res.interval is not None and res.interval[0] > 0:
            widths.append(res.interval[1] / res.interval[0])
    stated = verdicts["covered"] + verdicts["missed"]
    return {
        "method": method,
        "limit_state": limit.name,
        "truth": limit.probability,
        "repeat": repeat,
        "statuses": dict(statuses),
        "covered": verdicts["covered"],
        "missed": verdicts["missed"],
        "silent": verdicts["silent"],
        "coverage_interval": clopper_pearson(verdicts["covered"], stated) if stated else None,
        "mean_ratio": float(np.mean(est) / limit.probability) if est else math.nan,
        "median_width": float(np.median(widths)) if widths else math.nan,
        "evals": float(np.mean(evals)),
        "seconds": time.perf_counter() - start,
    }


def _fmt(row: dict) -> str:
    ci = row["coverage_interval"]
    cover = f"{row['covered']}/{row['covered'] + row['missed']}"
    if ci is not None:
        cover += f" ({ci[0]:.2f}-{ci[1]:.2f})"
    st = ", ".join(f"{k} {v}" for k, v in sorted(row["statuses"].items()))
    return (
        f"| {row['method']} | {row['limit_state']} | {row['truth']:.3g} | {st} | {cover} | "
        f"{row['missed']} | {row['silent']} | {row['mean_ratio']:.3f} | "
        f"{row['median_width']:.3g} | {row['evals']:,.0f} |"
    )


HEADER = (
    "| method | limit state | truth | statuses | cover (95 % CI) | wrong | silent | "
    "mean est / truth | hi/lo | evals |\n|---|---|---|---|---|---|---|---|---|---|"
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=100)
    parser.add_argument("--n-per-level", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=4)
    parser.add_argument("--budget", type=int, default=30_000)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.repeat < 1 or args.repeats < 1:
        parser.error("--repeat and --repeats must be at least 1")
    if args.budget < args.repeats * args.n_per_level:
        parser.error(
            f"--budget must allow level 0 of every repeat ({args.repeats} x {args.n_per_level})"
        )
    print(
        f"Python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} CPUs; "
        f"{args.repeat} repetitions, K = {args.repeats} repeats of N = {args.n_per_level} per "
        f"level, budget {args.budget:,} evaluations",
        flush=True,
    )
    print(HEADER, flush=True)
    rows = []
    for limit, budget in cases(args.budget):
        for method in ("single margin", "series"):
            row = measure(method, limit, args.repeat, args.n_per_level, args.repeats, budget)
            rows.append(row)
            print(_fmt(row), flush=True)
    print(f"estimations: {sum(r['seconds'] for r in rows):.1f} s in all", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows}, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
