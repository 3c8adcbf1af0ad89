"""The rate-command Monte Carlo in Basilisk, for the peer comparison in docs/basilisk_peer.md.

Runs under a Python environment with Basilisk installed (``pip install bsk numpy``), NOT
rcsim's: it imports nothing from rcsim.  Its counterpart for rcsim is benchmarks/peer_rcsim.py;
both draw the same dispersed vehicles run for run (see ``draw_params``).

Scenario (the same in both scripts)
-----------------------------------
* Vehicle: one rigid body, mass 3505 kg, CG at x = 1.41 m, principal inertia about the CG
  diag(3583.09, 3160.22, 2457.06) kg m^2, no gravity, no environment.
* 16 jets of 22.24 N, geometry copied from rcsim/models/vehicle/paper.toml (``JETS`` below).
* Rate case 26 of Table 3 (0.1732 deg/s on each axis), fired open loop from the lookup table
  (rcsim/models/data/table7_lookup_updated.csv): roll jets 2, 4 and pitch jets 10, 12 for 0.28 s,
  yaw jets 14, 16 for 0.24 s, all from t = 0; commanded as on-times once per 40 ms control
  cycle by a flight-software task; 20 s per run.
* Dispersions per run (1-sigma = Table 5's 3-sigma / 3, rcsim/models/data/table5_dispersions.csv):
  mass, the three principal inertias, the thrust of each jet.
* No per-run retention: only each run's final attitude and body rate are kept.

Measured
--------
* Simulated seconds per wall second of the whole Monte Carlo (set-up of every run included),
  at a 40 ms and a 1 ms dynamics step (RK4, Basilisk's default integrator), with Basilisk's
  Monte Carlo ``Controller`` (1 and 2 processes) and a plain loop re-building the sim per run
  (1 process, and 2 processes through a ``multiprocessing.Pool`` over chunks of runs).
* Pulse accuracy: the angular impulse the jets delivered (final angular momentum, inertial
  frame; the vehicle is torque-free after the firing so it is conserved) against the
  analytic sum of r x F * t, per axis, for the nominal vehicle and for every dispersed run;
  and a 12 ms sub-cycle pulse on the roll jets (the case that shows step quantization).

Usage::

    python benchmarks/basilisk_peer.py [--runs 100] [--repeat 3] [--json FILE]
"""

from __future__ import annotations

import argparse
import functools
import json
import multiprocessing as mp
import platform
import statistics
import sys
import time

import numpy as np
from Basilisk import __version__ as BSK_VERSION
from Basilisk.architecture import messaging, sysModel
from Basilisk.simulation import spacecraft, thrusterDynamicEffector
from Basilisk.utilities import SimulationBaseClass, macros, simIncludeThruster
from Basilisk.utilities.MonteCarlo.Controller import Controller

# ---------------------------------------------------------------------------------------------
# The vehicle (rcsim/models/vehicle/paper.toml; Gambone Table 1).  Body frame B: x roll, y pitch,
# z yaw; origin at the structural reference point.
MASS_KG = 3505.00
CG_B = (1.41, 0.0, 0.0)
INERTIA_B = (3583.09, 3160.22, 2457.06)  # principal, about the CG
THRUST_N = 22.24
# (position in B [m], unit force direction on the vehicle in B), jets 1..16, copied from the
# [[jet]] entries of rcsim/models/vehicle/paper.toml (direction = force direction).
JETS = (
    ((1.41, 0.812, 0.0), (0, 0, -1)),
    ((1.41, 0.812, 0.0), (0, 0, 1)),  # 1, 2 roll
    ((1.41, -0.812, 0.0), (0, 0, 1)),
    ((1.41, -0.812, 0.0), (0, 0, -1)),  # 3, 4 roll
    ((0.41, 0.0, 0.0), (1, 0, 0)),
    ((2.41, 0.0, 0.0), (-1, 0, 0)),  # 5, 6 translation
    ((1.41, 0.0, -1.0), (0, 0, 1)),
    ((1.41, 0.0, 1.0), (0, 0, -1)),  # 7, 8 translation
    ((1.41, 0.0, 0.776), (-1, 0, 0)),
    ((1.41, 0.0, 0.776), (1, 0, 0)),  # 9, 10 pitch
    ((1.41, 0.0, -0.776), (1, 0, 0)),
    ((1.41, 0.0, -0.776), (-1, 0, 0)),  # 11, 12 pitch
    ((2.134, 0.0, 0.0), (0, -1, 0)),
    ((2.134, 0.0, 0.0), (0, 1, 0)),  # 13, 14 yaw
    ((0.686, 0.0, 0.0), (0, 1, 0)),
    ((0.686, 0.0, 0.0), (0, -1, 0)),  # 15, 16 yaw
)
N_JETS = len(JETS)

# Rate case 26, on-times [s] per jet (0-based index = jet number - 1).
CASE26_ON_S = np.zeros(N_JETS)
CASE26_ON_S[[1, 3, 9, 11]] = 0.28
CASE26_ON_S[[13, 15]] = 0.24
# Sub-cycle probe: roll jets 2 and 4 for 12 ms.
PROBE_ON_S = np.zeros(N_JETS)
PROBE_ON_S[[1, 3]] = 0.012
PROBE_DURATION_S = 1.0

CYCLE_S = 0.04
DURATION_S = 20.0

# Table 5 three-sigma values -> one sigma.
SIGMA_MASS_KG = 73.60 / 3
SIGMA_INERTIA = np.array([322.48, 284.42, 221.13]) / 3
SIGMA_THRUST_N = 2.00 / 3


def _draw() -> dict:
    """One dispersed vehicle from numpy's legacy global generator, in its current state."""
    return {
        "mass": MASS_KG + SIGMA_MASS_KG * np.random.standard_normal(),
        "inertia": np.array(INERTIA_B) + SIGMA_INERTIA * np.random.standard_normal(3),
        "thrust": THRUST_N + SIGMA_THRUST_N * np.random.standard_normal(N_JETS),
    }


def draw_params(run: int | None) -> dict:
    """Vehicle parameters of run ``run`` (``None``: the nominal vehicle).

    Basilisk's Monte Carlo ``SimulationExecutor`` seeds numpy's legacy generator with
    ``10 * run`` before it builds run ``run``; the creation function then draws with
    ``_draw``.  Seeding the same way here gives the same vehicle in the plain loop, and
    benchmarks/peer_rcsim.py repeats this exact draw so that both simulators fly the same
    vehicles run for run.
    """
    if run is None:
        return {
            "mass": MASS_KG,
            "inertia": np.array(INERTIA_B),
            "thrust": np.full(N_JETS, THRUST_N),
        }
    np.random.seed(10 * run)
    return _draw()


def analytic_impulse(thrust: np.ndarray, on_s: np.ndarray) -> np.ndarray:
    """Angular impulse about the CG, sum of (r - cg) x F * t, body axes [N m s]."""
    h = np.zeros(3)
    for (r, d), f, t in zip(JETS, thrust, on_s):
        h += np.cross(np.subtract(r, CG_B), f * np.asarray(d, float)) * t
    return h


def mrp_to_dcm(sigma: np.ndarray) -> np.ndarray:
    """[BN] from the MRP sigma_BN (maps N components to B components)."""
    s = np.asarray(sigma, float)
    s2 = s @ s
    sx = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
    return np.eye(3) + (8 * sx @ sx - 4 * (1 - s2) * sx) / (1 + s2) ** 2


# ---------------------------------------------------------------------------------------------
class OpenLoopFiring(sysModel.SysModel):
    """Flight-software stand-in: every control cycle, the on-time left of each jet's firing,
    clipped to one cycle, as a THRArrayOnTimeCmdMsg."""

    def __init__(self, on_s: np.ndarray, cycle_s: float):
        super().__init__()
        self.on_s = np.asarray(on_s, float)
        self.cycle_s = cycle_s
        self.cmdOutMsg = messaging.THRArrayOnTimeCmdMsg()

    def Reset(self, CurrentSimNanos):
        pass

    def UpdateState(self, CurrentSimNanos):
        payload = messaging.THRArrayOnTimeCmdMsgPayload()
        left = np.clip(self.on_s - CurrentSimNanos * 1e-9, 0.0, self.cycle_s)
        payload.OnTimeRequest = left.tolist()
        self.cmdOutMsg.write(payload, CurrentSimNanos, self.moduleID)


def build_sim(dt_s: float, params: dict, on_s: np.ndarray = CASE26_ON_S, fsw: str = "python"):
    """One Basilisk simulation of the scenario at dynamics step ``dt_s``.

    ``fsw="python"``: the on-times come from ``OpenLoopFiring``, a Python module run every
    40 ms control cycle (like-for-like with rcsim, whose controller is Python every cycle).
    ``fsw="none"``: no flight software; one on-time message with the whole firing is written
    before the run (the least Basilisk can do per run: a lower bound on its cost).
    """
    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("rcs")
    # Order within a time tick (higher priority runs first): the flight-software task writes
    # the new cycle's on-times; then, in the dynamics task, the hub integrates the step that
    # ends at this tick (still with the ending cycle's firing); then the thruster set reads
    # the new command, which it times from the message's write time.  With the thruster set
    # before the hub, the last cycle of every firing is lost at a 40 ms step (-14 % here);
    # with the flight software after the dynamics, every cycle's command is read one cycle
    # late, already expired, and almost nothing fires.
    proc.addTask(sim.CreateNewTask("fsw", macros.sec2nano(CYCLE_S)), 20)
    proc.addTask(sim.CreateNewTask("dyn", macros.sec2nano(dt_s)), 10)

    sc = spacecraft.Spacecraft()
    sc.ModelTag = "vehicle"
    sc.hub.mHub = float(params["mass"])
    sc.hub.r_BcB_B = [[CG_B[0]], [CG_B[1]], [CG_B[2]]]
    ixx, iyy, izz = (float(v) for v in params["inertia"])
    sc.hub.IHubPntBc_B = [[ixx, 0.0, 0.0], [0.0, iyy, 0.0], [0.0, 0.0, izz]]

    factory = simIncludeThruster.thrusterFactory()
    for (r, d), f in zip(JETS, params["thrust"]):
        th = factory.create(
            "MOOG_Monarc_1", r, np.asarray(d, float), MaxThrust=float(f), useMinPulseTime=False
        )
        th.updateOnly = True  # no mass-depletion (jet damping) terms: rcsim has none
    thrusters = thrusterDynamicEffector.ThrusterDynamicEffector()
    factory.addToSpacecraft("jets", thrusters, sc)

    if fsw == "python":
        module = OpenLoopFiring(on_s, CYCLE_S)
        module.ModelTag = "openLoop"
        thrusters.cmdsInMsg.subscribeTo(module.cmdOutMsg)
        sim.AddModelToTask("fsw", module)
    elif fsw == "none":
        payload = messaging.THRArrayOnTimeCmdMsgPayload()
        payload.OnTimeRequest = np.asarray(on_s, float).tolist()
        module = messaging.THRArrayOnTimeCmdMsg().write(payload, 0)
        thrusters.cmdsInMsg.subscribeTo(module)
        sim.disableTask("fsw")
    else:
        raise ValueError(f"fsw must be 'python' or 'none', got {fsw!r}")
    sim.AddModelToTask("dyn", sc, 20)
    sim.AddModelToTask("dyn", thrusters, 10)
    # Keep the Python-side objects alive as long as the simulation.
    sim.vehicle, sim.thrusters, sim.fsw, sim.factory = sc, thrusters, module, factory
    return sim


def final_state(sim) -> tuple[np.ndarray, np.ndarray]:
    """(omega_BN_B [rad/s], H about the CG in N [N m s]) at the end of the run."""
    state = sim.vehicle.scStateOutMsg.read()
    omega = np.array(state.omega_BN_B, float)
    inertia = np.array(sim.vehicle.hub.IHubPntBc_B, float)
    h_N = mrp_to_dcm(state.sigma_BN).T @ (inertia @ omega)
    return omega, h_N


def execute(sim, duration_s: float = DURATION_S) -> None:
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(duration_s))
    sim.ExecuteSimulation()


# ---------------------------------------------------------------------------------------------
# Monte Carlo Controller path.  The Controller seeds numpy per run before it calls the
# creation function, which then draws the run's vehicle (see draw_params).  In one process the
# runs execute in order, so the results list is in run order; main() checks that the
# Controller's final rates equal the plain loop's, which re-seeds explicitly.
_RESULTS: list = []  # (run, omega, H) per run; filled only when the Controller runs in-process


def _mc_create(dt_s: float, fsw: str):
    return build_sim(dt_s, _draw(), fsw=fsw)


def _mc_execute(sim) -> None:
    execute(sim)
    _RESULTS.append((len(_RESULTS), *final_state(sim)))


def run_controller(dt_s: float, n_runs: int, n_proc: int, fsw: str) -> float:
    """Wall time [s] of Basilisk's Monte Carlo Controller over ``n_runs`` runs."""
    mc = Controller()
    mc.setSimulationFunction(functools.partial(_mc_create, dt_s, fsw))
    mc.setExecutionFunction(_mc_execute)
    mc.setExecutionCount(n_runs)
    mc.setThreadCount(n_proc)
    mc.setShouldDisperseSeeds(False)
    mc.setShouldArchiveParameters(False)
    mc.setVerbose(False)
    t0 = time.perf_counter()
    failed = mc.executeSimulations()
    wall = time.perf_counter() - t0
    if failed:
        raise RuntimeError(f"Monte Carlo runs failed: {failed}")
    return wall


# Plain loop: build, run, read, drop, one run after another.
def _loop_chunk(args) -> list:
    dt_s, runs, fsw = args
    out = []
    for run in runs:
        sim = build_sim(dt_s, draw_params(run), fsw=fsw)
        execute(sim)
        out.append((run, *final_state(sim)))
    return out


def run_loop(dt_s: float, n_runs: int, n_proc: int, fsw: str) -> tuple[float, list]:
    t0 = time.perf_counter()
    if n_proc == 1:
        results = _loop_chunk((dt_s, range(n_runs), fsw))
    else:
        chunks = [(dt_s, list(range(n_runs))[i::n_proc], fsw) for i in range(n_proc)]
        with mp.get_context("fork").Pool(n_proc) as pool:
            results = [r for part in pool.map(_loop_chunk, chunks) for r in part]
    return time.perf_counter() - t0, sorted(results, key=lambda r: r[0])


# ---------------------------------------------------------------------------------------------
def accuracy(dt_s: float, results: list, fsw: str) -> dict:
    """Impulse errors at step ``dt_s``: nominal vehicle, every dispersed run, 12 ms probe."""
    nominal = build_sim(dt_s, draw_params(None), fsw=fsw)
    execute(nominal)
    omega, h = final_state(nominal)
    h_ref = analytic_impulse(np.full(N_JETS, THRUST_N), CASE26_ON_S)
    nominal_err = (h - h_ref) / h_ref

    disp_err = []
    for run, _, h_run in results:
        ref = analytic_impulse(draw_params(run)["thrust"], CASE26_ON_S)
        disp_err.append((h_run - ref) / ref)
    disp_err = np.array(disp_err)

    probe = build_sim(dt_s, draw_params(None), PROBE_ON_S, fsw=fsw)
    execute(probe, PROBE_DURATION_S)
    _, h_probe = final_state(probe)
    probe_ref = analytic_impulse(np.full(N_JETS, THRUST_N), PROBE_ON_S)
    return {
        "nominal_impulse_rel_err_xyz": nominal_err.tolist(),
        "nominal_rate_after_firing_rad_s": (h / np.array(INERTIA_B)).tolist(),
        "analytic_rate_after_firing_rad_s": (h_ref / np.array(INERTIA_B)).tolist(),
        "nominal_final_rate_rad_s": omega.tolist(),
        "dispersed_max_abs_rel_err": float(np.abs(disp_err).max()) if len(disp_err) else None,
        "probe_12ms_rel_err": float((h_probe[0] - probe_ref[0]) / probe_ref[0]),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=3, help="timings repeated, median reported")
    ap.add_argument("--steps", type=float, nargs="+", default=[0.04, 0.001])
    ap.add_argument("--procs", type=int, nargs="+", default=[1, 2])
    ap.add_argument(
        "--fsw",
        choices=("python", "none"),
        default="python",
        help="on-times from a Python module every 40 ms cycle, or one message "
        "written before the run (no flight software)",
    )
    ap.add_argument(
        "--methods", nargs="+", choices=("controller", "loop"), default=["controller", "loop"]
    )
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)

    sim_s = args.runs * DURATION_S
    out = {
        "bsk_version": BSK_VERSION,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "cpus": mp.cpu_count(),
        "runs": args.runs,
        "duration_s": DURATION_S,
        "repeat": args.repeat,
        "fsw": args.fsw,
        "steps": {},
    }
    print(
        f"Basilisk {BSK_VERSION}, Python {platform.python_version()}, {mp.cpu_count()} CPUs; "
        f"{args.runs} runs x {DURATION_S:g} s, median of {args.repeat}; flight software: {args.fsw}"
    )
    print(f"{'step':>6} {'method':<24} {'wall s':>8} {'sim-s/wall-s':>13}")
    for dt in args.steps:
        entry = {"timing": {}}
        results = None
        for n_proc in args.procs:
            for method in args.methods:
                walls = []
                for _ in range(args.repeat):
                    _RESULTS.clear()
                    if method == "controller":
                        walls.append(run_controller(dt, args.runs, n_proc, args.fsw))
                        if n_proc == 1:
                            results = sorted(_RESULTS, key=lambda r: r[0])
                    else:
                        wall, res = run_loop(dt, args.runs, n_proc, args.fsw)
                        walls.append(wall)
                        if results is not None:  # the Controller flew the same vehicles
                            diff = max(np.abs(a[1] - b[1]).max() for a, b in zip(results, res))
                            if diff > 1e-12:
                                raise RuntimeError(f"Controller and loop disagree by {diff}")
                        results = results or res
                wall = statistics.median(walls)
                name = f"{method}, {n_proc} proc"
                entry["timing"][name] = {
                    "wall_s": walls,
                    "median_wall_s": wall,
                    "sim_s_per_wall_s": sim_s / wall,
                }
                print(f"{dt * 1e3:4g}ms {name:<24} {wall:8.2f} {sim_s / wall:13.0f}", flush=True)
        if results is None:
            # Only multi-process Controller runs were timed: their final states stay in the
            # worker processes, so fly the same vehicles once here for the accuracy figures.
            _, results = run_loop(dt, args.runs, 1, args.fsw)
        entry["accuracy"] = accuracy(dt, results, args.fsw)
        entry["final_omega_rad_s"] = [r[1].tolist() for r in results]
        out["steps"][f"{dt:g}"] = entry

    print("\npulse accuracy (delivered angular impulse vs sum r x F t; roll, pitch, yaw)")
    for dt, entry in out["steps"].items():
        acc = entry["accuracy"]
        nom = ", ".join(f"{e:+.2e}" for e in acc["nominal_impulse_rel_err_xyz"])
        print(
            f"{float(dt) * 1e3:4g}ms case 26 nominal [{nom}]  dispersed max |err| "
            f"{acc['dispersed_max_abs_rel_err']:.2e}  12 ms pulse {acc['probe_12ms_rel_err']:+.3f}"
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
