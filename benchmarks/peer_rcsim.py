"""rcsim's side of the Basilisk peer comparison (docs/basilisk_peer.md).

The scenario of benchmarks/basilisk_peer.py, flown with rcsim's batched simulator: rate case
26 of Table 3 fired open loop from the lookup table (roll jets 2, 4 and pitch jets 10, 12 for
0.28 s, yaw jets 14, 16 for 0.24 s, from t = 0), commanded as on-times every 40 ms control
cycle by a trivial controller, 20 s per run, N runs with mass, inertia and per-jet thrust
dispersed exactly as the Basilisk script draws them (same seeds, same order: the two
simulators fly the same vehicles run for run).

Measured: simulated seconds per wall second of the whole batch (set-up included) at the
packaged 40 ms RK4 step, with MuJoCo's pool at 1 and 2 threads; and the pulse accuracy (the
angular impulse delivered, from the final angular momentum in the inertial frame, against the
analytic sum of r x F * t per axis; nominal vehicle, every dispersed run, and a 12 ms
sub-cycle pulse on the roll jets).

Usage::

    python benchmarks/peer_rcsim.py [--runs 100] [--repeat 3] [--json FILE]
                                    [--compare BASILISK_JSON]   # run-by-run final rates
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.spacecraft.navigation import Guidance, NavState  # noqa: E402
from rcsim.spacecraft.simulation import BatchSimulation  # noqa: E402
from rcsim.spacecraft.vehicle import Vehicle  # noqa: E402
from rcsim.spacecraft.vehicle.run_parameters import RunParameters, torque_per_jet_B  # noqa: E402

N_JETS = 16  # the paper's vehicle (paper.toml), as benchmarks/basilisk_peer.py copies it

DURATION_S = 20.0
CYCLE_S = 0.04
RATE_CMD_RAD_S = np.deg2rad(0.1732)  # Table 3, case 26: each axis

CASE26_ON_S = np.zeros(N_JETS)
CASE26_ON_S[[1, 3, 9, 11]] = 0.28
CASE26_ON_S[[13, 15]] = 0.24
PROBE_ON_S = np.zeros(N_JETS)
PROBE_ON_S[[1, 3]] = 0.012
PROBE_DURATION_S = 1.0

# Table 5 three-sigma values -> one sigma (rcsim/models/data/table5_dispersions.csv).
SIGMA_MASS_KG = 73.60 / 3
SIGMA_INERTIA = np.array([322.48, 284.42, 221.13]) / 3
SIGMA_THRUST_N = 2.00 / 3


class OpenLoopFiring:
    """Controller: each cycle, the on-time left of each jet's firing, clipped to one cycle."""

    def __init__(self, on_s: np.ndarray, cycle_s: float = CYCLE_S):
        self.on_s = np.asarray(on_s, float)
        self.cycle_s = cycle_s

    def initial_state(self, n_runs: int):
        return None

    def step(self, nav: NavState, state):
        left = np.clip(self.on_s - nav.t_s, 0.0, self.cycle_s)
        return np.broadcast_to(left, (nav.n_runs, N_JETS)).copy(), state


def dispersed_params(n_runs: int, vehicle: Vehicle) -> RunParameters:
    """The vehicles of benchmarks/basilisk_peer.py's runs 0..n_runs-1 (same seeds, same order:
    numpy's legacy generator seeded with 10 * run, then mass, 3 inertias, 16 thrusts)."""
    params = vehicle.nominal(n_runs)
    mass, inertia, thrust = params.mass_kg.copy(), params.inertia_B.copy(), params.thrust_n.copy()
    for run in range(n_runs):
        np.random.seed(10 * run)
        mass[run] += SIGMA_MASS_KG * np.random.standard_normal()
        inertia[run] += SIGMA_INERTIA * np.random.standard_normal(3)
        thrust[run] += SIGMA_THRUST_N * np.random.standard_normal(N_JETS)
    return replace(params, mass_kg=mass, inertia_B=inertia, thrust_n=thrust)


def fly(params: RunParameters, vehicle: Vehicle, on_s: np.ndarray, duration_s: float, nthread: int):
    """Build the batch and fly it; returns (history, wall seconds including set-up).

    No propellant tank (``tank=None``): the mass properties stay the drawn ones, as in the
    Basilisk script (its thrusters do not deplete mass)."""
    t0 = time.perf_counter()
    sim = BatchSimulation(params, vehicle, nthread=nthread, tank=None)
    guidance = Guidance.rate(np.full((params.n_runs, 3), RATE_CMD_RAD_S))
    hist = sim.run(OpenLoopFiring(on_s), guidance, duration_s)
    return hist, time.perf_counter() - t0


def momentum_N(hist, params: RunParameters) -> np.ndarray:
    """Angular momentum about the CG in the inertial frame at the end, (n_runs, 3) [N m s]."""
    h_B = params.inertia_B * hist.final.omega_B
    out = np.empty_like(h_B)
    for i, (q, h) in enumerate(zip(hist.final.q_BN, h_B)):
        mat = np.empty(9)
        mujoco.mju_quat2Mat(mat, q)  # body -> world
        out[i] = mat.reshape(3, 3) @ h
    return out


def analytic_impulse(params: RunParameters, model: mujoco.MjModel, on_s: np.ndarray) -> np.ndarray:
    """Sum over jets of (r - cg) x F * t, (n_runs, 3) [N m s]."""
    return np.einsum("nja,j->na", torque_per_jet_B(params, model), on_s)


def accuracy(vehicle: Vehicle, params: RunParameters, hist) -> dict:
    model = vehicle.model
    nominal = vehicle.nominal(1)
    h_nom, _ = fly(nominal, vehicle, CASE26_ON_S, DURATION_S, 1)
    ref = analytic_impulse(nominal, model, CASE26_ON_S)[0]
    h = momentum_N(h_nom, nominal)[0]
    disp = (
        momentum_N(hist, params) - analytic_impulse(params, model, CASE26_ON_S)
    ) / analytic_impulse(params, model, CASE26_ON_S)
    h_probe, _ = fly(nominal, vehicle, PROBE_ON_S, PROBE_DURATION_S, 1)
    probe_ref = analytic_impulse(nominal, model, PROBE_ON_S)[0]
    probe = momentum_N(h_probe, nominal)[0]
    return {
        "nominal_impulse_rel_err_xyz": ((h - ref) / ref).tolist(),
        "analytic_impulse_Nms": ref.tolist(),
        "nominal_rate_after_firing_rad_s": (h / nominal.inertia_B[0]).tolist(),
        "analytic_rate_after_firing_rad_s": (ref / nominal.inertia_B[0]).tolist(),
        "nominal_final_rate_rad_s": h_nom.final.omega_B[0].tolist(),
        "dispersed_max_abs_rel_err": float(np.abs(disp).max()),
        "probe_12ms_rel_err": float((probe[0] - probe_ref[0]) / probe_ref[0]),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3, help="timings repeated, median reported")
    ap.add_argument(
        "--steps",
        type=float,
        nargs="+",
        default=[0.04],
        help="physics steps [s] (each must divide the 40 ms cycle)",
    )
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--compare", help="a basilisk_peer.py --json file: compare final rates")
    args = ap.parse_args(argv)

    sim_s = args.runs * DURATION_S
    out = {
        "mujoco": mujoco.__version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "cpus": os.cpu_count(),
        "runs": args.runs,
        "duration_s": DURATION_S,
        "repeat": args.repeat,
        "steps": {},
    }
    print(
        f"rcsim on MuJoCo {mujoco.__version__}, Python {platform.python_version()}, "
        f"{os.cpu_count()} CPUs; {args.runs} runs x {DURATION_S:g} s, median of {args.repeat}"
    )
    print(f"{'step':>6} {'threads':<10} {'wall s':>8} {'sim-s/wall-s':>13}")
    for dt in args.steps:
        vehicle = Vehicle.load().with_physics(timestep_s=dt)
        if vehicle.control.cycle_s != CYCLE_S or vehicle.n_jets != N_JETS:
            raise SystemExit(f"the paper's vehicle is no longer the peer's: {vehicle.label}")
        params = dispersed_params(args.runs, vehicle)
        entry = {"timing": {}}
        hist = None
        for nthread in args.threads:
            walls = []
            for _ in range(args.repeat):
                hist, wall = fly(params, vehicle, CASE26_ON_S, DURATION_S, nthread)
                walls.append(wall)
            wall = statistics.median(walls)
            entry["timing"][f"{nthread} thread"] = {
                "wall_s": walls,
                "median_wall_s": wall,
                "sim_s_per_wall_s": sim_s / wall,
            }
            print(f"{dt * 1e3:4g}ms {nthread:<10} {wall:8.3f} {sim_s / wall:13.0f}", flush=True)
        if hist.failed.any():
            raise RuntimeError(f"runs failed: {set(hist.reason) - {''}}")
        entry["accuracy"] = accuracy(vehicle, params, hist)
        entry["final_omega_rad_s"] = hist.final.omega_B.tolist()
        out["steps"][f"{dt:g}"] = entry

    print("\npulse accuracy (delivered angular impulse vs sum r x F t; roll, pitch, yaw)")
    for dt, entry in out["steps"].items():
        acc = entry["accuracy"]
        nom = ", ".join(f"{e:+.2e}" for e in acc["nominal_impulse_rel_err_xyz"])
        print(
            f"{float(dt) * 1e3:4g}ms case 26 nominal [{nom}]  dispersed max |err| "
            f"{acc['dispersed_max_abs_rel_err']:.2e}  12 ms pulse {acc['probe_12ms_rel_err']:+.2e}"
        )

    if args.compare:
        other = json.loads(Path(args.compare).read_text())
        print(
            f"\nfinal body rates, run by run, against {Path(args.compare).name} "
            f"(Basilisk {other.get('bsk_version')}, flight software {other.get('fsw')})"
        )
        out["compare"] = {}
        for dt, entry in out["steps"].items():
            mine = np.array(entry["final_omega_rad_s"])
            for bdt, bentry in other["steps"].items():
                theirs = np.array(bentry["final_omega_rad_s"])
                n = min(len(mine), len(theirs))
                diff = np.abs(mine[:n] - theirs[:n]).max(axis=1)
                rel = float((diff / np.linalg.norm(mine[:n], axis=1)).max())
                key = f"rcsim {float(dt) * 1e3:g} ms vs Basilisk {float(bdt) * 1e3:g} ms"
                out["compare"][key] = {
                    "runs": n,
                    "max_abs_rad_s": float(diff.max()),
                    "max_rel": rel,
                }
                print(
                    f"  {key}: {n} runs, max |d omega| {diff.max():.2e} rad/s "
                    f"({rel:.2e} of |omega|)"
                )
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
