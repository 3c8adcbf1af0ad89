"""Cost of the closed loop on campaign-like work: exact-in-time pieces, sensors and delays.

Flies a campaign-like chunk without the campaign machinery: the 26 rate cases of Table 3 x
``--runs-per-case`` runs, each with its own Table 5 dispersed vehicle (seed 1), the lookup
controller with the packaged table, ``--duration-s`` of flight, one MuJoCo thread, and reports
simulated seconds per CPU second of the process (best of ``--repeats``; CPU time, not wall time,
because with one thread it is the work done, much less disturbed by other load on a shared
machine) for

* ``nominal``: perfect sensors, no delays (the campaign of today);
* ``noisy``: the sensor noise and delays of ``docs/faults.md``'s campaigns (attitude 0.003 deg,
  rate 0.001 deg/s white, gyro random walk, 5 ms sensor-to-actuator delay, 8/5 ms valve
  open/close latency), when this version of ``spacecraft`` has them;

plus the mean number of physics pieces per run per cycle (1 = one fixed step).  Run it with
another ``spacecraft`` package on the path to compare versions.

Usage: ``python benchmarks/exact_time_cost.py [--runs-per-case 10] [--duration-s 20]``.
"""

from __future__ import annotations

import argparse
import inspect
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.lookup.registry import make_controller  # noqa: E402
from rcsim.models.tables import load_dispersions, load_rate_cases  # noqa: E402
from rcsim.spacecraft import simulation  # noqa: E402
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs, run_streams  # noqa: E402
from rcsim.spacecraft.navigation import Guidance  # noqa: E402
from rcsim.spacecraft.vehicle import Vehicle  # noqa: E402


def noisy_options(n: int, seed: int, run_ids) -> dict:
    from rcsim.spacecraft.sensors import SensorParams
    from rcsim.spacecraft.valves import ValveTiming

    sensors = SensorParams.of(
        n,
        att_noise_rad=np.radians(0.003),
        rate_noise_rad_s=np.radians(0.001),
        rate_walk_rad_s_per_sqrt_s=np.radians(0.0005),
    )
    streams = [run_streams(seed, i)[1].spawn(1)[0] for i in run_ids]
    timing = ValveTiming.of(n, command_delay_s=0.005, open_delay_s=0.008, close_delay_s=0.005)
    return {"sensors": sensors, "sensor_streams": streams, "timing": timing}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=10)
    ap.add_argument("--duration-s", type=float, default=20.0)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)

    vehicle = Vehicle.load()
    cases = load_rate_cases()
    rate = np.repeat(np.asarray(cases.rate_cmd, float), args.runs_per_case, axis=0)
    n = rate.shape[0]
    run_ids = np.arange(n)
    sigmas = DispersionSigmas.from_table(load_dispersions())
    params = draw_runs(vehicle.nominal(1), sigmas, 1, run_ids).params
    ctl = make_controller("lookup", vehicle)
    has_effects = "sensors" in inspect.signature(simulation.BatchSimulation).parameters
    variants = {"nominal": {}}
    if has_effects:
        variants["noisy"] = noisy_options(n, 1, run_ids)
    print(
        f"{n} runs x {args.duration_s:g} s, lookup controller, one thread; spacecraft from "
        f"{Path(simulation.__file__).parent}"
    )
    for name, opts in variants.items():
        best = np.inf
        for _ in range(args.repeats):
            sim = simulation.BatchSimulation(params, vehicle, nthread=1, **opts)
            rollouts = []
            real = sim.physics.batch.rollout

            def counting(nstep, *a, rollouts=rollouts, real=real, **kw):
                ids = kw.get("ids")
                if len(rollouts) < 10**7:
                    rollouts.append(nstep * (n if ids is None else len(ids)))
                return real(nstep, *a, **kw)

            sim.physics.batch.rollout = counting
            t0 = time.process_time()
            sim.run(ctl, Guidance.rate(np.zeros((n, 3))), args.duration_s, omega0_B=rate)
            best = min(best, time.process_time() - t0)
        cycles = int(np.ceil(args.duration_s / 0.04 - 1e-9))
        print(
            f"{name:8s}: {n * args.duration_s / best:8.0f} sim-s per CPU-s  "
            f"({best:.2f} s)  physics pieces per run-cycle {sum(rollouts) / (n * cycles):.4f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
