"""A slosh mode and a hinged panel in Basilisk, for the peer comparison in docs/basilisk_peer.md.

Runs under a Python environment with Basilisk installed (``pip install bsk numpy``), NOT
rcsim's: it imports nothing from rcsim.  Its counterpart for rcsim (MuJoCo) is
benchmarks/peer_modes.py, which flies the same two scenarios, writes the same JSON layout and
compares both against an independent linear model (``--compare``).

Scenarios (the same numbers in both scripts; each JSON carries them under ``params`` and the
comparer refuses files whose parameters differ)
-----------------------------------------------------------------------------------------
* Hub: the paper's vehicle as one rigid body, 3505 kg, CG at x = 1.41 m, principal inertia
  about the CG diag(3583.09, 3160.22, 2457.06) kg m^2, no gravity.  Body frame B: x roll,
  y pitch, z yaw; origin at the structural reference point.
* ``slosh``: one spring-mass-damper particle (``linearSpringMassDamper``), 350.5 kg (10 % of
  the hub) whose equilibrium P is 1 m ahead of the CG at r_PB_B = (2.41, 0, 0), moving along
  pHat_B = +y; k = m (2 pi 0.3 Hz)^2, damping ratio 0.01.  Mode coordinate rho [m]: the
  particle's displacement from P along pHat_B.
* ``panel``: one hinged rigid panel (``hingedRigidBodyStateEffector``), 50 kg, a 3 m x 2 m
  plate hinged at r_HB_B = (1.41, 1.5, 0) about +z, its CG d = 1.5 m out along +y (3 m from
  the vehicle's axis); k = (I_22 + m d^2) (2 pi 0.5 Hz)^2 about the hinge, damping ratio
  0.01.  Mode coordinate theta [rad]: the panel's rotation about the hinge axis +z,
  right-handed (Basilisk's H frame: h1 = -y, so the CG sits at r_H - d h1; h2 = +z, the
  axis; h3 = h1 x h2 = -x).
* Jets: the paper's four yaw jets (13-16) of 22.24 N, a pure couple of 32.2 N m about z:
  jets 14 + 16 (+z) fire 0.2 s at t = 0, 1, 2, 3, 4 s, jets 13 + 15 (-z) fire 0.2 s at
  t = 5, 6, 7, 8, 9 s; then 50 s free (60 s in all).  Commanded, as in basilisk_peer.py, as
  on-times once per 40 ms cycle by a flight-software task (each firing edge is on the step
  grid, so the pulses are exact in Basilisk too).

Output: for each scenario and dynamics step, at every 40 ms: the hub body rates omega_BN_B
[rad/s] and the mode coordinate and its rate (rho, rho-dot or theta, theta-dot), read from
the integrator's states.  RK4 (Basilisk's default) at a fixed step.

Usage::

    python benchmarks/basilisk_modes.py [--steps 0.04 0.01] [--scenarios slosh panel]
                                        [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time

import numpy as np
from Basilisk import __version__ as BSK_VERSION
from Basilisk.architecture import messaging, sysModel
from Basilisk.simulation import (
    hingedRigidBodyStateEffector,
    linearSpringMassDamper,
    spacecraft,
    thrusterDynamicEffector,
)
from Basilisk.utilities import SimulationBaseClass, macros, simIncludeThruster

# ---------------------------------------------------------------------------------------------
# The scenarios.  Everything the two scripts must agree on is in PARAMS (JSON-serialisable);
# benchmarks/peer_modes.py builds the same dictionary and its comparer checks equality.
HUB_MASS_KG = 3505.0
CG_B = [1.41, 0.0, 0.0]
INERTIA_B = [3583.09, 3160.22, 2457.06]
THRUST_N = 22.24
# The paper's yaw jets (rcsim/models/vehicle/paper.toml): (number, position in B [m], unit
# force direction on the vehicle in B).
JETS = [
    [13, [2.134, 0.0, 0.0], [0.0, -1.0, 0.0]],
    [14, [2.134, 0.0, 0.0], [0.0, 1.0, 0.0]],
    [15, [0.686, 0.0, 0.0], [0.0, 1.0, 0.0]],
    [16, [0.686, 0.0, 0.0], [0.0, -1.0, 0.0]],
]
# (jet numbers, start [s], on-time [s]); starts on the 40 ms grid.
PULSES = [[[14, 16], float(k), 0.2] for k in range(5)] + [
    [[13, 15], float(k), 0.2] for k in range(5, 10)
]
DURATION_S = 60.0
CYCLE_S = 0.04
OUTPUT_DT_S = 0.04

SLOSH_MASS_KG = 0.1 * HUB_MASS_KG
SLOSH_HZ = 0.3
SLOSH_ZETA = 0.01
SLOSH_K = SLOSH_MASS_KG * (2 * math.pi * SLOSH_HZ) ** 2
SLOSH = {
    "mass_kg": SLOSH_MASS_KG,
    "r_PB_B": [2.41, 0.0, 0.0],
    "pHat_B": [0.0, 1.0, 0.0],
    "k_n_m": SLOSH_K,
    "c_n_s_m": 2 * SLOSH_ZETA * math.sqrt(SLOSH_K * SLOSH_MASS_KG),
}

PANEL_MASS_KG = 50.0
PANEL_L_M, PANEL_W_M = 3.0, 2.0  # length along s1 (out from the hinge), width along the axis
PANEL_D_M = 1.5
# Thin plate about its CG, in the panel frame S (s1 along its length, s2 the hinge axis, s3
# normal to the plate).
PANEL_I_S = [
    PANEL_MASS_KG * PANEL_W_M**2 / 12,
    PANEL_MASS_KG * PANEL_L_M**2 / 12,
    PANEL_MASS_KG * (PANEL_L_M**2 + PANEL_W_M**2) / 12,
]
PANEL_HZ = 0.5
PANEL_ZETA = 0.01
PANEL_I_HINGE = PANEL_I_S[1] + PANEL_MASS_KG * PANEL_D_M**2
PANEL_K = PANEL_I_HINGE * (2 * math.pi * PANEL_HZ) ** 2
PANEL = {
    "mass_kg": PANEL_MASS_KG,
    "IPntS_S": PANEL_I_S,
    "d_m": PANEL_D_M,
    "r_HB_B": [1.41, 1.5, 0.0],
    # rows h1, h2, h3 in B: h1 = -y (the CG is at r_H - d h1), h2 = +z (the hinge axis).
    "dcm_HB": [[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]],
    "k_n_m_rad": PANEL_K,
    "c_n_m_s_rad": 2 * PANEL_ZETA * math.sqrt(PANEL_K * PANEL_I_HINGE),
}

PARAMS = {
    "hub": {"mass_kg": HUB_MASS_KG, "cg_B": CG_B, "inertia_B": INERTIA_B},
    "thrust_n": THRUST_N,
    "jets": JETS,
    "pulses": PULSES,
    "duration_s": DURATION_S,
    "cycle_s": CYCLE_S,
    "output_dt_s": OUTPUT_DT_S,
    "slosh": SLOSH,
    "panel": PANEL,
}
SCENARIOS = ("slosh", "panel")
MODE_NAMES = {"slosh": "rho_m", "panel": "theta_rad"}


def _col(v) -> list:
    return [[float(x)] for x in v]


# ---------------------------------------------------------------------------------------------
class PulseTrain(sysModel.SysModel):
    """Flight-software stand-in: every control cycle, each jet's on-time left in the cycle,
    from the fixed pulse schedule, as a THRArrayOnTimeCmdMsg (integer nanoseconds, so that a
    firing edge on the cycle grid is exactly on it)."""

    def __init__(self, pulses: list, jet_numbers: list[int], cycle_s: float):
        super().__init__()
        self.windows_ns = [[] for _ in jet_numbers]
        for jets, start, on in pulses:
            for j in jets:
                lo = macros.sec2nano(start)
                self.windows_ns[jet_numbers.index(j)].append((lo, lo + macros.sec2nano(on)))
        self.cycle_ns = macros.sec2nano(cycle_s)
        self.cmdOutMsg = messaging.THRArrayOnTimeCmdMsg()

    def Reset(self, CurrentSimNanos):
        pass

    def UpdateState(self, CurrentSimNanos):
        left = []
        for windows in self.windows_ns:
            ns = 0
            for lo, hi in windows:
                if lo <= CurrentSimNanos < hi:
                    ns = min(hi - CurrentSimNanos, self.cycle_ns)
            left.append(ns * 1e-9)
        payload = messaging.THRArrayOnTimeCmdMsgPayload()
        payload.OnTimeRequest = left
        self.cmdOutMsg.write(payload, CurrentSimNanos, self.moduleID)


def build_sim(scenario: str, dt_s: float, params: dict = PARAMS):
    """The Basilisk simulation of ``scenario`` ("slosh" or "panel") at dynamics step ``dt_s``.

    Task and module order as in basilisk_peer.py's ``build_sim`` (flight software first in a
    tick, then the hub integrates the step ending at the tick, then the thruster set reads the
    new command): with that order a per-cycle on-time command fires for exactly its cycle.
    """
    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("rcs")
    proc.addTask(sim.CreateNewTask("fsw", macros.sec2nano(params["cycle_s"])), 20)
    proc.addTask(sim.CreateNewTask("dyn", macros.sec2nano(dt_s)), 10)

    sc = spacecraft.Spacecraft()
    sc.ModelTag = "vehicle"
    hub = params["hub"]
    sc.hub.mHub = hub["mass_kg"]
    sc.hub.r_BcB_B = _col(hub["cg_B"])
    sc.hub.IHubPntBc_B = np.diag(hub["inertia_B"]).tolist()

    if scenario == "slosh":
        p = params["slosh"]
        mode = linearSpringMassDamper.LinearSpringMassDamper()
        mode.massInit = p["mass_kg"]  # no FuelTank: the particle's mass state stays constant
        mode.k = p["k_n_m"]
        mode.c = p["c_n_s_m"]
        mode.r_PB_B = _col(p["r_PB_B"])
        mode.pHat_B = _col(p["pHat_B"])
        state_names = (mode.nameOfRhoState, mode.nameOfRhoDotState)
    elif scenario == "panel":
        p = params["panel"]
        mode = hingedRigidBodyStateEffector.HingedRigidBodyStateEffector()
        mode.mass = p["mass_kg"]
        mode.IPntS_S = np.diag(p["IPntS_S"]).tolist()
        mode.d = p["d_m"]
        mode.k = p["k_n_m_rad"]
        mode.c = p["c_n_m_s_rad"]
        mode.r_HB_B = _col(p["r_HB_B"])
        mode.dcm_HB = p["dcm_HB"]
        state_names = (mode.nameOfThetaState, mode.nameOfThetaDotState)
    else:
        raise ValueError(f"scenario must be one of {SCENARIOS}, got {scenario!r}")
    mode.ModelTag = scenario
    sc.addStateEffector(mode)

    factory = simIncludeThruster.thrusterFactory()
    for _, r, d in params["jets"]:
        th = factory.create(
            "MOOG_Monarc_1", r, np.asarray(d, float), MaxThrust=params["thrust_n"],
            useMinPulseTime=False,
        )  # fmt: skip
        th.updateOnly = True  # no mass-depletion (jet damping) terms: rcsim has none
    thrusters = thrusterDynamicEffector.ThrusterDynamicEffector()
    factory.addToSpacecraft("jets", thrusters, sc)

    fsw = PulseTrain(params["pulses"], [j[0] for j in params["jets"]], params["cycle_s"])
    fsw.ModelTag = "pulseTrain"
    thrusters.cmdsInMsg.subscribeTo(fsw.cmdOutMsg)
    sim.AddModelToTask("fsw", fsw)
    sim.AddModelToTask("dyn", sc, 20)
    sim.AddModelToTask("dyn", thrusters, 10)
    # Keep the Python-side objects alive as long as the simulation.
    sim.vehicle, sim.mode, sim.thrusters, sim.fsw, sim.factory = sc, mode, thrusters, fsw, factory
    sim.state_names = state_names
    return sim


def fly(scenario: str, dt_s: float, params: dict = PARAMS) -> dict:
    """Fly ``scenario``; its time series at every ``output_dt_s`` (t = 0 included)."""
    t0 = time.perf_counter()
    sim = build_sim(scenario, dt_s, params)
    sim.InitializeSimulation()
    dm = sim.vehicle.dynManager
    omega_state = dm.getStateObject(sim.vehicle.hub.nameOfHubOmega)
    q_state, qd_state = (dm.getStateObject(n) for n in sim.state_names)
    n_out = round(params["duration_s"] / params["output_dt_s"])
    out = {"t_s": [], "omega_B_rad_s": [], "q": [], "q_dot": []}
    for i in range(n_out + 1):
        t_ns = macros.sec2nano(i * params["output_dt_s"])
        if i:
            sim.ConfigureStopTime(t_ns)
            sim.ExecuteSimulation()
        out["t_s"].append(t_ns * 1e-9)
        out["omega_B_rad_s"].append([row[0] for row in omega_state.getState()])
        out["q"].append(q_state.getState()[0][0])
        out["q_dot"].append(qd_state.getState()[0][0])
    out["q_name"] = MODE_NAMES[scenario]
    out["wall_s"] = time.perf_counter() - t0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--steps", type=float, nargs="+", default=[0.04, 0.01],
        help="dynamics steps [s] (each must divide the 40 ms cycle)",
    )  # fmt: skip
    ap.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=list(SCENARIOS))
    ap.add_argument(
        "--thrust-scale", type=float, default=1.0,
        help="multiply the jets' thrust (the amplitudes) by this",
    )  # fmt: skip
    ap.add_argument("--json", help="write the time series here")
    args = ap.parse_args(argv)
    if not (math.isfinite(args.thrust_scale) and args.thrust_scale > 0):
        ap.error(f"--thrust-scale must be positive, got {args.thrust_scale}")
    params = {**PARAMS, "thrust_n": PARAMS["thrust_n"] * args.thrust_scale}
    for dt in args.steps:
        # The pulse edges and the output times are on the 40 ms grid; a step that divides it
        # puts every edge and every sample on the dynamics task's ticks.
        dt_ns = macros.sec2nano(dt)
        if not (dt_ns > 0 and macros.sec2nano(CYCLE_S) % dt_ns == 0):
            ap.error(f"--steps {dt:g} does not divide the {CYCLE_S:g} s cycle")

    out = {
        "simulator": "basilisk",
        "version": BSK_VERSION,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "integrator": "RK4 (svIntegratorRK4), fixed step",
        "params": params,
        "steps": {},
    }
    print(f"Basilisk {BSK_VERSION}, Python {platform.python_version()}; RK4, fixed step")
    print(f"{'step':>6} {'scenario':<8} {'wall s':>7} {'peak |w_z| rad/s':>17} {'peak |q|':>10}")
    for dt in args.steps:
        entry = {}
        for scenario in args.scenarios:
            series = fly(scenario, dt, params)
            entry[scenario] = series
            wz = np.abs(np.array(series["omega_B_rad_s"])[:, 2]).max()
            q = np.abs(series["q"]).max()
            print(
                f"{dt * 1e3:4g}ms {scenario:<8} {series['wall_s']:7.2f} {wz:17.3e} {q:10.3e} "
                f"{series['q_name']}",
                flush=True,
            )
        out["steps"][f"{dt:g}"] = entry
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
