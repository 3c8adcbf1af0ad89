"""Benchmark: rare-event estimators on analytic limit states with known failure probability.

For each limit state (``rcsim.analysis.engine.rare.limit_states``: linear in d = 10 and 86 at
P = 1e-3, 1e-5, 1e-6; two opposite failure regions; a curved boundary) and each method, runs
``--repeat`` independent estimations (seeds 0 .. R-1) and prints one row:

* ``truth``, ``mean est / truth`` (bias), ``emp CoV`` (the standard deviation of the estimates
  over the truth: the CoV the method really has), ``rep CoV`` (the mean CoV it reported) and,
  for subset simulation, ``AB CoV`` (Au & Beck's usual uncorrelated-level CoV, not reported);
* ``cover`` -- how many of the R 95 % intervals held the truth, with the exact 95 % interval
  of that coverage, and ``cover AB`` for intervals on the uncorrelated CoV;
* ``evals`` -- mean evaluations of g, and ``MC evals`` -- what plain Monte Carlo needs for the
  same (empirical) CoV, ``(1 - P) / (P CoV^2)``, with the ratio;
* ``|u*|`` -- the mean norm of the closest failure sample, beside ``beta``;

and after the table, each row's median interval width (upper over lower end: what a reader's
interval spans) and, for the repeated rows, the coverage of a plain Student's ``t`` interval on
the K raw estimates (the alternative to Cox's, ``rcsim.analysis.engine.rare.repeats``).

With ``--repeats K`` (K >= 2), each ``subset`` row is followed by one of the repeated estimator
(``repeated_subset_simulation``: K independent subset simulations of N per level each,
combined; repetition ``r`` is seeded ``r``, its repeat 0 is the plain row's estimation) with
the same columns: ``rep CoV`` is then the CoV measured from the K estimates' spread, ``cover``
counts Cox's log-normal intervals, and ``AB CoV`` / ``cover AB`` do not apply.

With ``--oracle``, OpenTURNS' ``SubsetSampling`` (if importable; it is not an rcsim
dependency: ``docs/rare_events.md``) runs the same limit states with the same level size, as a
check of the estimates and the evaluation counts.  Its seed is global
(``ot.RandomGenerator.SetSeed``).

Usage: ``python benchmarks/rare_event.py [--repeat R] [--methods subset,ce] [--oracle]
[--n-per-level N] [--repeats K] [--json FILE]``; docs/rare_events.md records the printed table.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time

import numpy as np
from scipy import stats

from rcsim.analysis.engine.rare import (
    SubsetConfig,
    limit_states,
    repeated_subset_simulation,
    subset_simulation,
)
from rcsim.analysis.engine.rare.importance import cross_entropy_is
from rcsim.analysis.engine.rare.intervals import (
    clopper_pearson,
    lognormal_interval,
    plain_mc_runs,
)


def cases() -> list:
    out = [limit_states.linear(d, p) for d in (10, 86) for p in (1e-3, 1e-5, 1e-6)]
    out += [limit_states.series(d, 1e-5) for d in (10, 86)]
    out.append(limit_states.parabolic(10, 4.5, -0.05))
    return out


def run_method(method: str, limit, seed: int, n: int):
    if method == "subset":
        return subset_simulation(limit, limit.dim, SubsetConfig(n_per_level=n), seed=seed)
    if method.startswith("subset x"):  # "subset xK": K independent repeats, combined
        k = int(method.removeprefix("subset x"))
        return repeated_subset_simulation(
            limit, limit.dim, SubsetConfig(n_per_level=n), k, seed=seed
        )
    return cross_entropy_is(limit, limit.dim, seed=seed, n_per_step=n, n_final=2 * n)


def measure(method: str, limit, repeat: int, n: int) -> dict:
    start = time.perf_counter()
    est, rep_cov, ab_cov, evals, norms, widths = [], [], [], [], [], []
    covered = covered_ab = covered_t = unresolved = 0
    for seed in range(repeat):
        res = run_method(method, limit, seed, n)
        evals.append(res.n_evaluations)
        if res.probability is None:
            unresolved += 1
            continue
        est.append(res.probability)
        rep_cov.append(res.cov)
        lo, hi = res.interval
        covered += lo <= limit.probability <= hi
        widths.append(hi / lo if lo > 0 else math.inf)
        if res.repeats:  # the plain Student's t interval on the K raw estimates, for reference
            parts = np.array([p.probability or 0.0 for p in res.repeats])
            k = parts.size
            half = float(stats.t.ppf(0.975, k - 1)) * parts.std(ddof=1) / math.sqrt(k)
            covered_t += abs(parts.mean() - limit.probability) <= half
        if res.cov_uncorrelated is not None:
            ab_cov.append(res.cov_uncorrelated)
            lo, hi = lognormal_interval(res.probability, res.cov_uncorrelated)
            covered_ab += lo <= limit.probability <= hi
        if res.closest_failure is not None:
            norms.append(res.closest_failure.norm)
    e = np.asarray(est)
    emp = float(e.std(ddof=1) / limit.probability) if e.size > 1 else math.nan
    mc = plain_mc_runs(limit.probability, emp) if emp > 0 else math.nan
    return {
        "method": method,
        "limit_state": limit.name,
        "dim": limit.dim,
        "truth": limit.probability,
        "beta": limit.beta,
        "repeat": repeat,
        "unresolved": unresolved,
        "mean_ratio": float(e.mean() / limit.probability) if e.size else math.nan,
        "emp_cov": emp,
        "reported_cov": float(np.mean(rep_cov)) if rep_cov else math.nan,
        "ab_cov": float(np.mean(ab_cov)) if ab_cov else math.nan,
        "covered": covered,
        "covered_ab": covered_ab if ab_cov else None,
        "coverage_interval": clopper_pearson(covered, repeat),
        "evals": float(np.mean(evals)),
        "mc_evals": mc,
        "closest_norm": float(np.mean(norms)) if norms else math.nan,
        "interval_ratio": float(np.median(widths)) if widths else math.nan,
        "covered_raw_t": covered_t if method.startswith("subset x") else None,
        "seconds": time.perf_counter() - start,
    }


def oracle(limit, repeat: int, n: int) -> dict | None:
    """OpenTURNS' SubsetSampling on the same limit state (level size ``n``, p0 = 0.1)."""
    try:
        import openturns as ot  # not an rcsim dependency: docs/rare_events.md
    except ImportError:
        return None
    est, evals, covs = [], [], []
    sizes: list[int] = []
    errors = 0
    for seed in range(repeat):
        ot.RandomGenerator.SetSeed(seed)

        def margins(x):
            x = np.asarray(x)
            sizes.append(len(x))
            return limit(x)[:, None]

        f = ot.PythonFunction(limit.dim, 1, func_sample=margins)
        event = ot.ThresholdEvent(
            ot.CompositeRandomVector(f, ot.RandomVector(ot.Normal(limit.dim))), ot.Less(), 0.0
        )
        algo = ot.SubsetSampling(event)
        algo.setBlockSize(n // 10)
        algo.setMaximumOuterSampling(10)
        try:
            algo.run()
        except Exception:  # noqa: BLE001 - counted: the oracle's own failures are a finding
            errors += 1
            continue
        result = algo.getResult()
        est.append(result.getProbabilityEstimate())
        covs.append(result.getCoefficientOfVariation())
        evals.append(f.getEvaluationCallsNumber())
    e = np.asarray(est)
    return {
        "method": f"OpenTURNS {ot.__version__} SubsetSampling",
        "limit_state": limit.name,
        "mean_ratio": float(e.mean() / limit.probability),
        "emp_cov": float(e.std(ddof=1) / limit.probability),
        "reported_cov": float(np.mean(covs)),
        "evals": float(np.mean(evals)),
        "batch_sizes": sorted(set(sizes)),
        "errors": errors,
    }


def _fmt(row: dict) -> str:
    lo, hi = row["coverage_interval"]
    ab = "" if row["covered_ab"] is None else f"{row['covered_ab']}"
    ab_cov = "" if math.isnan(row["ab_cov"]) else f"{row['ab_cov']:.3f}"
    unresolved = f" ({row['unresolved']} unresolved)" if row["unresolved"] else ""
    ratio = row["mc_evals"] / row["evals"] if row["evals"] else math.nan
    return (
        f"| {row['method']} | {row['limit_state']} | {row['truth']:.3g} | "
        f"{row['mean_ratio']:.3f}{unresolved} | {row['emp_cov']:.3f} | {row['reported_cov']:.3f} | "
        f"{ab_cov} | {row['covered']}/{row['repeat']} ({lo:.2f}-{hi:.2f}) | {ab} | "
        f"{row['evals']:,.0f} | {row['mc_evals']:,.3g} ({ratio:,.0f}x) | "
        f"{row['closest_norm']:.2f} / {row['beta']:.2f} |"
    )


HEADER = (
    "| method | limit state | truth | mean est / truth | emp CoV | rep CoV | AB CoV | "
    "cover (95 % CI) | cover AB | evals | plain MC at emp CoV | closest |u*| / beta |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|"
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=100)
    parser.add_argument("--n-per-level", type=int, default=1000)
    parser.add_argument("--methods", default="subset,ce")
    parser.add_argument(
        "--repeats",
        type=int,
        default=1,
        help="K >= 2: add rows of K independent subset simulations combined (N per level each)",
    )
    parser.add_argument("--oracle", action="store_true")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    print(
        f"Python {platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} CPUs; "
        f"{args.repeat} repetitions, N = {args.n_per_level} per level (subset simulation, "
        f"p0 = 0.1) / per step (cross-entropy, final batch 2N)",
        flush=True,
    )
    print(HEADER, flush=True)
    rows, oracles = [], []
    for method in filter(None, args.methods.split(",")):
        for limit in cases():
            row = measure(method, limit, args.repeat, args.n_per_level)
            rows.append(row)
            print(_fmt(row), flush=True)
            if method == "subset" and args.repeats > 1:
                row = measure(f"subset x{args.repeats}", limit, args.repeat, args.n_per_level)
                rows.append(row)
                print(_fmt(row), flush=True)
    if args.oracle:
        for limit in cases():
            found = oracle(limit, args.repeat, args.n_per_level)
            if found is None:
                print("openturns is not importable: no oracle rows", file=sys.stderr)
                break
            oracles.append(found)
            print(
                f"oracle | {found['limit_state']} | mean est / truth {found['mean_ratio']:.3f} | "
                f"emp CoV {found['emp_cov']:.3f} | rep CoV {found['reported_cov']:.3f} | "
                f"evals {found['evals']:,.0f} | batches of {found['batch_sizes']} | "
                f"{found['errors']} of {args.repeat} runs raised",
                flush=True,
            )
    print(
        "median width of the 95 % interval a reader is shown (upper / lower end); for repeats, "
        "how many plain t intervals on the K raw estimates held the truth:",
        flush=True,
    )
    for r in rows:
        raw = "" if r["covered_raw_t"] is None else f" | raw t {r['covered_raw_t']}/{r['repeat']}"
        print(
            f"  {r['method']} | {r['limit_state']} | {r['truth']:.3g} | "
            f"{r['interval_ratio']:.2f}{raw}"
        )
    total = sum(r["seconds"] for r in rows)
    print(f"estimations: {total:.1f} s in all", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows, "oracle": oracles}, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
