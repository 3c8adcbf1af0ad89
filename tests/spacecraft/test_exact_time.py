"""Exact in time: each cycle integrated in pieces at the jets' switch instants
(rcsim.spacecraft.pieces).

Oracles
-------
* Rigid-body mechanics about one principal axis (no gyroscopic term): a firing pair of angular
  acceleration ``alpha`` on over ``[a, b]`` from rest gives ``w(t) = alpha (clip(t, a, b) - a)``
  and the rotation angle ``theta(t) = alpha/2 (clip(t,a,b) - a)^2 + alpha (b - a)(t - b)^+``.
  Both are polynomials of degree <= 2 in every piece, which RK4 integrates exactly, so the
  simulation must match them to float rounding (1e-9 relative is far above rounding and far
  below the ``alpha t (T - t) / 2`` attitude error of a pulse spread over a 40 ms step: 0.3 to
  50 % of the angle for the pulses below).  ``alpha = sum of the pair's torques / I``, torques
  from the MJCF geometry (:func:`torque_per_jet_B`).
* Three axes at once (gyroscopic coupling): SciPy DOP853 at rtol 1e-12 on Euler's equations and
  the quaternion kinematics, integrated between the exact switch instants.
* A cycle with no switch inside must be the plain fixed-step rollout, bit for bit.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from mujoco.batch import Batch
from scipy.integrate import solve_ivp

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.tables import PAPER_CYCLE_S, load_jet_map
from rcsim.spacecraft.flight_model import flight_model, jet_wrench_B
from rcsim.spacecraft.navigation import Guidance, quat_conj, quat_mul, rotvec_from_quat
from rcsim.spacecraft.pieces import cycle_pieces
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle.run_parameters import torque_per_jet_B

CYCLE_S = 0.04
REL = 1e-9  # see the module docstring


def roll_plus_jets():
    return np.flatnonzero(load_jet_map()[:, 0] == 1)


def roll_alpha(paper):
    params = paper.nominal(1)
    tau = torque_per_jet_B(params, paper.model)[0, roll_plus_jets(), 0].sum()
    return tau / params.inertia_B[0, 0]


def roll_angle(q):
    return 2.0 * np.arctan2(q[..., 1], q[..., 0])


def boundaries_q(hist):
    return np.concatenate([hist.q_BN, hist.final.q_BN[:, None]], axis=1)


PULSES_S = np.array([0.0012, 0.017, 0.0233, 0.04, 0.0433, 0.1234, 0.52])


def test_single_axis_pulses_are_exact_in_attitude_and_rate(paper):
    """Seven pulse lengths in one batch, each run cut at its own switch instant."""
    n = PULSES_S.size
    on = np.zeros((n, 16))
    on[:, roll_plus_jets()] = PULSES_S[:, None]
    hist = BatchSimulation(paper.nominal(n), vehicle=paper, nthread=1).run(
        OpenLoopController(on, PAPER_CYCLE_S), Guidance.attitude(np.zeros((n, 3))), 0.72
    )
    alpha = roll_alpha(paper)
    t = np.arange(hist.t_s.size + 1) * CYCLE_S
    u = PULSES_S[:, None]
    tc = np.minimum(t[None], u)
    theta = 0.5 * alpha * tc**2 + alpha * u * np.maximum(t[None] - u, 0.0)
    np.testing.assert_allclose(
        roll_angle(boundaries_q(hist)), theta, rtol=REL, atol=REL * np.abs(theta).max()
    )
    w = np.concatenate([hist.omega_B[:, :, 0], hist.final.omega_B[:, None, 0]], axis=1)
    np.testing.assert_allclose(w, alpha * tc, rtol=REL, atol=REL * alpha * u.max())


def _reference(paper, on_total, duration_s):
    """DOP853 between the exact switch instants: attitude at every cycle boundary."""
    params = paper.nominal(1)
    tau_j = torque_per_jet_B(params, paper.model)[0]
    inertia = params.inertia_B[0]
    x = np.array([1.0, 0, 0, 0, 0, 0, 0])
    out = [x[:4]]
    n_cycles = int(round(duration_s / CYCLE_S))
    for k in range(n_cycles):
        on = np.clip(on_total - k * CYCLE_S, 0.0, CYCLE_S)
        cuts = np.unique(np.concatenate([[0.0, CYCLE_S], on[(on > 0) & (on < CYCLE_S)]]))
        for a, b in zip(cuts[:-1], cuts[1:]):
            torque = tau_j[on > 0.5 * (a + b)].sum(axis=0)

            def rhs(_, s, torque=torque):
                w = s[4:]
                dq = 0.5 * quat_mul(s[:4], np.concatenate([[0.0], w]))
                return np.concatenate([dq, (torque - np.cross(w, inertia * w)) / inertia])

            x = solve_ivp(rhs, (a, b), x, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
        out.append(x[:4] / np.linalg.norm(x[:4]))
    return np.array(out)


def test_three_axis_pulses_with_distinct_switch_times_match_dop853(paper):
    """Roll, pitch and yaw pairs switching off at three different instants of one cycle."""
    jm = load_jet_map()
    on = np.zeros(16)
    for a, t in enumerate((0.011, 0.0634, 0.029)):
        on[jm[:, a] == (1 if a != 1 else -1)] = t
    hist = BatchSimulation(paper.nominal(1), vehicle=paper, nthread=1).run(
        OpenLoopController(on[None], PAPER_CYCLE_S), Guidance.attitude(np.zeros((1, 3))), 0.2
    )
    ref = _reference(paper, on, 0.2)
    dev = np.linalg.norm(rotvec_from_quat(quat_mul(quat_conj(ref), boundaries_q(hist)[0])), axis=1)
    # 1e-10 rad: DOP853 at rtol 1e-12 and RK4 on 11-40 ms pieces at these rates (<0.01 rad/s)
    # agree to ~1e-13 rad; a pulse spread over the cycle would be ~1e-6 rad off.
    assert dev.max() < 1e-10


def test_whole_cycle_firings_are_the_fixed_step_rollout_bit_for_bit(paper):
    """No switch inside a cycle: exactly the steps of a plain rollout of the flight model
    (jets 1 or 0, summed into its wrench controls the way the simulation sums them; that sum
    itself is checked against the jets' MJCF in tests/spacecraft/test_flight_model.py)."""
    on = np.zeros((1, 16))
    on[0, roll_plus_jets()] = 3 * CYCLE_S
    params = paper.nominal(1)
    hist = BatchSimulation(params, vehicle=paper, nthread=1).run(
        OpenLoopController(on, PAPER_CYCLE_S), Guidance.attitude(np.zeros((1, 3))), 5 * CYCLE_S
    )
    batch = Batch(flight_model(paper.model), 1, 1)
    batch.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
    batch.forward()
    duty = np.zeros((1, 5, 16))
    duty[0, :3, roll_plus_jets()] = 1.0
    ctrl = np.einsum("nwj,nsj->nsw", jet_wrench_B(params, paper.model), duty)
    batch.rollout(5, control=ctrl, control_spec=int(mujoco.mjtState.mjSTATE_CTRL), record=())
    np.testing.assert_array_equal(hist.final.q_BN[0], batch.bind("qpos")[0, 3:7])
    np.testing.assert_array_equal(hist.final.omega_B[0], batch.bind("qvel")[0, 3:6])


def test_pieces_cut_at_every_switch_and_cover_the_union():
    """Overlapping intervals: on-time is the union's length; pieces end at every bound."""
    start = np.array([[[0.0, 0.01, np.nan]]])  # one run, one jet, three slots
    end = np.array([[[0.015, 0.03, np.nan]]])
    p = cycle_pieces(start, end, CYCLE_S)
    # Bounds 0, 10, 15, 30, 40 ms: four pieces, on in the first three.
    np.testing.assert_allclose(p.length_s[0], [0.01, 0.005, 0.015, 0.01], atol=1e-17)
    np.testing.assert_array_equal(p.on[0, :, 0], [True, True, True, False])
    assert p.on_time_s()[0, 0] == pytest.approx(0.03, abs=1e-17)
    assert p.length_s.sum() == pytest.approx(CYCLE_S, abs=1e-17)


def test_pieces_keep_the_physics_grid():
    """With a 10 ms physics step, a switch at 17 ms makes pieces 10, 7, 3, 10, 10 ms."""
    p = cycle_pieces(np.zeros((1, 1, 1)), np.full((1, 1, 1), 0.017), CYCLE_S, dt_s=0.01)
    np.testing.assert_allclose(p.length_s[0], [0.01, 0.007, 0.003, 0.01, 0.01], atol=1e-17)
    np.testing.assert_array_equal(p.on[0, :, 0], [True, True, False, False, False])


@pytest.mark.parametrize("shape", [(7, 16, 0), (7, 16, 1), (512, 16, 3), (5, 4, 16, 3)])
def test_any_last_is_numpys_any_over_the_last_axis(shape):
    """The cutting's fast ``any`` over a jet's few intervals (oracle: ``ndarray.any``)."""
    from rcsim.spacecraft.pieces import any_last

    a = np.random.default_rng(len(shape)).random(shape) < 0.1
    out = any_last(a)
    assert out.dtype == bool and out.shape == shape[:-1]
    assert np.array_equal(out, a.any(axis=-1))
