"""Cost of real pulses and blowdown: a batched flight with shaped pulses against square ones.

Flies the 26 rate cases of Table 3 x ``--runs-per-case`` runs of the paper's vehicle with 40 kg
of propellant tracked, each run its own Table 5 dispersed vehicle (seed 1), the lookup
controller with the packaged table, ``--duration-s`` of flight, one MuJoCo thread, and reports
simulated seconds per CPU second of the process (best of ``--repeats``, the variants
interleaved repeat by repeat so that a change of load hits them alike) for

* ``square``: square pulses, constant thrust (the vehicle as rcsim flew it before pulses);
* ``shaped``: first-order rise 8 ms and tail-off 12 ms, a pulse-mode Isp table, and a
  blowdown tank (22 bar on 20 L of gas) -- the file's ``[pulse]`` and ``[propellant.blowdown]``;

their ratio, and the physics pieces per run per cycle.  With ``--baseline-root DIR`` (a checkout
of another rcsim version, its extension built) it also times the *rigid* square-pulse vehicle
(the packaged paper vehicle, no propellant tracked: what campaigns fly) under both versions,
each in its own process, interleaved ``--repeats`` times: this version's cost against the
other's (the 5 % rule of real pulses: a vehicle without them must fly as fast as before).

Usage: ``python benchmarks/pulse_cost.py [--runs-per-case 4] [--duration-s 10]
[--baseline-root DIR]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(os.environ.get("PULSE_COST_ROOT", Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(ROOT))

from rcsim.lookup.registry import make_controller  # noqa: E402
from rcsim.models.tables import load_dispersions, load_rate_cases  # noqa: E402
from rcsim.spacecraft import simulation  # noqa: E402
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs  # noqa: E402
from rcsim.spacecraft.navigation import Guidance  # noqa: E402

try:  # the vehicle package; a --baseline-root from before it kept Vehicle in vehicle_file
    from rcsim.spacecraft.vehicle import Vehicle
except ImportError:  # pragma: no cover - an older rcsim as the baseline
    from rcsim.spacecraft.vehicle_file import Vehicle  # type: ignore[no-redef]

SHAPED = """
[pulse]
model = "exponential"
rise_s = 0.008
tail_s = 0.012
isp_on_time_s = [0.005, 0.03]
isp_s = [200.0, 270.0]

[propellant.blowdown]
gas_volume_m3 = 0.02
pressure_pa = 2.2e6
density_kg_m3 = 1004.0
"""


def paper_text(extra: str = "") -> str:
    text = (ROOT / "rcsim" / "models" / "vehicle" / "paper.toml").read_text(encoding="utf-8")
    return text.replace("[propellant]\n", "[propellant]\nmass_kg = 40.0\n", 1) + extra


def setup(vehicle: Vehicle, runs_per_case: int):
    cases = load_rate_cases()
    rate = np.repeat(np.asarray(cases.rate_cmd, float), runs_per_case, axis=0)
    n = rate.shape[0]
    sigmas = DispersionSigmas.from_table(load_dispersions())
    params = draw_runs(vehicle.nominal(1), sigmas, 1, np.arange(n)).params
    return params, rate, make_controller("lookup", vehicle)


def fly_once(vehicle: Vehicle, params, rate, ctl, duration_s: float) -> tuple[float, float]:
    """CPU seconds of one flight, and its physics pieces per run-cycle."""
    n = rate.shape[0]
    sim = simulation.BatchSimulation(params, vehicle, nthread=1)
    count = [0]
    real = sim.physics.batch.rollout

    def counting(nstep, *a, **kw):
        ids = kw.get("ids")
        count[0] += nstep * (n if ids is None else len(ids))
        return real(nstep, *a, **kw)

    sim.physics.batch.rollout = counting
    t0 = time.process_time()
    sim.run(ctl, Guidance.rate(np.zeros((n, 3))), duration_s, omega0_B=rate)
    cpu = time.process_time() - t0
    cycles = int(np.ceil(duration_s / vehicle.control.cycle_s - 1e-9))
    return cpu, count[0] / (n * cycles)


def rigid_rate(runs_per_case: int, duration_s: float) -> float:
    """Sim-s per CPU-s of the packaged paper vehicle (square pulses, no propellant tracked)."""
    vehicle = Vehicle.load("paper")
    params, rate, ctl = setup(vehicle, runs_per_case)
    cpu, _ = fly_once(vehicle, params, rate, ctl, duration_s)
    return rate.shape[0] * duration_s / cpu


def compare_versions(args) -> None:
    """The rigid vehicle under this version and ``--baseline-root``'s, interleaved, each run
    in a fresh process (its own imports)."""
    me = Path(__file__).resolve()
    roots = {"this": str(ROOT), "baseline": str(Path(args.baseline_root).resolve())}
    best = {k: 0.0 for k in roots}
    for _ in range(args.repeats):
        for name, root in roots.items():
            env = {**os.environ, "PULSE_COST_ROOT": root}
            out = subprocess.run(
                [
                    sys.executable,
                    str(me),
                    "--rigid-only",
                    "--runs-per-case",
                    str(args.runs_per_case),
                    "--duration-s",
                    str(args.duration_s),
                ],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            ).stdout
            best[name] = max(best[name], float(out.split()[-1]))
    ratio = best["baseline"] / best["this"]
    print(
        f"rigid square-pulse vehicle: this version {best['this']:8.0f} sim-s per CPU-s, "
        f"baseline {best['baseline']:8.0f}; this / baseline cost {ratio:.3f}"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=4)
    ap.add_argument("--duration-s", type=float, default=10.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--baseline-root", default=None)
    ap.add_argument("--rigid-only", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.rigid_only:
        print(f"{rigid_rate(args.runs_per_case, args.duration_s):.6g}")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        vehicles = {}
        for name, extra in (("square", ""), ("shaped", SHAPED)):
            path = Path(tmp) / f"{name}.toml"
            path.write_text(paper_text(extra), encoding="utf-8")
            vehicles[name] = Vehicle.load(str(path))
        setups = {name: setup(v, args.runs_per_case) for name, v in vehicles.items()}
        n = setups["square"][1].shape[0]
        print(
            f"{n} runs x {args.duration_s:g} s, lookup controller, one thread, 40 kg propellant "
            f"tracked; load average {os.getloadavg()[0]:.2f}"
        )
        best = {name: np.inf for name in vehicles}
        pieces = {}
        for _ in range(args.repeats):
            for name, vehicle in vehicles.items():
                cpu, pieces[name] = fly_once(vehicle, *setups[name], args.duration_s)
                best[name] = min(best[name], cpu)
    for name in vehicles:
        print(
            f"{name:7s}: {n * args.duration_s / best[name]:8.0f} sim-s per CPU-s  "
            f"({best[name]:.2f} s)  physics pieces per run-cycle {pieces[name]:.3f}"
        )
    print(f"shaped / square cost: {best['shaped'] / best['square']:.3f}")
    if args.baseline_root:
        compare_versions(args)
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
