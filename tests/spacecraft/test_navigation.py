"""Quaternion helpers, attitude-error sign convention and guidance (rcsim.spacecraft.navigation).

Oracles: quaternion algebra (Hamilton product, unit norm, q and -q the same rotation), the
closed forms of elementary rotations (a rotation by angle theta about unit axis n is
``[cos(theta/2), sin(theta/2) n]``; it maps x to y for +90 deg about z), the convention stated in
the module docstring (scalar-first, ``q_BN`` maps body vectors into N, error positive when the
body is rotated past the command) and MuJoCo's own free-body integration (its quaternion and
body-frame rate are what navigation reads).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from rcsim.spacecraft import navigation as nav
from rcsim.spacecraft.vehicle import build_model, load_vehicle

# Float round-trip tolerance: a few ulp of the angle through sin/cos/arctan2 (~1e-16 rad) for
# angles up to pi; 1e-12 rad is ~1e4 ulp, far below any convention error (>= the angle itself).
ROUND_TRIP_ATOL = 1e-12

rotvecs = arrays(np.float64, (3,), elements=st.floats(-1.7, 1.7, allow_nan=False))  # |v| < pi


def rotate(q, v):
    """Rotate vector v by unit quaternion q: q * [0, v] * q^-1 (independent of the module)."""
    w, x, y, z = q
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return r @ v


@settings(max_examples=200, deadline=None, derandomize=True)
@given(v=rotvecs)
def test_rotvec_quat_round_trip(v):
    q = nav.quat_from_rotvec(v)
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(nav.rotvec_from_quat(q), v, rtol=0, atol=ROUND_TRIP_ATOL)
    # q and -q are the same rotation.
    np.testing.assert_allclose(nav.rotvec_from_quat(-q), v, rtol=0, atol=ROUND_TRIP_ATOL)


@pytest.mark.parametrize("angle", [0.0, 1e-300, 1e-14, 1e-9, 1e-8, 1.0001e-8, 1e-6, 1e-3])
def test_small_angles_keep_relative_accuracy(angle):
    """Near identity the rotation vector keeps full relative precision (series branches)."""
    v = angle * np.array([0.6, -0.48, 0.64])  # unit axis
    q = nav.quat_from_rotvec(v)
    k = np.sin(angle / 2) / angle if angle > 0 else 0.5  # closed form of the vector part
    np.testing.assert_allclose(q[1:], k * v, rtol=1e-12, atol=0)
    assert q[0] == pytest.approx(np.cos(angle / 2), rel=1e-15)
    back = nav.rotvec_from_quat(q)
    np.testing.assert_allclose(back, v, rtol=1e-12, atol=0)


def test_elementary_rotation_closed_form():
    theta = np.radians(90.0)
    q = nav.quat_from_rotvec([0.0, 0.0, theta])
    np.testing.assert_allclose(q, [np.cos(theta / 2), 0, 0, np.sin(theta / 2)], atol=1e-16)
    # +90 deg about z maps body x to inertial y.
    np.testing.assert_allclose(rotate(q, [1.0, 0, 0]), [0, 1.0, 0], atol=1e-15)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(a=rotvecs, b=rotvecs, c=rotvecs)
def test_quat_mul_is_composition(a, b, c):
    qa, qb, qc = (nav.quat_from_rotvec(x) for x in (a, b, c))
    # Composition of rotations: rotate(a*b, v) == rotate(a, rotate(b, v)).
    v = np.array([0.3, -1.2, 0.7])
    np.testing.assert_allclose(
        rotate(nav.quat_mul(qa, qb), v), rotate(qa, rotate(qb, v)), atol=1e-12
    )
    # Associativity, and conj is the inverse.
    np.testing.assert_allclose(
        nav.quat_mul(nav.quat_mul(qa, qb), qc), nav.quat_mul(qa, nav.quat_mul(qb, qc)), atol=1e-14
    )
    np.testing.assert_allclose(nav.quat_mul(qa, nav.quat_conj(qa)), [1, 0, 0, 0], atol=1e-15)


def test_quat_mul_matches_mujoco():
    qa = nav.quat_from_rotvec([0.3, -0.2, 0.9])
    qb = nav.quat_from_rotvec([-1.1, 0.4, 0.2])
    ref = np.empty(4)
    mujoco.mju_mulQuat(ref, qa, qb)
    np.testing.assert_allclose(nav.quat_mul(qa, qb), ref, atol=1e-15)


def test_batched_shapes():
    v = np.random.default_rng(0).normal(size=(5, 7, 3))
    q = nav.quat_from_rotvec(v)
    assert q.shape == (5, 7, 4)
    assert nav.quat_mul(q, q).shape == (5, 7, 4)
    assert nav.rotvec_from_quat(q).shape == (5, 7, 3)
    assert nav.euler321_deg(q).shape == (5, 7, 3)


@pytest.mark.parametrize("axis", range(3))
def test_euler321_single_axis(axis):
    v = np.zeros(3)
    v[axis] = np.radians(30.0)
    expected = np.zeros(3)
    expected[axis] = 30.0
    np.testing.assert_allclose(nav.euler321_deg(nav.quat_from_rotvec(v)), expected, atol=1e-12)


def test_euler321_sequence_is_yaw_then_pitch_then_roll():
    yaw, pitch, roll = np.radians([40.0, -20.0, 10.0])
    q = nav.quat_mul(
        nav.quat_mul(nav.quat_from_rotvec([0, 0, yaw]), nav.quat_from_rotvec([0, pitch, 0])),
        nav.quat_from_rotvec([roll, 0, 0]),
    )
    np.testing.assert_allclose(nav.euler321_deg(q), [10.0, -20.0, 40.0], atol=1e-12)


# ---------------------------------------------------------------------------------------------
# Attitude error sign convention and guidance
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("axis", range(3))
def test_attitude_error_sign(axis):
    """Body short of a +5 deg command: error -5 deg; body past it (+7 deg): error +2 deg."""
    cmd = np.zeros((1, 3))
    cmd[0, axis] = np.radians(5.0)
    g = nav.Guidance.attitude(cmd)
    w = np.zeros((1, 3))
    at_rest = nav.navigate(0.0, np.array([[1.0, 0, 0, 0]]), w, g)
    np.testing.assert_allclose(at_rest.att_err_B, -cmd, atol=1e-15)
    past = cmd * 7.0 / 5.0
    state = nav.navigate(0.0, nav.quat_from_rotvec(past), w, g)
    np.testing.assert_allclose(state.att_err_B, past - cmd, atol=1e-15)


def test_attitude_error_is_body_relative_to_command():
    """Error = rotvec(q_cmd^-1 q): for a rotated command frame the error is about its axes."""
    q_cmd = nav.quat_from_rotvec(np.radians([0.0, 0.0, 90.0]))[None]
    g = nav.Guidance(q_cmd, np.zeros((1, 3)))
    # Body = command followed by +3 deg about the *body* x axis (right multiplication).
    q = nav.quat_mul(q_cmd, nav.quat_from_rotvec(np.radians([3.0, 0.0, 0.0]))[None])
    err = nav.navigate(0.0, q, np.zeros((1, 3)), g).att_err_B
    np.testing.assert_allclose(err, np.radians([[3.0, 0.0, 0.0]]), atol=1e-14)


def test_rate_error_is_rate_minus_command():
    g = nav.Guidance.rate(np.array([[0.01, -0.02, 0.0]]))
    s = nav.navigate(0.0, np.array([[1.0, 0, 0, 0]]), np.array([[0.015, -0.02, 0.003]]), g)
    np.testing.assert_allclose(s.rate_err_B, [[0.005, 0.0, 0.003]], atol=1e-17)


@settings(max_examples=50, deadline=None, derandomize=True)
@given(w=arrays(np.float64, (3,), elements=st.floats(-0.05, 0.05)), t=st.floats(0.0, 100.0))
def test_rate_guidance_attitude_follows_rate(w, t):
    """q_cmd(t) = exp(w t / 2) from identity; a body flying exactly that sees no error."""
    g = nav.Guidance.rate(w[None])
    q_cmd, w_cmd = g.at(t)
    np.testing.assert_allclose(q_cmd[0], nav.quat_from_rotvec(w * t), atol=1e-14)
    np.testing.assert_array_equal(w_cmd[0], w)
    s = nav.navigate(t, q_cmd, w[None], g)
    np.testing.assert_allclose(s.att_err_B, 0.0, atol=1e-12)
    np.testing.assert_allclose(s.rate_err_B, 0.0, atol=0)


def test_rate_guidance_matches_mujoco_free_body():
    """Navigation reads MuJoCo's state with the same conventions as Guidance.

    A torque-free body spinning about a principal axis keeps a constant body rate w; starting
    from a tilted attitude q0 its attitude is q0 * exp(w t / 2) (body-frame rate, right
    multiplication).  Guidance(q0, w) must then report ~zero error against MuJoCo's state;
    a left-multiplication or frame mix-up would give an error of order the 34 deg turned.
    """
    model = build_model(load_vehicle("paper"))
    d = mujoco.MjData(model)
    q0 = nav.quat_from_rotvec(np.radians([20.0, -35.0, 50.0]))
    w = np.array([0.0, 0.0, 0.03])  # about the principal z axis: w stays constant
    d.qpos[3:7] = q0
    d.qvel[3:6] = w
    t = 20.0
    for _ in range(int(round(t / model.opt.timestep))):
        mujoco.mj_step(model, d)
    g = nav.Guidance(q0[None], w[None])
    s = nav.navigate(d.time, d.qpos[None, 3:7].copy(), d.qvel[None, 3:6].copy(), g)
    # Angle turned 0.6 rad; RK4 + float error is ~1e-12 rad over 20 s; 1e-9 rad is 1e-3 arcsec.
    np.testing.assert_allclose(s.att_err_B, 0.0, atol=1e-9)
    np.testing.assert_allclose(s.rate_err_B, 0.0, atol=1e-15)
