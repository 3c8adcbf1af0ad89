"""rcsim's side of the slosh / hinged-panel peer comparison (docs/basilisk_peer.md).

The two scenarios of benchmarks/basilisk_modes.py (a rigid hub plus ONE spring-mass slosh
mode, ``slosh``; a rigid hub plus ONE hinged rigid panel, ``panel``), flown in MuJoCo with the
same parameters and the same pulse train, written in the same JSON layout; and an independent
linear model of each (small angles, small rates: the linearised equations of motion of hub +
mode, integrated by SciPy's DOP853 at rtol 1e-12 between the pulse edges), so that each
simulator's error against the linear truth is known on its own.

The MuJoCo model is rcsim's own by default (``--model vehicle-file``): each scenario written as
a vehicle file (:func:`vehicle_file_text`: the hub and its mode composed into the file's
whole-vehicle ``[mass]`` by the parallel-axis theorem, the mode as a ``[[slosh]]`` or
``[[appendage]]`` block) and compiled by rcsim (``Vehicle.model``, its jets as site actuators),
as a user's vehicle is. ``--model hand-built`` flies :func:`build_scenario` instead, a small
MJCF written independently from Basilisk's definitions (a free hub body with the jets as site
actuators; a child body on a slide joint with stiffness and damping for the slosh mass, or on a
hinge joint with stiffness and damping for the panel): the two agree to rounding for the panel,
and to 3e-7 for the slosh, whose point mass rcsim gives m (1 mm)^2 of inertia
(tests/spacecraft/modes/test_modes_peer_model.py). The pulse train is exact in time: each
physics step divides the pulse edges, so a jet is fully on or fully off within every step (the
script refuses a step that does not).

Output per scenario and physics step, every 40 ms: the hub body rates omega_B [rad/s] (the
free joint's angular velocity, body frame), the mode coordinate q and its rate (slosh: rho
[m], the slide joint's displacement along pHat_B; panel: theta [rad], the hinge angle about
+z, right-handed).

Usage::

    python benchmarks/peer_modes.py [--steps 0.04 0.01] [--scenarios slosh panel]
                                    [--model vehicle-file|hand-built]
                                    [--json FILE] [--compare BASILISK_JSON]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
from scipy.integrate import solve_ivp

# ---------------------------------------------------------------------------------------------
# The scenarios: the same numbers as benchmarks/basilisk_modes.py (copied, not imported: that
# script runs in Basilisk's environment).  The comparer checks the two PARAMS are equal.
HUB_MASS_KG = 3505.0
CG_B = [1.41, 0.0, 0.0]
INERTIA_B = [3583.09, 3160.22, 2457.06]
THRUST_N = 22.24
JETS = [  # the paper's yaw jets: (number, position in B [m], unit force direction in B)
    [13, [2.134, 0.0, 0.0], [0.0, -1.0, 0.0]],
    [14, [2.134, 0.0, 0.0], [0.0, 1.0, 0.0]],
    [15, [0.686, 0.0, 0.0], [0.0, 1.0, 0.0]],
    [16, [0.686, 0.0, 0.0], [0.0, -1.0, 0.0]],
]
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
PANEL_L_M, PANEL_W_M = 3.0, 2.0
PANEL_D_M = 1.5
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
NS = 1_000_000_000


def _ns(t_s: float) -> int:
    return round(t_s * NS)


def _vec(v) -> str:
    return " ".join(repr(float(x)) for x in v)


# ------------------------------------------------------------------------ MuJoCo model --
def build_scenario(scenario: str, params: dict, dt_s: float) -> mujoco.MjModel:
    """The MuJoCo model of ``scenario`` ("slosh" or "panel") at physics step ``dt_s`` [s].

    The hub is a free body whose frame is B (origin at the structural reference point), with
    the jets as site actuators (force ``ctrl`` [N] along the site's +z).  The mode is a child
    body of the hub:

    * slosh: a point mass on a slide joint along pHat_B, its body frame at the equilibrium P
      (so the joint's position is Basilisk's rho); MuJoCo wants a positive rotational
      inertia for a body, so the particle gets 1e-12 kg m^2 (Basilisk's particle has none;
      against the hub's ~2.5e3 kg m^2 the difference is at rounding level).
    * panel: a rigid body on a hinge joint at r_HB_B about h2 (the second row of dcm_HB),
      its CG at -d h1 from the hinge and its inertia about the CG IPntS_S rotated into B.

    Springs act about the equilibrium (``springref`` 0); damping is linear in the joint rate.
    Integrator RK4 (rcsim's default), no gravity, no contacts.
    """
    hub = params["hub"]
    sites = "\n".join(
        f'      <site name="j{n}" pos="{_vec(r)}" zaxis="{_vec(d)}"/>' for n, r, d in params["jets"]
    )
    actuators = "\n".join(
        f'    <general name="jet{n}" site="j{n}" gear="0 0 1 0 0 0" ctrllimited="false"/>'
        for n, _, _ in params["jets"]
    )
    if scenario == "slosh":
        p = params["slosh"]
        child = f"""
      <body name="slosh" pos="{_vec(p["r_PB_B"])}">
        <joint name="mode" type="slide" axis="{_vec(p["pHat_B"])}"
               stiffness="{p["k_n_m"]!r}" damping="{p["c_n_s_m"]!r}"/>
        <inertial pos="0 0 0" mass="{p["mass_kg"]!r}" diaginertia="1e-12 1e-12 1e-12"/>
      </body>"""
    elif scenario == "panel":
        p = params["panel"]
        dcm_HB = np.array(p["dcm_HB"], float)
        h1, h2 = dcm_HB[0], dcm_HB[1]
        inertia_B = dcm_HB.T @ np.diag(p["IPntS_S"]) @ dcm_HB  # about the CG, B axes
        full = [inertia_B[0, 0], inertia_B[1, 1], inertia_B[2, 2]]
        full += [inertia_B[0, 1], inertia_B[0, 2], inertia_B[1, 2]]
        child = f"""
      <body name="panel" pos="{_vec(p["r_HB_B"])}">
        <joint name="mode" type="hinge" axis="{_vec(h2)}"
               stiffness="{p["k_n_m_rad"]!r}" damping="{p["c_n_m_s_rad"]!r}"/>
        <inertial pos="{_vec(-p["d_m"] * h1)}" mass="{p["mass_kg"]!r}" fullinertia="{_vec(full)}"/>
      </body>"""
    else:
        raise ValueError(f"scenario must be one of {SCENARIOS}, got {scenario!r}")
    xml = f"""
<mujoco model="modes_{scenario}">
  <compiler angle="radian"/>
  <option timestep="{dt_s!r}" integrator="RK4" gravity="0 0 0" density="0" viscosity="0">
    <flag contact="disable"/>
  </option>
  <worldbody>
    <body name="hub">
      <freejoint name="root"/>
      <inertial pos="{_vec(hub["cg_B"])}" mass="{hub["mass_kg"]!r}"
                diaginertia="{_vec(hub["inertia_B"])}"/>
{sites}{child}
    </body>
  </worldbody>
  <actuator>
{actuators}
  </actuator>
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def _point_inertia(m: float, r) -> np.ndarray:
    """A point mass ``m`` [kg] at ``r`` [m]: its inertia about the origin [kg m^2]."""
    r = np.asarray(r, float)
    return m * (r @ r * np.eye(3) - np.outer(r, r))


def vehicle_file_text(scenario: str, params: dict) -> str:
    """``scenario`` as an rcsim vehicle file: ``[mass]`` is the whole vehicle with the mode at
    rest (the hub of ``params`` plus the mode, by the parallel-axis theorem), the jets in
    ``params["jets"]`` order (``jet_01``...), the mode a block named ``mode`` (its joint
    ``mode_1`` for the slosh, ``mode_hinge`` for the panel: :data:`VEHICLE_FILE_NAMES`)."""
    from rcsim.spacecraft.modes.definition import POINT_GYRATION_M

    hub = params["hub"]
    if scenario == "slosh":
        p = params["slosh"]
        own = p["mass_kg"] * POINT_GYRATION_M**2 * np.eye(3)  # rcsim's point mass
        mode_mass, mode_cg = p["mass_kg"], np.asarray(p["r_PB_B"], float)
        block = (
            f'[[slosh]]\nname = "mode"\nmodel = "spring"\nmass_kg = {p["mass_kg"]!r}\n'
            f"position_m = {list(p['r_PB_B'])}\ndirection = {list(p['pHat_B'])}\n"
            f"frequency_hz = {_hz(p['k_n_m'], p['mass_kg'])!r}\n"
            f"damping_ratio = {_zeta(p['k_n_m'], p['c_n_s_m'], p['mass_kg'])!r}\n"
        )
    elif scenario == "panel":
        p = params["panel"]
        h = np.asarray(p["dcm_HB"], float)
        own = h.T @ np.diag(p["IPntS_S"]) @ h  # about the panel's CG, B axes
        offset = -p["d_m"] * h[0]  # the CG at -d h1 from the hinge
        mode_mass, mode_cg = p["mass_kg"], np.add(p["r_HB_B"], offset)
        i = own.tolist()
        i_hinge = p["IPntS_S"][1] + p["mass_kg"] * p["d_m"] ** 2  # about the hinge axis h2
        block = (
            f'[[appendage]]\nname = "mode"\nmass_kg = {p["mass_kg"]!r}\n'
            f"inertia_kg_m2 = [{i[0][0]!r}, {i[1][1]!r}, {i[2][2]!r}]\n"
            f"products_kg_m2 = [{i[0][1]!r}, {i[0][2]!r}, {i[1][2]!r}]\n"
            f"hinge_m = {list(p['r_HB_B'])}\naxis = {h[1].tolist()}\n"
            f"cg_offset_m = {offset.tolist()}\n"
            f"frequency_hz = {_hz(p['k_n_m_rad'], i_hinge)!r}\n"
            f"damping_ratio = {_zeta(p['k_n_m_rad'], p['c_n_m_s_rad'], i_hinge)!r}\n"
        )
    else:
        raise ValueError(f"scenario must be one of {SCENARIOS}, got {scenario!r}")
    hub_m, hub_c = hub["mass_kg"], np.asarray(hub["cg_B"], float)
    mass = hub_m + mode_mass
    cg = (hub_m * hub_c + mode_mass * mode_cg) / mass
    inertia = np.diag(hub["inertia_B"]) + _point_inertia(hub_m, hub_c - cg)
    inertia = (inertia + own + _point_inertia(mode_mass, mode_cg - cg)).tolist()
    thrust = params["thrust_n"]
    jets = "".join(
        f"[[jet]]\nposition_m = {list(r)}\ndirection = {list(d)}\nthrust_n = {thrust!r}\n"
        for _, r, d in params["jets"]
    )
    return (
        f"[mass]\nmass_kg = {mass!r}\ncg_m = [{', '.join(repr(float(x)) for x in cg)}]\n"
        f"inertia_kg_m2 = [{inertia[0][0]!r}, {inertia[1][1]!r}, {inertia[2][2]!r}]\n"
        f"products_kg_m2 = [{inertia[0][1]!r}, {inertia[0][2]!r}, {inertia[1][2]!r}]\n"
        + jets
        + block
    )


def _hz(k: float, m: float) -> float:
    """The clamped frequency [Hz] of stiffness ``k`` on mass or inertia ``m``."""
    return math.sqrt(k / m) / (2 * math.pi)


def _zeta(k: float, c: float, m: float) -> float:
    """The damping ratio of damper ``c`` with stiffness ``k`` on ``m``."""
    return c / (2 * math.sqrt(k * m))


#: How rcsim's compiled vehicle names what :func:`fly_mujoco` reads, per scenario.
VEHICLE_FILE_NAMES = {"slosh": "mode_1", "panel": "mode_hinge"}
MODELS = ("vehicle-file", "hand-built")


def vehicle_file_model(scenario: str, params: dict, dt_s: float) -> mujoco.MjModel:
    """rcsim's compiled model of ``scenario`` (:func:`vehicle_file_text`), at step ``dt_s``
    [s], RK4 (rcsim's integrator)."""
    import tempfile

    from rcsim.spacecraft.vehicle import Vehicle

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{scenario}.toml"
        path.write_text(vehicle_file_text(scenario, params), encoding="utf-8")
        model = Vehicle.load(path).model
    model.opt.timestep = dt_s
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    return model


def _on_windows_ns(params: dict) -> list[list[tuple[int, int]]]:
    """Each jet's firing windows [start, end) in integer nanoseconds, in ``params["jets"]``
    order."""
    numbers = [j[0] for j in params["jets"]]
    windows: list[list[tuple[int, int]]] = [[] for _ in numbers]
    for jets, start, on in params["pulses"]:
        for n in jets:
            windows[numbers.index(n)].append((_ns(start), _ns(start) + _ns(on)))
    return windows


def step_divides(dt_s: float, params: dict) -> bool:
    """Whether the physics step ``dt_s`` divides every pulse edge and the output interval
    (then every jet is fully on or fully off within each step: the pulses are exact)."""
    dt_ns = _ns(dt_s)
    edges = {e for w in _on_windows_ns(params) for lo_hi in w for e in lo_hi}
    edges.add(_ns(params["output_dt_s"]))
    return dt_ns > 0 and all(e % dt_ns == 0 for e in edges)


def fly_mujoco(
    scenario: str, dt_s: float, params: dict = PARAMS, model_source: str = "vehicle-file"
) -> dict:
    """Fly ``scenario`` in MuJoCo at step ``dt_s``; its time series every ``output_dt_s``.
    ``model_source``: rcsim's model of the scenario's vehicle file, or the hand-built MJCF."""
    t0 = time.perf_counter()
    if not step_divides(dt_s, params):
        raise ValueError(f"step {dt_s:g} s does not divide the pulse edges and the output")
    dt_ns, out_ns = _ns(dt_s), _ns(params["output_dt_s"])
    windows = _on_windows_ns(params)
    # Looked up by name, not by position: the free joint "root" (its angular velocity, body
    # frame, is the hub's body rate), the mode's joint, each jet's actuator.  rcsim's jets
    # take the fraction of their thrust (gain = thrust), the hand-built ones newtons.
    if model_source == "vehicle-file":
        model = vehicle_file_model(scenario, params, dt_s)
        joint = model.joint(VEHICLE_FILE_NAMES[scenario])
        act = [model.actuator(f"jet_{k + 1:02d}").id for k in range(len(params["jets"]))]
        level = 1.0
    elif model_source == "hand-built":
        model = build_scenario(scenario, params, dt_s)
        joint = model.joint("mode")
        act = [model.actuator(f"jet{n}").id for n, _, _ in params["jets"]]
        level = params["thrust_n"]
    else:
        raise ValueError(f"model_source must be one of {MODELS}, got {model_source!r}")
    data = mujoco.MjData(model)
    w_adr = model.joint("root").dofadr[0] + 3
    q_adr, qd_adr = joint.qposadr[0], joint.dofadr[0]
    n_steps = round(params["duration_s"] / dt_s)
    every = out_ns // dt_ns
    out: dict = {"t_s": [], "omega_B_rad_s": [], "q": [], "q_dot": []}
    for i in range(n_steps + 1):
        if i % every == 0:
            out["t_s"].append(i * dt_ns / NS)
            out["omega_B_rad_s"].append(data.qvel[w_adr : w_adr + 3].tolist())
            out["q"].append(float(data.qpos[q_adr]))
            out["q_dot"].append(float(data.qvel[qd_adr]))
        if i == n_steps:
            break
        t_ns = i * dt_ns
        data.ctrl[act] = [level * any(lo <= t_ns < hi for lo, hi in w) for w in windows]
        mujoco.mj_step(model, data)
    out["q_name"] = MODE_NAMES[scenario]
    out["wall_s"] = time.perf_counter() - t0
    return out


# ------------------------------------------------------------------ linear analytic model --
def _skew(v) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def linear_matrices(scenario: str, params: dict):
    """(M, C, K, B_jets) of the linearised equations M z'' + C z' + K z = B_jets f(t).

    Generalised coordinates z (7): the position of B in the inertial frame (3), the hub's small
    rotation vector phi (3; phi' = omega_B to first order) and the mode coordinate (rho [m]
    or theta [rad]).  M comes from the kinetic energy at rest: a point at body position r
    moves with x' + phi' x r = x' - [r]x phi', so each mass m at r adds m J^T J with
    J = [I, -[r]x, dr/dq] (dr/dq: pHat for the slosh particle; d h3 for the panel's CG, whose
    position is r_H - d s1 and s1 turns about h2); a body's rotational inertia I about its CG
    adds J_w^T I J_w with J_w = [0, I, dw/dq] (h2 for the panel, 0 otherwise).  The spring
    and the damper act on the mode coordinate alone.  A jet of thrust f along d at r exerts
    the generalised force [d; r x d; 0] f.  Dropped (second order): the gyroscopic and
    centripetal terms (rate^2), the dependence of the geometry on the mode coordinate
    (q times rate or acceleration), and the rotation of the jets' forces with the hub
    (zero for a pure couple).
    """
    hub = params["hub"]
    n = 7
    M = np.zeros((n, n))

    def add_mass(m: float, r, dr_dq) -> None:
        J = np.zeros((3, n))
        J[:, :3] = np.eye(3)
        J[:, 3:6] = -_skew(r)
        J[:, 6] = dr_dq
        M[:] += m * J.T @ J

    def add_inertia(inertia_B: np.ndarray, dw_dq) -> None:
        J = np.zeros((3, n))
        J[:, 3:6] = np.eye(3)
        J[:, 6] = dw_dq
        M[:] += J.T @ inertia_B @ J

    add_mass(hub["mass_kg"], hub["cg_B"], np.zeros(3))
    add_inertia(np.diag(hub["inertia_B"]), np.zeros(3))
    K = np.zeros((n, n))
    C = np.zeros((n, n))
    if scenario == "slosh":
        p = params["slosh"]
        add_mass(p["mass_kg"], p["r_PB_B"], np.asarray(p["pHat_B"], float))
        K[6, 6], C[6, 6] = p["k_n_m"], p["c_n_s_m"]
    elif scenario == "panel":
        p = params["panel"]
        dcm_HB = np.array(p["dcm_HB"], float)
        h1, h2, h3 = dcm_HB
        r_S = np.asarray(p["r_HB_B"], float) - p["d_m"] * h1
        add_mass(p["mass_kg"], r_S, p["d_m"] * h3)
        add_inertia(dcm_HB.T @ np.diag(p["IPntS_S"]) @ dcm_HB, h2)
        K[6, 6], C[6, 6] = p["k_n_m_rad"], p["c_n_m_s_rad"]
    else:
        raise ValueError(f"scenario must be one of {SCENARIOS}, got {scenario!r}")
    B_jets = np.zeros((n, len(params["jets"])))
    for j, (_, r, d) in enumerate(params["jets"]):
        B_jets[:3, j] = d
        B_jets[3:6, j] = np.cross(r, d)
    return M, C, K, B_jets


def fly_linear(scenario: str, params: dict = PARAMS, rtol: float = 1e-12) -> dict:
    """The linear model's time series, in fly_mujoco's layout (DOP853 between pulse edges)."""
    t0 = time.perf_counter()
    M, C, K, B_jets = linear_matrices(scenario, params)
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((7, 7)), np.eye(7)], [-Minv @ K, -Minv @ C]])
    windows = _on_windows_ns(params)
    out_ns, end_ns = _ns(params["output_dt_s"]), _ns(params["duration_s"])
    t_out_ns = list(range(0, end_ns + 1, out_ns))
    edges = sorted({0, end_ns} | {e for w in windows for lo_hi in w for e in lo_hi})
    x = np.zeros(14)
    states = {0: x.copy()}
    for lo, hi in zip(edges[:-1], edges[1:]):
        f = params["thrust_n"] * np.array([any(a <= lo < b for a, b in w) for w in windows])
        b = np.concatenate([np.zeros(7), Minv @ B_jets @ f])
        inside = [t for t in t_out_ns if lo < t <= hi]
        sol = solve_ivp(
            lambda _t, y, b=b: A @ y + b, (lo / NS, hi / NS), x, method="DOP853", rtol=rtol,
            atol=1e-16, t_eval=[t / NS for t in inside] or None,
        )  # fmt: skip
        if not sol.success:
            raise RuntimeError(sol.message)
        for k, t in enumerate(inside):
            states[t] = sol.y[:, k]
        x = states[hi] if inside and inside[-1] == hi else sol.y[:, -1]
    ys = np.array([states[t] for t in t_out_ns])
    return {
        "t_s": [t / NS for t in t_out_ns],
        "omega_B_rad_s": ys[:, 10:13].tolist(),
        "q": ys[:, 6].tolist(),
        "q_dot": ys[:, 13].tolist(),
        "q_name": MODE_NAMES[scenario],
        "wall_s": time.perf_counter() - t0,
    }


def coupled_modes_hz(scenario: str, params: dict = PARAMS) -> list[float]:
    """Undamped frequencies [Hz] of the free vehicle's elastic modes (linear model)."""
    M, _, K, _ = linear_matrices(scenario, params)
    w2 = np.linalg.eigvals(np.linalg.solve(M, K)).real
    return sorted(float(np.sqrt(v) / (2 * np.pi)) for v in w2 if v > 1e-9)


def coupling(series: dict, params: dict) -> dict:
    """How visible the mode is in the hub rates.  The pulse train's couples cancel (as many
    +z as -z firings), so after the last pulse the vehicle holds zero angular momentum and
    any hub rate left is the mode trading momentum with the hub."""
    end = max(start + on for _, start, on in params["pulses"])
    t = np.array(series["t_s"])
    w = np.linalg.norm(np.array(series["omega_B_rad_s"]), axis=1)
    return {
        "firing_end_s": end,
        "peak_rate_rad_s": float(w.max()),
        "peak_rate_after_firing_rad_s": float(w[t > end + 1e-9].max()),
    }


# ------------------------------------------------------------------------------ compare --
def difference(a: dict, b: dict) -> dict:
    """Max over the flight of |a - b| for the hub rates (vector norm), q and q', each relative
    to b's peak (b is the reference)."""
    if len(a["t_s"]) != len(b["t_s"]) or not np.allclose(a["t_s"], b["t_s"], rtol=0, atol=1e-9):
        raise SystemExit("peer_modes: error: the two series are not sampled at the same times")
    out = {}
    for key in ("omega_B_rad_s", "q", "q_dot"):
        x, y = np.array(a[key], float), np.array(b[key], float)
        diff = np.abs(x - y) if x.ndim == 1 else np.linalg.norm(x - y, axis=1)
        peak = np.abs(y) if y.ndim == 1 else np.linalg.norm(y, axis=1)
        out[key] = {"max_abs": float(diff.max()), "rel_peak": float(diff.max() / peak.max())}
    return out


def _row(label: str, d: dict) -> str:
    return (
        f"| {label} | {d['omega_B_rad_s']['rel_peak']:.1e} | {d['q']['rel_peak']:.1e} | "
        f"{d['q_dot']['rel_peak']:.1e} |"
    )


def compare(mine: dict, theirs: dict, linear: dict) -> dict:
    """Every pair of (rcsim step, other step) per scenario, and each against the linear model;
    prints Markdown tables of max |difference| / peak."""
    if theirs["params"] != mine["params"]:
        raise SystemExit(
            "peer_modes: error: --compare: the file's scenario parameters differ from this "
            "script's (the two scripts' PARAMS must be kept equal)"
        )
    other = f"{theirs['simulator']} {theirs['version']}"
    result: dict = {}
    for scenario in linear:
        print(f"\n{scenario}: max |difference| over the flight / peak of the reference")
        print("| pair | hub rates | mode q | mode q' |\n|---|---|---|---|")
        res: dict = {}
        for sim_name, doc in (("rcsim", mine), (other, theirs)):
            for dt, entry in doc["steps"].items():
                if scenario in entry:
                    label = f"{sim_name} {float(dt) * 1e3:g} ms vs linear"
                    res[label] = difference(entry[scenario], linear[scenario])
                    print(_row(label, res[label]))
        for dt, entry in mine["steps"].items():
            for bdt, bentry in theirs["steps"].items():
                if scenario in entry and scenario in bentry:
                    label = f"rcsim {float(dt) * 1e3:g} ms vs {other} {float(bdt) * 1e3:g} ms"
                    res[label] = difference(entry[scenario], bentry[scenario])
                    print(_row(label, res[label]))
        result[scenario] = res
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--steps", type=float, nargs="+", default=[0.04, 0.01],
        help="physics steps [s] (each must divide the pulse edges and the 40 ms output)",
    )  # fmt: skip
    ap.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=list(SCENARIOS))
    ap.add_argument(
        "--thrust-scale", type=float, default=1.0,
        help="multiply the jets' thrust (the amplitudes) by this; the nonlinear terms the "
        "linear model drops shrink with its square",
    )  # fmt: skip
    ap.add_argument(
        "--model", choices=MODELS, default="vehicle-file",
        help="rcsim's model of the scenario written as a vehicle file (default), or the "
        "hand-built MJCF",
    )  # fmt: skip
    ap.add_argument("--json", help="write the time series (and the linear model's) here")
    ap.add_argument("--compare", help="a basilisk_modes.py --json file (or this script's own)")
    args = ap.parse_args(argv)
    if not (math.isfinite(args.thrust_scale) and args.thrust_scale > 0):
        ap.error(f"--thrust-scale must be positive, got {args.thrust_scale}")
    params = {**PARAMS, "thrust_n": PARAMS["thrust_n"] * args.thrust_scale}
    for dt in args.steps:
        if not step_divides(dt, params):
            ap.error(f"--steps {dt:g} does not divide the pulse edges and the 0.04 s output")

    out: dict = {
        "simulator": "rcsim-mujoco",
        "version": mujoco.__version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "integrator": "RK4 (MuJoCo), fixed step",
        "model": args.model,
        "params": params,
        "steps": {},
    }
    print(f"rcsim side on MuJoCo {mujoco.__version__}, Python {platform.python_version()}; RK4")
    for scenario in args.scenarios:
        modes = ", ".join(f"{f:.4f}" for f in coupled_modes_hz(scenario, params))
        print(f"{scenario}: free-vehicle mode frequency {modes} Hz (linear model)")
    print(f"{'step':>6} {'scenario':<8} {'wall s':>7} {'peak |w_z| rad/s':>17} {'peak |q|':>10}")
    for dt in args.steps:
        entry = {}
        for scenario in args.scenarios:
            series = fly_mujoco(scenario, dt, params, args.model)
            entry[scenario] = series
            wz = np.abs(np.array(series["omega_B_rad_s"])[:, 2]).max()
            print(
                f"{dt * 1e3:4g}ms {scenario:<8} {series['wall_s']:7.2f} {wz:17.3e} "
                f"{np.abs(series['q']).max():10.3e} {series['q_name']}",
                flush=True,
            )
        out["steps"][f"{dt:g}"] = entry
    out["linear"] = {s: fly_linear(s, params) for s in args.scenarios}
    print("\ncoupling (linear model): hub rate left after the last pulse, all of it the mode's")
    for scenario in args.scenarios:
        c = coupling(out["linear"][scenario], params)
        out["linear"][scenario]["coupling"] = c
        print(
            f"  {scenario}: peak |omega| {c['peak_rate_rad_s']:.3e} rad/s during the firing, "
            f"{c['peak_rate_after_firing_rad_s']:.3e} rad/s after "
            f"({c['peak_rate_after_firing_rad_s'] / c['peak_rate_rad_s']:.1%})"
        )
    if args.compare:
        theirs = json.loads(Path(args.compare).read_text())
        out["compare"] = compare(out, theirs, out["linear"])
    else:
        for scenario in args.scenarios:
            print(f"\n{scenario}: max |difference| over the flight / peak of the reference")
            print("| pair | hub rates | mode q | mode q' |\n|---|---|---|---|")
            for dt, entry in out["steps"].items():
                d = difference(entry[scenario], out["linear"][scenario])
                print(_row(f"rcsim {float(dt) * 1e3:g} ms vs linear", d))
    if args.json:
        Path(args.json).write_text(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
