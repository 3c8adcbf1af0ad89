"""Benchmark: subset simulation on the real simulator, against plain Monte Carlo.

A prototype of the campaign adapter (docs/rare_events.md, "Plan"), for measurement only: one
rate case of a campaign spec (Table 5 dispersions, no sensor noise or delays, so the margin is
a deterministic function of the run's standard-normal vector ``u``), flown in batches through
:func:`rcsim.analysis.engine.flight.fly_batch` with the vehicles of
:func:`rcsim.spacecraft.standard_space.vehicles_from_standard`.  The margin is the failure
criterion's, scaled: ``(thr - max_axis |final rate error|) / thr``, below 0 exactly when the
campaign calls the run failed on its rate (0 itself moved just below 0); NaN where the
simulation failed (the estimator counts it failed).

It prints plain Monte Carlo's estimate of the case (``--mc-runs`` independent runs, exact
95 % interval) and ``--repeat`` subset-simulation estimates (level size ``--n-per-level``):
each one's estimate, interval and runs; then their mean, empirical CoV, how many intervals
hold the plain Monte Carlo estimate, and the runs plain Monte Carlo needs for the same CoV.

Usage: ``python benchmarks/rare_event_flight.py [--case 2] [--table table6] [--scale 1]
[--mc-runs 20000] [--repeat 20] [--n-per-level 500]``
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from rcsim.analysis.engine.campaign.spec import parse_dict
from rcsim.analysis.engine.flight import fly_batch
from rcsim.analysis.engine.rare import SubsetConfig, subset_simulation
from rcsim.analysis.engine.rare.intervals import clopper_pearson, plain_mc_runs
from rcsim.lookup.registry import make_controller
from rcsim.spacecraft import standard_space

#: Runs flown per fly_batch call (level 0 and plain Monte Carlo are split into these).
BATCH = 500


class CaseMargin:
    """``g(u, ids)`` of one rate case: fly the runs of ``u``, return their margins."""

    def __init__(self, spec):
        self.spec = spec
        self.vehicle = spec.vehicle
        self.nominal = self.vehicle.nominal(1)
        self.controller = make_controller(spec.controller, self.vehicle, table=spec.table)
        self.case = spec.cases[0]
        self.runs = 0

    @property
    def dim(self) -> int:
        return standard_space.n_standard(self.nominal.n_jets, self.spec.sigmas.has_mass_extras)

    def __call__(self, u: np.ndarray, ids: np.ndarray) -> np.ndarray:
        out = np.empty(u.shape[0])
        for lo in range(0, u.shape[0], BATCH):
            part = u[lo : lo + BATCH]
            runs = standard_space.vehicles_from_standard(self.nominal, self.spec.sigmas, part)
            history = fly_batch(
                [self.case] * part.shape[0], runs.params, self.controller, vehicle=self.vehicle
            )
            worst = np.max(np.abs(history.final.rate_err_B), axis=1)
            thr = self.spec.rate_threshold_rad_s
            margin = (thr - worst) / thr
            margin = np.where(margin == 0.0, -np.finfo(float).tiny, margin)
            out[lo : lo + BATCH] = np.where(np.asarray(history.failed, bool), np.nan, margin)
        self.runs += u.shape[0]
        return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", type=int, default=2)
    parser.add_argument("--table", default="table6")
    parser.add_argument("--scale", type=float, default=1.0)
    parser.add_argument("--mc-runs", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--n-per-level", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--mc-first", type=int, default=0, help="first run id of the plain Monte Carlo runs"
    )
    args = parser.parse_args(argv)
    spec = parse_dict(
        {
            "seed": args.seed,
            "scenario": {"kind": "rate-cases", "cases": [args.case]},
            "controller": {"name": "lookup", "table": args.table},
            "dispersions": {"scale": args.scale},
        }
    )
    g = CaseMargin(spec)
    print(
        f"case {g.case.name}, {args.table}, Table 5 x {args.scale:g}, d = {g.dim}; threshold "
        f"{math.degrees(spec.rate_threshold_rad_s):g} deg/s",
        flush=True,
    )
    start = time.perf_counter()
    mc_ids = np.arange(args.mc_first, args.mc_first + args.mc_runs)
    u = standard_space.run_standard_normals(args.seed, mc_ids, 16, False)
    margins = g(u, mc_ids)
    k = int(np.sum(~(margins >= 0)))
    p_mc = k / args.mc_runs
    lo, hi = clopper_pearson(k, args.mc_runs)
    mc_cov = math.sqrt((1 - p_mc) / (p_mc * args.mc_runs)) if k else math.inf
    print(
        f"plain Monte Carlo (runs {args.mc_first}-{args.mc_first + args.mc_runs - 1}): "
        f"{k} of {args.mc_runs} failed, P = {p_mc:.4g} "
        f"(95 % {lo:.3g} - {hi:.3g}, CoV {mc_cov:.3f}), {time.perf_counter() - start:.0f} s",
        flush=True,
    )
    if args.repeat == 0:
        return 0
    estimates, covers, runs = [], 0, []
    config = SubsetConfig(n_per_level=args.n_per_level)
    for rep in range(args.repeat):
        start = time.perf_counter()
        res = subset_simulation(g, g.dim, config, seed=np.random.SeedSequence([args.seed, rep]))
        runs.append(res.n_evaluations)
        if res.probability is None:
            print(f"  {rep}: {res.summary()}", flush=True)
            continue
        estimates.append(res.probability)
        covers += res.interval[0] <= p_mc <= res.interval[1]
        top = ", ".join(
            f"{n} {v:+.1f}"
            for n, v in res.closest_failure.largest(
                standard_space.standard_names(16, False), count=3
            )
        )
        print(
            f"  {rep}: {res.status} P = {res.probability:.4g} "
            f"({res.interval[0]:.3g} - {res.interval[1]:.3g}, CoV {res.cov:.2f}) in "
            f"{res.n_evaluations} runs, {time.perf_counter() - start:.0f} s; closest failure "
            f"{res.closest_failure.norm:.2f} sigma ({top})",
            flush=True,
        )
    e = np.asarray(estimates)
    emp = float(e.std(ddof=1) / e.mean())
    print(
        f"subset simulation: mean P = {e.mean():.4g} over {e.size}, empirical CoV {emp:.3f}, "
        f"{covers} of {e.size} intervals hold the plain MC estimate; mean runs "
        f"{np.mean(runs):,.0f}; plain MC at that CoV: {plain_mc_runs(e.mean(), emp):,.0f} runs",
        flush=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
