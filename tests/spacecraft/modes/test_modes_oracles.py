"""Oracles of the modes' dynamics that are not the code under test: coupled frequencies
derived by hand (the linearised mass and stiffness matrices of each geometry, written out
below, solved with numpy) against the frequency of MuJoCo's free response of the flight model
(what every flight integrates); the whole vehicle's angular momentum about its CG conserved
over 600 s with the slosh masses and panels moving."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from rcsim.spacecraft.modes.definition import POINT_GYRATION_M
from rcsim.spacecraft.vehicle import Vehicle


def point_inertia(m: float, r) -> np.ndarray:
    """A point mass ``m`` at ``r`` about the origin, written out."""
    x, y, z = r
    return m * np.array(
        [
            [y * y + z * z, -x * y, -x * z],
            [-x * y, x * x + z * z, -y * z],
            [-x * z, -y * z, x * x + y * y],
        ]
    )


def whole_vehicle(hub_mass, hub_inertia, parts):
    """The whole vehicle's mass, CG and inertia about the CG from a hub whose CG is at the
    origin and ``parts`` ``(mass, position, own inertia (3, 3))``: composition by the
    parallel-axis theorem, the forward direction of what the reader undoes."""
    mass = hub_mass + sum(m for m, _, _ in parts)
    cg = sum(m * np.asarray(r, float) for m, r, _ in parts) / mass
    inertia = np.asarray(hub_inertia, float) + point_inertia(hub_mass, -cg)
    for m, r, own in parts:
        inertia = inertia + own + point_inertia(m, np.asarray(r, float) - cg)
    return mass, cg, inertia


def load(tmp_path, mass, cg, inertia, blocks: str, *, timestep_s: float) -> Vehicle:
    i = np.asarray(inertia, float).tolist()
    text = (
        "[mass]\n"
        f"mass_kg = {float(mass)!r}\n"
        f"cg_m = [{', '.join(repr(float(c)) for c in cg)}]\n"
        f"inertia_kg_m2 = [{i[0][0]!r}, {i[1][1]!r}, {i[2][2]!r}]\n"
        f"products_kg_m2 = [{i[0][1]!r}, {i[0][2]!r}, {i[1][2]!r}]\n"
        f"[physics]\ntimestep_s = {timestep_s!r}\n"
        "[[jet]]\nposition_m = [0.0, 0.0, 2.0]\ndirection = [0, 1, 0]\nthrust_n = 10.0\n" + blocks
    )
    path = tmp_path / "v.toml"
    path.write_text(text, encoding="utf-8")
    return Vehicle.load(path)


def free_response_hz(model: mujoco.MjModel, coordinate: int, start: float, seconds: float) -> float:
    """Frequency of MuJoCo's free response of mode ``coordinate`` (qpos index) released at
    ``start`` from rest: the mean spacing of its crossings of the mid-line (max + min) / 2,
    each located by linear interpolation between steps (at a crossing of a cosine the curve
    is straight to third order, so the interpolation error is O(dt^3))."""
    data = mujoco.MjData(model)
    data.qpos[coordinate] = start
    n = int(round(seconds / model.opt.timestep))
    q = np.empty(n + 1)
    q[0] = data.qpos[coordinate]
    for k in range(n):
        mujoco.mj_step(model, data)
        q[k + 1] = data.qpos[coordinate]
    x = q - (q.max() + q.min()) / 2
    idx = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    t = (idx + x[idx] / (x[idx] - x[idx + 1])) * model.opt.timestep
    return (len(t) - 1) / (2 * (t[-1] - t[0]))


def coupled_hz(mass_matrix, stiffness) -> float:
    """The one non-zero frequency of ``M q'' + K q = 0`` (numpy's eig of M^-1 K)."""
    w2 = np.linalg.eigvals(np.linalg.solve(mass_matrix, stiffness)).real
    return math.sqrt(w2.max()) / (2 * math.pi)


# Tolerance of a measured frequency: 1e-6 relative (measured 7e-9 to 7e-8).  The response is
# integrated by RK4 at 10 ms (omega dt <= 0.05: its phase error, (omega dt)^4 / 120 relative,
# is ~5e-8), the crossings interpolated to O(dt^3) and averaged over ~50 periods (~1e-8), and
# the amplitude (1 mm, 1 mrad) keeps the terms the linearisation drops at ~1e-7.
RTOL = 1e-6
DT = 0.01


def test_spring_mass_through_the_cg_coupled_frequency(tmp_path):
    """Free-free two-body: omega^2 = k (1/m_s + 1/m_hub) for a slide along a line through the
    CG (no rotation)."""
    m_hub, m_s, f_clamped = 400.0, 25.0, 0.6
    hub_i = np.diag([120.0, 150.0, 130.0])
    pos = (0.0, 0.0, 0.0)
    own = m_s * POINT_GYRATION_M**2 * np.eye(3)
    mass, cg, inertia = whole_vehicle(m_hub, hub_i, [(m_s, pos, own)])
    blocks = (
        '[[slosh]]\nname = "s"\nmodel = "spring"\n'
        f"mass_kg = {m_s}\nposition_m = [0.0, 0.0, 0.0]\ndirection = [1, 0, 0]\n"
        f"frequency_hz = {f_clamped}\ndamping_ratio = 0.0\n"
    )
    v = load(tmp_path, mass, cg, inertia, blocks, timestep_s=DT)
    k = m_s * (2 * math.pi * f_clamped) ** 2
    expected = math.sqrt(k * (1 / m_s + 1 / m_hub)) / (2 * math.pi)
    measured = free_response_hz(v.flight_model, 7, 1e-3, 80.0)
    assert measured == pytest.approx(expected, rel=RTOL)


def test_spring_mass_off_the_cg_couples_rotation(tmp_path):
    """A slide along y at x = d from the hub's CG turns the hub about z.  Coordinates (hub y,
    hub angle about z, slide s); the mass moves by y + d theta + s:

        T = 1/2 M y'^2 + 1/2 (J + m g^2) theta'^2 + 1/2 m (y' + d theta' + s')^2,  V = 1/2 k s^2

    (g: the point mass's radius of gyration, POINT_GYRATION_M, turning with the hub)."""
    m_hub, m_s, d, f_clamped = 400.0, 25.0, 1.2, 0.5
    hub_i = np.diag([120.0, 150.0, 130.0])
    own = m_s * POINT_GYRATION_M**2 * np.eye(3)
    mass, cg, inertia = whole_vehicle(m_hub, hub_i, [(m_s, (d, 0.0, 0.0), own)])
    blocks = (
        '[[slosh]]\nname = "s"\nmodel = "spring"\n'
        f"mass_kg = {m_s}\nposition_m = [{d}, 0.0, 0.0]\ndirection = [0, 1, 0]\n"
        f"frequency_hz = {f_clamped}\ndamping_ratio = 0.0\n"
    )
    v = load(tmp_path, mass, cg, inertia, blocks, timestep_s=DT)
    k = m_s * (2 * math.pi * f_clamped) ** 2
    j = hub_i[2, 2] + m_s * POINT_GYRATION_M**2
    mass_matrix = np.array(
        [
            [m_hub + m_s, m_s * d, m_s],
            [m_s * d, j + m_s * d * d, m_s * d],
            [m_s, m_s * d, m_s],
        ]
    )
    expected = coupled_hz(mass_matrix, np.diag([0.0, 0.0, k]))
    # rotation makes it differ from the through-the-CG formula by far more than the tolerance
    assert expected / (math.sqrt(k * (1 / m_s + 1 / m_hub)) / (2 * math.pi)) - 1 > 100 * RTOL
    measured = free_response_hz(v.flight_model, 7, 1e-3, 80.0)
    assert measured == pytest.approx(expected, rel=RTOL)


def test_panel_on_the_hub_axis_coupled_frequency(tmp_path):
    """A panel hinged on a line through the hub's CG, its CG on the hinge line: hub and panel
    turn against each other about the axis, omega^2 = k (1/I_p + 1/J), so
    f_coupled = f_clamped sqrt(I_total / I_hub) with I_total = J + I_p about the axis."""
    m_hub, m_p, f_clamped = 400.0, 20.0, 0.5
    hub_i = np.diag([120.0, 150.0, 130.0])
    panel_i = np.diag([5.0, 4.5, 9.0])  # about its CG; 9 kg m^2 about the z hinge
    mass, cg, inertia = whole_vehicle(m_hub, hub_i, [(m_p, (0.0, 0.0, 0.0), panel_i)])
    blocks = (
        '[[appendage]]\nname = "p"\n'
        f"mass_kg = {m_p}\ninertia_kg_m2 = [5.0, 4.5, 9.0]\nhinge_m = [0.0, 0.0, 0.0]\n"
        f"axis = [0, 0, 1]\ncg_offset_m = [0.0, 0.0, 0.0]\nfrequency_hz = {f_clamped}\n"
        "damping_ratio = 0.0\n"
    )
    v = load(tmp_path, mass, cg, inertia, blocks, timestep_s=DT)
    expected = f_clamped * math.sqrt((hub_i[2, 2] + panel_i[2, 2]) / hub_i[2, 2])
    measured = free_response_hz(v.flight_model, 7, 1e-3, 100.0)
    assert measured == pytest.approx(expected, rel=RTOL)


def test_offset_panel_coupled_frequency(tmp_path):
    """A panel hinged at x = h from the hub's CG about z, its CG a further rho along x.
    Coordinates (hub y, hub angle theta, hinge angle phi); the panel's CG moves by
    y + (h + rho) theta + rho phi and turns by theta + phi:

        T = 1/2 M y'^2 + 1/2 J theta'^2 + 1/2 m (y' + a theta' + rho phi')^2
            + 1/2 I_p (theta' + phi')^2,    a = h + rho,   V = 1/2 k phi^2

    with k = (I_p + m rho^2) (2 pi f_clamped)^2 (the hinge inertia's clamped frequency)."""
    m_hub, m_p, h, rho, f_clamped = 400.0, 20.0, 0.8, 1.5, 0.5
    hub_i = np.diag([120.0, 150.0, 130.0])
    panel_i = np.diag([1.0, 2.0, 3.0])
    mass, cg, inertia = whole_vehicle(m_hub, hub_i, [(m_p, (h + rho, 0.0, 0.0), panel_i)])
    blocks = (
        '[[appendage]]\nname = "p"\n'
        f"mass_kg = {m_p}\ninertia_kg_m2 = [1.0, 2.0, 3.0]\nhinge_m = [{h}, 0.0, 0.0]\n"
        f"axis = [0, 0, 1]\ncg_offset_m = [{rho}, 0.0, 0.0]\nfrequency_hz = {f_clamped}\n"
        "damping_ratio = 0.0\n"
    )
    v = load(tmp_path, mass, cg, inertia, blocks, timestep_s=DT)
    ip, j, a = panel_i[2, 2], hub_i[2, 2], h + rho
    k = (ip + m_p * rho**2) * (2 * math.pi * f_clamped) ** 2
    mass_matrix = np.array(
        [
            [m_hub + m_p, m_p * a, m_p * rho],
            [m_p * a, j + m_p * a * a + ip, m_p * a * rho + ip],
            [m_p * rho, m_p * a * rho + ip, m_p * rho * rho + ip],
        ]
    )
    expected = coupled_hz(mass_matrix, np.diag([0.0, 0.0, k]))
    measured = free_response_hz(v.flight_model, 7, 1e-3, 100.0)
    assert measured == pytest.approx(expected, rel=RTOL)


def system_angular_momentum(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The whole vehicle's angular momentum about its CG in N, (3,): sum over bodies of
    R I R' w + m (x - c) x (v - v_c), each body's velocity at its own CG from MuJoCo's
    kinematics (mj_objectVelocity), the sum written here."""
    mujoco.mj_forward(model, data)
    masses = model.body_mass[1:]
    c = (masses[:, None] * data.xipos[1:]).sum(axis=0) / masses.sum()
    vel = np.zeros((model.nbody, 6))
    for b in range(1, model.nbody):
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, b, vel[b], 0)
    v_c = (masses[:, None] * vel[1:, 3:]).sum(axis=0) / masses.sum()
    total = np.zeros(3)
    for b in range(1, model.nbody):
        rot = data.ximat[b].reshape(3, 3)
        total += rot @ np.diag(model.body_inertia[b]) @ rot.T @ vel[b, :3]
        total += model.body_mass[b] * np.cross(data.xipos[b] - c, vel[b, 3:] - v_c)
    return total


@pytest.mark.parametrize("damping", [0.005, 0.0])
def test_angular_momentum_conserved_over_600_s(damping):
    """canted16_modes (two lateral slosh modes, two wings) tumbling with every mode excited,
    no jet: the angular momentum about the system CG stays within 1e-9 relative over 600 s
    with RK4 at 20 ms (measured 3.1e-11 damped, 2.1e-10 undamped; at canted16's own 40 ms
    step 1.7e-9 and 7.0e-9: the 20 ms step is the claim)."""
    from pathlib import Path

    text = Path("docs/examples/canted16_modes.toml").read_text(encoding="utf-8")
    text = text.replace("damping_ratio = 0.005", f"damping_ratio = {damping}")
    v = Vehicle.load(_write(text)).with_physics(timestep_s=0.02, integrator="RK4")
    model = v.flight_model
    data = mujoco.MjData(model)
    data.qvel[0:3] = [0.01, 0.0, 0.0]
    data.qvel[3:6] = np.radians([0.5, -0.3, 0.4])
    data.qpos[7:] = [0.05, -0.03, 0.1, -0.05]
    before = system_angular_momentum(model, data)
    for _ in range(int(round(600 / model.opt.timestep))):
        mujoco.mj_step(model, data)
    after = system_angular_momentum(model, data)
    assert np.linalg.norm(after - before) / np.linalg.norm(before) < 1e-9


def _write(text: str):
    import tempfile
    from pathlib import Path

    path = Path(tempfile.mkdtemp()) / "canted16_modes.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_pendulum_swings_at_sqrt_of_thrust_over_hub_mass_and_length(tmp_path):
    """A pendulum hung from the hub's CG, the hub pushed by a constant force F along the rod
    (the flight model's force_x): in the CG's frame the lateral momentum is zero, so with
    mu = M m / (M + m) and a = F / (M + m),

        T = 1/2 (mu L^2 + m g^2) phi'^2,   V = 1/2 m a L phi^2
        omega^2 = m a L / (mu L^2 + m g^2)   (= F / (M L) for g -> 0)

    (g: the bob's radius of gyration, POINT_GYRATION_M; the pivot force passes through the
    hub's CG and turns nothing).  Coasting it has no restoring force: no frequency."""
    m_hub, m_s, length, force = 400.0, 25.0, 0.5, 710.0
    hub_i = np.diag([120.0, 150.0, 130.0])
    own = m_s * POINT_GYRATION_M**2 * np.eye(3)
    mass, cg, inertia = whole_vehicle(m_hub, hub_i, [(m_s, (-length, 0.0, 0.0), own)])
    blocks = (
        '[[slosh]]\nname = "p"\nmodel = "pendulum"\n'
        f"mass_kg = {m_s}\npivot_m = [0.0, 0.0, 0.0]\ndirection = [-1, 0, 0]\n"
        f"length_m = {length}\n"
    )
    v = load(tmp_path, mass, cg, inertia, blocks, timestep_s=DT)
    model = v.flight_model
    mu = m_hub * m_s / (m_hub + m_s)
    a = force / (m_hub + m_s)
    expected = math.sqrt(m_s * a * length / (mu * length**2 + m_s * POINT_GYRATION_M**2))
    expected /= 2 * math.pi
    thrust = model.actuator("force_x").id
    data = mujoco.MjData(model)
    data.qpos[7] = 1e-3
    data.ctrl[thrust] = force
    n = int(round(60.0 / model.opt.timestep))
    q = np.empty(n + 1)
    q[0] = data.qpos[7]
    for k in range(n):
        mujoco.mj_step(model, data)
        q[k + 1] = data.qpos[7]
    x = q - (q.max() + q.min()) / 2
    i = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    t = (i + x[i] / (x[i] - x[i + 1])) * model.opt.timestep
    measured = (len(t) - 1) / (2 * (t[-1] - t[0]))
    assert measured == pytest.approx(expected, rel=RTOL)
