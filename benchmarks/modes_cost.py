"""Cost of flying slosh and appendage modes, and the rigid vehicle's speed against a baseline.

Flies a campaign-like batch without the campaign machinery: the 26 rate cases of Table 3 x
``--runs-per-case`` runs, each its own dispersed vehicle (the vehicle file's ``[dispersions]``,
seed 1), the allocator, the vehicle's propellant tracked, ``--duration-s`` of flight, one
MuJoCo thread, and reports the CPU seconds of the flight per run (median of ``--repeats``; CPU
time of the worker process, not wall time: with one thread it is the work done, much less
disturbed by other load on a shared machine), the part of it inside MuJoCo's rollouts (the
physics), the physics steps and the firings per run, for

* ``rigid``: canted16;
* ``modes``: ``docs/examples/canted16_modes.toml``, canted16 with two lateral slosh modes (one
  tank, one ``[[slosh]]`` block) and two hinged solar wings, at canted16's 40 ms step;
* ``modes-20ms``: the same at a 20 ms step (what the 1e-9 angular-momentum claim needs,
  ``docs/vehicles.md``, "Slosh and appendages");
* ``rigid-baseline``: canted16 flown by another checkout's code (``--baseline DIR``, e.g. the
  main branch's), to show the rigid vehicle's speed is unchanged.

Each measurement is a fresh worker process (``--worker``), the variants interleaved repeat by
repeat so that a change of the machine's load falls on all of them; the load average is printed
before and after.

Usage: ``python benchmarks/modes_cost.py [--runs-per-case 4] [--duration-s 20] [--repeats 5]
[--baseline DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "canted16_modes.toml"


def worker(vehicle_ref: str, timestep_s: float, runs_per_case: int, duration_s: float) -> dict:
    """One flight; the CPU seconds of ``BatchSimulation.run`` and what the code was."""
    import numpy as np

    import rcsim
    from rcsim.lookup.registry import make_controller
    from rcsim.models.tables import load_rate_cases
    from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
    from rcsim.spacecraft.navigation import Guidance
    from rcsim.spacecraft.simulation import BatchSimulation

    vehicle = rcsim.Vehicle.load(vehicle_ref)
    if timestep_s > 0:
        vehicle = vehicle.with_physics(timestep_s=timestep_s)
    rate = np.repeat(np.asarray(load_rate_cases().rate_cmd, float), runs_per_case, axis=0)
    n = rate.shape[0]
    sigmas = DispersionSigmas.from_table(vehicle.definition.dispersion_table())
    params = draw_runs(vehicle.nominal(1), sigmas, 1, np.arange(n)).params
    ctl = make_controller("allocator", vehicle)
    sim = BatchSimulation(params, vehicle, nthread=1, tank=vehicle.tank(n))
    physics = [0.0, 0]  # CPU seconds inside MuJoCo's rollouts, run-steps integrated
    real = sim.physics.batch.rollout

    def timed(nstep, *a, **kw):
        ids = kw.get("ids")
        t = time.process_time()
        try:
            return real(nstep, *a, **kw)
        finally:
            physics[0] += time.process_time() - t
            physics[1] += nstep * (n if ids is None else len(ids))

    sim.physics.batch.rollout = timed
    t0 = time.process_time()
    history = sim.run(ctl, Guidance.rate(np.zeros((n, 3))), duration_s, omega0_B=rate)
    cpu = time.process_time() - t0
    return {
        "cpu_s": cpu,
        "physics_s": physics[0],
        "run_steps": physics[1],
        "firings": float(history.propulsion.firings.sum(axis=1).mean()),
        "runs": n,
        "failed": int(history.failed.sum()),
        "nq": int(vehicle.model.nq),
        "code": str(Path(rcsim.__file__).parent),
    }


def _run_worker(code_root: Path, vehicle: str, timestep_s: float, args) -> dict:
    env = {**os.environ, "PYTHONPATH": str(code_root)}
    cmd = [
        sys.executable,
        str(Path(__file__).resolve()),
        "--worker",
        vehicle,
        "--timestep-s",
        str(timestep_s),
        "--runs-per-case",
        str(args.runs_per_case),
        "--duration-s",
        str(args.duration_s),
    ]
    out = subprocess.run(cmd, env=env, cwd=code_root, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=4)
    ap.add_argument("--duration-s", type=float, default=20.0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--baseline", type=Path, help="another checkout whose rigid flight to time")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--timestep-s", type=float, default=0.0, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.worker, args.timestep_s, args.runs_per_case, args.duration_s)))
        return 0

    variants = {
        "rigid": (ROOT, "canted16", 0.0),
        "modes": (ROOT, str(EXAMPLE), 0.0),
        "modes-20ms": (ROOT, str(EXAMPLE), 0.02),
    }
    if args.baseline is not None:
        variants["rigid-baseline"] = (args.baseline.resolve(), "canted16", 0.0)
    load0 = os.getloadavg()
    cpu: dict[str, list[float]] = {name: [] for name in variants}
    phys: dict[str, list[float]] = {name: [] for name in variants}
    info: dict[str, dict] = {}
    for _ in range(args.repeats):
        for name, (code, vehicle, dt) in variants.items():
            result = _run_worker(code, vehicle, dt, args)
            cpu[name].append(result["cpu_s"] / result["runs"])
            phys[name].append(result["physics_s"] / result["runs"])
            info[name] = result
    load1 = os.getloadavg()
    n = info["rigid"]["runs"]
    print(
        f"{n} runs x {args.duration_s:g} s (26 rate cases x {args.runs_per_case}), allocator, "
        f"dispersed, propellant tracked, one thread; {args.repeats} interleaved repeats; load "
        f"average {load0[0]:.2f} before, {load1[0]:.2f} after"
    )

    def median(xs: list[float]) -> float:
        s = sorted(xs)
        return 0.5 * (s[(len(s) - 1) // 2] + s[len(s) // 2])

    base, base_phys = median(cpu["rigid"]), median(phys["rigid"])
    for name, values in cpu.items():
        r = info[name]
        p = median(phys[name])
        print(
            f"{name:15s}: {median(values) * 1e3:8.3f} ms CPU per run (median; "
            f"{min(values) * 1e3:.3f}-{max(values) * 1e3:.3f})  x {median(values) / base:.3f} "
            f"of rigid; physics {p * 1e3:.3f} ms x {p / base_phys:.3f}, "
            f"{r['run_steps'] / r['runs']:.0f} steps/run; firings/run {r['firings']:.1f}; "
            f"qpos {r['nq']}, failed {r['failed']}, code {r['code']}"
        )
    if "rigid-baseline" in cpu:
        ratios = [a / b for a, b in zip(cpu["rigid"], cpu["rigid-baseline"])]
        print(
            f"rigid / rigid-baseline per repeat: {', '.join(f'{x:.3f}' for x in ratios)} "
            f"(median {median(ratios):.3f})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
