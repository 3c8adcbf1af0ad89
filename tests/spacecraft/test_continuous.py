"""Continuous-torque plant of the DAI papers: MuJoCo rigid body, CMGs, disturbances.

Oracles are stated per test: Euler's equations integrated by SciPy DOP853, angular-momentum
conservation, the CMG Jacobian's definition and 002 Eq. (7), the 1976 standard atmosphere.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rcsim.models.dai import Damage, load_cmg, load_environment
from rcsim.spacecraft.continuous.cmg import CmgArray, CmgState, determinant, jacobian, unit_momenta
from rcsim.spacecraft.continuous.disturbances import (
    Disturbances,
    density_kg_m3,
    thermosphere_temperature_k,
)
from rcsim.spacecraft.continuous.kinematics import dcm_NB
from rcsim.spacecraft.continuous.plant import ContinuousPlant, fly

J002 = np.full((3, 3), 0.1) + 9.9 * np.eye(3)  # 002 Sec. 3: off-diagonal inertia


def _euler_reference(j, omega0, torque, t_end):
    """Body rate after t_end under a constant body torque: Euler's equations, DOP853."""
    j_inv = np.linalg.inv(j)
    rhs = lambda t, w: j_inv @ (torque - np.cross(w, j @ w))  # noqa: E731
    return solve_ivp(rhs, (0, t_end), omega0, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]


@pytest.mark.parametrize("dt", [0.01, 0.001])
def test_rigid_body_matches_euler_equations(dt):
    # Tumbling with a constant torque, off-diagonal J: MuJoCo RK4 vs DOP853 at rtol 1e-13.
    # Tolerance 1e-10 rad/s: RK4's global error at 0.01 s over 5 s here is ~1e-12.
    omega0, torque = np.array([0.03, 0.02, -0.04]), np.array([0.01, -0.02, 0.015])
    plant = ContinuousPlant(J002[None], timestep_s=dt)
    plant.reset(omega0_B=omega0[None])
    plant.step(torque[None], int(round(5.0 / dt)))
    np.testing.assert_allclose(
        plant.omega_B[0], _euler_reference(J002, omega0, torque, 5.0), atol=1e-10
    )


def test_angular_momentum_conserved_batched():
    # Torque-free: inertial H = R J w constant.  1e-12 relative over 20 s (RK4 at 0.01 s
    # keeps it to ~1e-15, docs/convergence.md's standard is 1e-9 over 600 s).
    inertia = np.stack([J002, np.diag([30.0, 60.0, 90.0])])
    plant = ContinuousPlant(inertia, timestep_s=0.01)
    plant.reset(omega0_B=np.tile([0.03, 0.02, -0.04], (2, 1)))
    h = lambda: np.einsum("nij,njk,nk->ni", dcm_NB(plant.q_BN), inertia, plant.omega_B)  # noqa
    h0 = h()
    plant.step(np.zeros((2, 3)), 2000)
    assert np.abs(h() - h0).max() / np.abs(h0).max() < 1e-12


def test_cmg_jacobian_is_derivative_of_momenta():
    # A = dh/dtheta by definition (002 Eq. 3); central differences, step 1e-6: error ~1e-12.
    rng = np.random.default_rng(1)
    theta, beta = rng.uniform(-3, 3, 3), rng.uniform(0.2, 1.5, 3)
    numeric = np.empty((3, 3))
    for i in range(3):
        step = np.zeros(3)
        step[i] = 1e-6
        diff = unit_momenta(theta + step, beta) - unit_momenta(theta - step, beta)
        numeric[:, i] = diff[:, i] / 2e-6
    np.testing.assert_allclose(jacobian(theta, beta), numeric, atol=1e-9)


def test_cmg_determinant_closed_form_and_singular_example():
    # beta = 90 deg: det A = -sin(theta2) sin(theta1 + theta3) (Eq. 7 specialised, cofactor
    # expansion of Eq. 3); 002 Sec. 2.2's example theta = 0 is singular.
    beta = np.full(3, math.pi / 2)
    rng = np.random.default_rng(2)
    theta = rng.uniform(-3, 3, (50, 3))
    np.testing.assert_allclose(
        determinant(theta, beta),
        -np.sin(theta[:, 1]) * np.sin(theta[:, 0] + theta[:, 2]),
        atol=1e-14,
    )
    assert determinant(np.zeros(3), beta) == pytest.approx(0.0, abs=1e-15)


def test_cmg_torque_equals_command_away_from_singularities():
    # Full-rank A: A A^+ = I, so the delivered torque equals the command (1e-9 N m: round-off
    # of the pseudo-inverse at |det A| >= 0.2).
    cmg = CmgArray(load_cmg())
    rng = np.random.default_rng(3)
    theta = rng.uniform(-3, 3, (400, 3))
    keep = np.abs(determinant(theta, cmg.setup.skew_rad)) > 0.2
    theta = theta[keep]
    u, omega = rng.normal(0, 2, (len(theta), 3)), rng.normal(0, 0.1, (len(theta), 3))
    out, _ = cmg.steer(u, omega, CmgState(theta), 0.01)
    assert not out.singular.any()
    np.testing.assert_allclose(out.torque_B, u, atol=1e-9)


def test_cmg_singular_set_flagged_with_finite_rates():
    cmg = CmgArray(load_cmg())
    singular = np.array(
        [
            [0.0, 0.0, 0.0],  # 002's example
            [0.3, 0.0, -1.0],  # sin(theta2) = 0
            [0.4, 1.0, -0.4],
        ]
    )  # sin(theta1 + theta3) = 0
    regular = np.full((1, 3), -math.pi / 6)  # 001 App. C initial gimbals: det = -0.433
    theta = np.vstack([singular, regular])
    out, nxt = cmg.steer(np.tile([0.5, -0.3, 1.0], (4, 1)), np.zeros((4, 3)), CmgState(theta), 0.01)
    np.testing.assert_array_equal(out.singular, [True, True, True, False])
    assert out.det[3] == pytest.approx(-math.sin(-math.pi / 6) * math.sin(-math.pi / 3))
    assert np.isfinite(out.gimbal_rate).all() and np.isfinite(nxt.theta).all()


def test_atmosphere_at_150_km():
    env = load_environment()
    # U.S. Standard Atmosphere 1976 at 150 km: T = 634.39 K, rho = 2.0752e-9 kg/m^3.
    # App. C's temperature formula is the standard's (tolerance 0.05 K: its Re = 6378 km
    # differs from the standard's 6356.766 km in xi); density to 0.1 %.
    assert thermosphere_temperature_k(env, 150e3) == pytest.approx(634.39, abs=0.05)
    assert density_kg_m3(env) == pytest.approx(2.0752e-9, rel=1e-3)


def test_disturbance_torques_against_hand_formulas():
    env = load_environment()
    inertia = np.diag([30.0, 60.0, 90.0])[None]
    w0 = env.mean_motion_rad_s
    # Gravity gradient, 3 w0^2 r x J r: nadir along a principal axis -> zero; yawed 45 deg
    # about x (roll), r_B = (0, s, -c)/..., |T_x| = 3 w0^2 (Jzz - Jyy) / 2.
    gg = Disturbances(env, gravity_gradient=True, aero_drag=False)
    assert np.abs(gg.torque_B(0.0, np.array([[1.0, 0, 0, 0]]), inertia)).max() < 1e-18
    q45 = np.array([[math.cos(math.pi / 8), math.sin(math.pi / 8), 0, 0]])
    assert abs(gg.torque_B(0.0, q45, inertia)[0, 0]) == pytest.approx(3 * w0**2 * 30 / 2, rel=1e-12)
    # Drag at t = 0, identity attitude: v_B = +x, A_p = A_x = 1 m^2,
    # F = -1/2 rho V^2 Cd A_x x, T = d_cp x F.
    dr = Disturbances(env, gravity_gradient=False, aero_drag=True)
    force = -0.5 * density_kg_m3(env) * env.speed_m_s**2 * env.cd * 1.0 * np.array([1, 0, 0])
    np.testing.assert_allclose(
        dr.torque_B(0.0, np.array([[1.0, 0, 0, 0]]), inertia)[0],
        np.cross(env.cp_cg_B, force),
        rtol=1e-12,
    )


class _Hold:
    """Constant-torque controller (test double)."""

    def initial_state(self, n):
        return None

    def step(self, t, euler, state):
        return np.tile([0.0, 0.0, 1.0], (euler.shape[0], 1)), state


def test_damage_changes_inertia_at_its_time():
    # 001 App. A.2: diagonal x (0.7, 0.3, 0.65) at t = 8 s.  Yaw torque 1 N m about the
    # principal z axis: w_z = t / 90 before, + (t - t_d) / 58.5 after (exact for RK4, linear).
    plant = ContinuousPlant(np.diag([30.0, 60.0, 90.0])[None], timestep_s=0.01)
    hist = fly(plant, _Hold(), 1.0, damage=Damage(time_s=0.5, factors=np.array([0.7, 0.3, 0.65])))
    np.testing.assert_allclose(np.diag(plant.inertia_B[0]), [21.0, 18.0, 58.5])
    np.testing.assert_allclose(plant.omega_B[0, 2], 0.5 / 90 + 0.5 / 58.5, rtol=1e-10)
    np.testing.assert_allclose(hist.omega_B[0, 50, 2], 0.5 / 90, rtol=1e-10)


def test_a_diverging_run_leaves_no_mujoco_log_in_the_working_directory(tmp_path, monkeypatch):
    """MuJoCo's warning on a blown-up state goes to the rcsim.mujoco logger, never to a
    MUJOCO_LOG.TXT in the user's directory (as for the RCS vehicle)."""
    import mujoco

    monkeypatch.chdir(tmp_path)
    before = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(None)  # as in a fresh process (another test may have set it)
    try:
        plant = ContinuousPlant(np.diag([30.0, 60.0, 90.0])[None], timestep_s=0.01)
        plant.reset(None, None)
        for _ in range(3):
            plant.step(np.full((1, 3), 1e300))
        assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    finally:
        mujoco.set_mju_user_warning(before)
