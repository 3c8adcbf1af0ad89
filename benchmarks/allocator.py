"""The allocator controller against the lookup table and the phase plane (issue 18).

Measures, in one process run:

1. ``speed``: a summary-only campaign of the 26 rate cases x N runs (Table 5 dispersions,
   paper vehicle, local mode) with the lookup controller and with the allocator, interleaved
   and repeated; runs per second of flying (``report.fly_s``) and the allocator's ratio to the
   lookup controller (target: >= 0.7);
2. ``compare``: on the paper's vehicle, the three controllers on the 26 rate cases (from rest
   to the case rate, 20 s), the 5 deg three-axis maneuver and the disturbed attitude hold
   (2 N m yaw): firings, propellant and final errors side by side;
3. ``canted``: the 26 rate cases x N runs on the canted-quad (16 jets) and canted-triad (12
   jets) vehicles with the allocator under Table 5-style dispersions (the vehicle file's
   table): failures and propellant per case, and the wall time.

4. ``milp`` (issue 28): the allocator in each allocation mode on canted12, canted16,
   service16 and smallsat8 (26 rate cases + 3 maneuver starts), its propellant against an
   independent mixed-integer optimum (scipy ``milp`` on ``min mdot . t, D t = b, t = 0 or
   >= t_min``, written here), and the time per command and the MILP count;
5. ``cost`` (issue 28): a campaign of the 26 rate cases x N runs on a vehicle with a minimum
   on-time (default service16) with the allocator: wall time, cycles flown, the allocator's
   time per cycle per run and its MILP solves (distinct commands whose minimum binds).  The
   same spec flown by an older rcsim gives "today's" figure to compare (docs/allocator.md).

Usage::

    python benchmarks/allocator.py [--runs-per-case 40] [--repeats 3] [--canted-runs 1000]
        [--canted-vehicles canted16,canted12] [--only speed|compare|canted|milp|cost]
        [--cost-vehicle docs/examples/service16.toml] [--cost-runs 20]

Timings are wall-clock on a shared machine: the script prints the load average before and
after; quote the ratio of interleaved repeats, not an absolute figure.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.analysis.engine.campaign.runner import run_campaign  # noqa: E402
from rcsim.analysis.engine.campaign.spec import parse_dict  # noqa: E402


def _spec(controller: str, runs: int, seed: int, vehicle: str | None = None):
    data = {
        "seed": seed,
        "runs_per_case": runs,
        "scenario": {"kind": "rate-cases", "cases": "all", "duration_s": 20.0},
        "controller": {"name": controller},
        "output": {"histories": "none", "plots": False},
    }
    if vehicle:
        data["vehicle"] = vehicle
    return parse_dict(data, source=f"benchmark {controller}")


def speed(runs: int, repeats: int) -> None:
    print(f"load average before: {os.getloadavg()}")
    rates: dict[str, list[float]] = {"lookup": [], "allocator": []}
    for r in range(repeats):
        for name in ("lookup", "allocator") if r % 2 == 0 else ("allocator", "lookup"):
            with tempfile.TemporaryDirectory() as tmp:
                report = run_campaign(_spec(name, runs, 7), Path(tmp) / "c", progress=False)
            rates[name].append(26 * runs / report.fly_s)
            print(f"  repeat {r + 1} {name:9s} {rates[name][-1]:7.1f} runs/s")
    ratio = [a / b for a, b in zip(rates["allocator"], rates["lookup"])]
    print(
        f"speed: lookup {np.median(rates['lookup']):.1f} runs/s, allocator "
        f"{np.median(rates['allocator']):.1f} runs/s; allocator / lookup per repeat "
        f"{[round(x, 3) for x in ratio]}, median {np.median(ratio):.3f} (target >= 0.7)"
    )
    print(f"load average after: {os.getloadavg()}")


def compare() -> None:
    from rcsim.analysis.engine.flight import Scenario, fly_batch
    from rcsim.analysis.engine.scenarios.catalog import get_scenario
    from rcsim.analysis.engine.scenarios.flying import build_controller
    from rcsim.lookup.registry import make_controller
    from rcsim.models.tables import load_rate_cases
    from rcsim.spacecraft.vehicle import Vehicle

    vehicle = Vehicle.load()
    rates = np.asarray(load_rate_cases().rate_cmd, float)
    sets = {
        "26 rate cases": (
            [Scenario(f"rate-{k + 1:02d}", 20.0, rate_cmd_rad_s=r) for k, r in enumerate(rates)],
            None,
        ),
        "5 deg three-axis": (list(get_scenario("three-axis-5deg").runs), "three-axis-5deg"),
        "disturbed hold": (
            list(get_scenario("attitude-hold-disturbed").runs),
            "attitude-hold-disturbed",
        ),
    }
    print(
        "| scenario | controller | firings | propellant [g] | max final att. err [deg] | "
        "max final rate err [deg/s] |\n|---|---|---|---|---|---|"
    )
    for label, (runs, named) in sets.items():
        for ctl_name in ("phase-plane", "lookup", "allocator"):
            if named is not None and ctl_name != "allocator":
                ctl = build_controller(get_scenario(named), ctl_name, vehicle)
            else:
                ctl = make_controller(ctl_name, vehicle)
            h = fly_batch(runs, vehicle.nominal(len(runs)), ctl, vehicle=vehicle)
            att = np.degrees(np.linalg.norm(h.final.att_err_B, axis=1)).max()
            rate = np.degrees(np.abs(h.final.rate_err_B)).max()
            print(
                f"| {label} | {ctl_name} | {int(h.propulsion.firings.sum())} | "
                f"{h.propulsion.propellant_kg(vehicle.isp_s).sum() * 1e3:.1f} | {att:.3f} | "
                f"{rate:.4f} |"
            )


def canted(runs: int, vehicle: str) -> None:
    import pandas as pd

    print(f"load average before: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run_campaign(_spec("allocator", runs, 18, vehicle), Path(tmp) / "c", progress=False)
        wall = time.perf_counter() - t0
        frame = pd.read_parquet(Path(tmp) / "c" / "runs.parquet")
    per_case = frame.groupby("case").agg(
        failed=("failed", "sum"),
        propellant_mean_g=("propellant_kg", lambda p: 1e3 * p.mean()),
        propellant_max_g=("propellant_kg", lambda p: 1e3 * p.max()),
    )
    jets = len(frame.filter(regex=r"^jet_\d+_on_time_s$").columns)
    print(
        f"{vehicle} ({jets} jets), allocator, 26 x {runs} runs, the file's dispersions: "
        f"{wall:.0f} s wall; load average after: {os.getloadavg()}"
    )
    print(per_case.to_string())
    print(f"total failed {int(frame['failed'].sum())} of {len(frame)}")


def milp_check() -> None:
    import itertools

    from scipy.optimize import Bounds, LinearConstraint, milp

    from rcsim.lookup.allocator_controller import allocator_controller, jet_model
    from rcsim.spacecraft.control_profile import ALLOCATION_MODES
    from rcsim.spacecraft.vehicle import Vehicle

    def optimum(D, mdot, t_min, b):
        n = D.shape[1]
        link = np.zeros((2 * n, 2 * n))
        link[:n, :n], link[:n, n:] = np.eye(n), -10.0 * np.eye(n)
        link[n:, :n], link[n:, n:] = np.eye(n), -np.diag(t_min)
        res = milp(
            np.r_[mdot / mdot.max(), np.zeros(n)],
            constraints=[
                LinearConstraint(np.hstack([D, np.zeros((3, n))]), b, b),
                LinearConstraint(
                    link,
                    np.r_[np.full(n, -np.inf), np.zeros(n)],
                    np.r_[np.zeros(n), np.full(n, np.inf)],
                ),
            ],
            integrality=np.r_[np.zeros(n), np.ones(n)],
            bounds=Bounds(0, np.r_[np.full(n, np.inf), np.ones(n)]),
            options={"mip_rel_gap": 1e-9},
        )
        return float(res.fun) * mdot.max()

    print("| vehicle | mode | worst / MILP optimum | mean / optimum | ms per command | MILPs |")
    print("|---|---|---|---|---|---|")
    for name in ("canted12", "canted16", "docs/examples/service16.toml",
                 "docs/examples/smallsat8.toml"):  # fmt: skip
        vehicle = Vehicle.load(ROOT / name if name.endswith(".toml") else name)
        control = vehicle.control
        signs = np.array([s for s in itertools.product((-1, 0, 1), repeat=3) if any(s)], float)
        b = np.vstack([
            signs / np.linalg.norm(signs, axis=1, keepdims=True) * control.rate_case_rad_s,
            np.eye(3) * control.maneuver_rate_rad_s,
        ])  # fmt: skip
        D, _, mdot, _ = jet_model(vehicle.model, vehicle.isp_s)
        for mode in ALLOCATION_MODES:
            alloc = allocator_controller(vehicle, allocation=mode).allocator
            best = np.array([optimum(D, mdot, alloc.t_min, row) for row in b])
            t0 = time.perf_counter()
            t, _ = alloc.allocate(b)
            ms = (time.perf_counter() - t0) / len(b) * 1e3
            ratio = (t @ mdot) / best
            print(
                f"| {Path(name).stem} | {mode} | {ratio.max():.5f} | {ratio.mean():.5f} | "
                f"{ms:.1f} | {alloc.n_milp} |"
            )


def cost(vehicle: str, runs: int) -> None:
    from rcsim.lookup.registry import make_controller
    from rcsim.models.tables import load_rate_cases
    from rcsim.spacecraft.navigation import Guidance
    from rcsim.spacecraft.simulation import simulate_batch
    from rcsim.spacecraft.vehicle import Vehicle

    path = str(ROOT / vehicle) if vehicle.endswith(".toml") else vehicle
    print(f"load average before: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        report = run_campaign(_spec("allocator", runs, 28, path), Path(tmp) / "c", progress=False)
        wall = time.perf_counter() - t0
    print(
        f"{vehicle}: campaign 26 x {runs} runs, 20 s each: {wall:.1f} s wall (flying "
        f"{report.fly_s:.1f} s)"
    )
    # The controller's own cost, in this process: the nominal 26 rate cases x runs, one batch.
    flown = Vehicle.load(path)
    rates = np.tile(np.asarray(load_rate_cases().rate_cmd, float), (runs, 1))
    controller = make_controller("allocator", flown)
    step = controller.step
    spent = {"s": 0.0, "cycles": 0}

    def timed(nav, state):
        t0 = time.perf_counter()
        out = step(nav, state)
        spent["s"] += time.perf_counter() - t0
        spent["cycles"] += 1
        return out

    controller.step = timed  # type: ignore[method-assign]
    t0 = time.perf_counter()
    simulate_batch(flown.nominal(len(rates)), controller, Guidance.rate(rates), 20.0, vehicle=flown)
    total = time.perf_counter() - t0
    alloc = controller.allocator
    per = spent["s"] / (spent["cycles"] * len(rates)) * 1e6
    print(
        f"nominal 26 x {runs} rate cases in one batch: {total:.1f} s, of which the controller "
        f"{spent['s']:.1f} s over {spent['cycles']} cycles = {per:.1f} us per cycle per run; "
        f"solver counts {alloc.counts()} (exact = HiGHS MILP solves); "
        f"load average after: {os.getloadavg()}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs-per-case", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--canted-runs", type=int, default=1000)
    parser.add_argument("--canted-vehicles", default="canted16,canted12")
    parser.add_argument("--only", choices=("speed", "compare", "canted", "milp", "cost"))
    parser.add_argument("--cost-vehicle", default="docs/examples/service16.toml")
    parser.add_argument("--cost-runs", type=int, default=20)
    args = parser.parse_args()
    if args.only in (None, "speed"):
        speed(args.runs_per_case, args.repeats)
    if args.only in (None, "compare"):
        compare()
    if args.only in (None, "canted"):
        for vehicle in args.canted_vehicles.split(","):
            canted(args.canted_runs, vehicle)
    if args.only in (None, "milp"):
        milp_check()
    if args.only in (None, "cost"):
        cost(args.cost_vehicle, args.cost_runs)


if __name__ == "__main__":
    main()
