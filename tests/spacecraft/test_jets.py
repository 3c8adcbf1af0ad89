"""Jet geometry and pulses: torque signs (Table 2), pure couples, translation jets, exact impulse.

Oracles
-------
* Gambone Table 2 (``rcsim.models.tables.load_jet_map``): the sign of each jet's torque about roll,
  pitch, yaw; jets 5-8 are not used for rotation.
* Gambone Table 1 (``load_mass_properties``): thrust F, mass m, inertias I.
* The design moment arms of ``rcsim/models/vehicle/README.md`` (roll 0.812 m, pitch 0.776 m, yaw
  0.724 m), which reproduce Table 6's pure-axis firing times (0.52, 0.48, 0.40 s).
* Rigid-body mechanics: a firing pair from rest spins the body about one principal axis, where
  Euler's equations reduce to ``I dw/dt = 2 F r`` (no gyroscopic term), so
  ``dw = 2 F r t / I`` exactly; a single jet gives ``dv_CG = F t / m`` (Newton).

Measurements come from MuJoCo itself (``mj_step`` on the packaged model at its default physics
step, or the production closed loop :class:`rcsim.spacecraft.simulation.BatchSimulation`), not from
the geometry helpers alone.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.tables import PAPER_CYCLE_S, load_jet_map, load_lookup_table
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle.model import BODY, jet_actuator_ids, jet_geometry_B
from rcsim.spacecraft.vehicle.run_parameters import torque_per_jet_B

ARM_M = np.array([0.812, 0.776, 0.724])  # design arms roll, pitch, yaw (README)
CYCLE_S = 0.040  # paper section II: 40 ms control rate
TRANSLATION_JETS = [4, 5, 6, 7]  # 0-based rows of jets 5..8 (Table 2: all zero)
# The accuracy target for any pulse's rate change.  With exact per-step duty the error is
# float rounding (~1e-15) at any step; a switch-off sampled at physics steps instead is 4-16 %
# off (docs/engine_facts.md), so 1e-6 separates the two by orders of magnitude either way.
PULSE_RTOL = 1e-6
# "Zero" for quantities that vanish in exact arithmetic (cross-axis rate, CG velocity of a
# couple, rotation from a jet through the CG): relative to the same pulse's main effect, 1e-9
# is far above float rounding (1e-16 .. 1e-13) and far below any geometric error (a 1 mm arm
# offset would give ~1e-3).
ZERO_RTOL = 1e-9


@pytest.fixture(scope="module")
def jet_map() -> np.ndarray:
    return load_jet_map()


def pairs(jet_map):
    """(axis, sign, jet indices) of the 6 rotational pairs: the jets that fire together."""
    out = []
    for a in range(3):
        for s in (-1, +1):
            jets = np.flatnonzero(jet_map[:, a] == s)
            assert len(jets) == 2, (a, s, jets)
            out.append((a, s, jets))
    return out


def fire(paper, jets, duration_s: float):
    """Fire ``jets`` (0-based) from rest at full duty for ``duration_s`` (a multiple of the step).

    Returns body-rate change (B frame) [rad/s], CG velocity change (world) [m/s], attitude q.
    """
    d = mujoco.MjData(paper.model)
    mujoco.mj_forward(paper.model, d)
    body = paper.model.body(BODY).id
    mujoco.mj_subtreeVel(paper.model, d)
    v0 = d.subtree_linvel[body].copy()
    ids = jet_actuator_ids(paper.model)[list(jets)]
    n = duration_s / paper.model.opt.timestep
    assert abs(n - round(n)) < 1e-9
    d.ctrl[ids] = 1.0
    for _ in range(int(round(n))):
        mujoco.mj_step(paper.model, d)
    d.ctrl[:] = 0.0
    mujoco.mj_forward(paper.model, d)
    mujoco.mj_subtreeVel(paper.model, d)
    return d.qvel[3:6].copy(), d.subtree_linvel[body] - v0, d.qpos[3:7].copy()


# ---------------------------------------------------------------------------------------------
# Geometry (torque_per_jet_B on the nominal vehicle)
# ---------------------------------------------------------------------------------------------
def test_torque_signs_match_table2(paper, jet_map):
    tau = torque_per_jet_B(paper.nominal(1), paper.model)[0]
    scale = np.abs(tau).max()
    sign = np.where(np.abs(tau) > ZERO_RTOL * scale, np.sign(tau), 0).astype(int)
    np.testing.assert_array_equal(sign, jet_map)


def test_rotation_jet_torque_is_thrust_times_design_arm(paper, table1, jet_map):
    tau = torque_per_jet_B(paper.nominal(1), paper.model)[0]
    for j in range(16):
        for a in range(3):
            expected = jet_map[j, a] * table1.thrust_n * ARM_M[a]
            assert tau[j, a] == pytest.approx(expected, rel=1e-12, abs=1e-12), (j + 1, a)


def test_translation_jets_have_zero_nominal_torque(paper, table1):
    tau = torque_per_jet_B(paper.nominal(1), paper.model)[0]
    # Relative to the smallest rotation jet's torque F * 0.724 N m.
    np.testing.assert_allclose(
        tau[TRANSLATION_JETS], 0.0, atol=ZERO_RTOL * table1.thrust_n * ARM_M.min()
    )


def test_pairs_are_pure_couples_in_geometry(paper, jet_map, table1):
    pos, dirs = jet_geometry_B(paper.model)
    for a, s, jets in pairs(jet_map):
        force = table1.thrust_n * dirs[jets].sum(axis=0)
        np.testing.assert_allclose(force, 0.0, atol=ZERO_RTOL * table1.thrust_n)
        # A couple has the same moment about every point: about the origin == about the CG.
        m_origin = np.cross(pos[jets], table1.thrust_n * dirs[jets]).sum(axis=0)
        expected = np.zeros(3)
        expected[a] = s * 2 * table1.thrust_n * ARM_M[a]
        np.testing.assert_allclose(m_origin, expected, rtol=1e-12, atol=1e-12)


def test_design_arms_reproduce_table6_pure_axis_times(paper, table1, jet_map):
    """t = I w / (2 F r), rounded up to whole 40 ms cycles, is Table 6's firing time.

    Table 6 (the paper's original lookup table) fires 0.52 s roll, 0.48 s pitch, 0.40 s yaw for
    the 0.3 deg/s single-axis cases; the arms come from the model's geometry here.
    """
    table6 = load_lookup_table(which="table6")
    tau = torque_per_jet_B(paper.nominal(1), paper.model)[0]
    checked = 0
    for case, rate, times in zip(table6.case, table6.rate_cmd, table6.firing_time_s):
        axes = np.flatnonzero(rate)
        if len(axes) != 1:
            continue
        a = axes[0]
        pair_torque = np.abs(tau[jet_map[:, a] > 0, a]).sum()
        t = table1.inertia_kgm2[a] * abs(rate[a]) / pair_torque
        cycles = math.ceil(t / CYCLE_S - 1e-9)
        assert cycles * CYCLE_S == pytest.approx(times.max(), abs=1e-9), (case, a, t)
        checked += 1
    assert checked == 6


# ---------------------------------------------------------------------------------------------
# Simulation: MuJoCo applies the forces at the sites
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("jet", range(16))
def test_single_jet_pulse_rate_change_matches_table2(paper, table1, jet_map, jet):
    dw, dv, _ = fire(paper, [jet], CYCLE_S)
    scale = table1.thrust_n * ARM_M.min() * CYCLE_S / table1.inertia_kgm2.max()
    sign = np.where(np.abs(dw) > ZERO_RTOL * scale, np.sign(dw), 0).astype(int)
    np.testing.assert_array_equal(sign, jet_map[jet])
    # Every jet also pushes the CG: |dv| = F t / m (Newton; Table 1 F and m).
    assert np.linalg.norm(dv) == pytest.approx(table1.thrust_n * CYCLE_S / table1.mass_kg, rel=1e-6)


@pytest.mark.parametrize("jet", TRANSLATION_JETS)
def test_translation_jet_pushes_cg_without_rotation(paper, table1, jet):
    dw, dv, _ = fire(paper, [jet], CYCLE_S)
    _, dirs = jet_geometry_B(paper.model)
    expected = table1.thrust_n * CYCLE_S / table1.mass_kg * dirs[jet]  # attitude stays identity
    np.testing.assert_allclose(dv, expected, rtol=1e-12, atol=ZERO_RTOL * np.abs(expected).max())
    rot_scale = table1.thrust_n * ARM_M.min() * CYCLE_S / table1.inertia_kgm2.max()
    np.testing.assert_allclose(dw, 0.0, atol=ZERO_RTOL * rot_scale)


@pytest.mark.parametrize("axis_sign", [(a, s) for a in range(3) for s in (-1, 1)])
def test_pair_pulse_is_a_pure_couple_in_simulation(paper, table1, jet_map, axis_sign):
    a, s = axis_sign
    jets = np.flatnonzero(jet_map[:, a] == s)
    t = 0.2  # 5 cycles
    dw, dv, _ = fire(paper, jets, t)
    expected = s * 2 * table1.thrust_n * ARM_M[a] * t / table1.inertia_kgm2[a]
    assert dw[a] == pytest.approx(expected, rel=PULSE_RTOL)
    others = np.delete(dw, a)
    np.testing.assert_allclose(others, 0.0, atol=ZERO_RTOL * abs(expected))
    # Zero net force: the CG does not move (vs one jet's F t / m).
    np.testing.assert_allclose(dv, 0.0, atol=ZERO_RTOL * table1.thrust_n * t / table1.mass_kg)


# ---------------------------------------------------------------------------------------------
# Pulses of any length through the production path (duty profile + batched closed loop)
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def pair_sim(paper):
    """One run per rotational pair, reused for every pulse length (run() resets the state)."""
    return BatchSimulation(paper.nominal(6), vehicle=paper, nthread=1)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(t=st.floats(min_value=1e-4, max_value=0.6, allow_nan=False))
@example(t=0.017)  # sub-cycle, not a multiple of any candidate step
@example(t=0.0433)  # just over one cycle
@example(t=0.52)  # Table 6 roll time, 13 cycles
@example(t=0.04)  # exactly one cycle
def test_pair_pulse_of_any_length_gives_exact_rate_change(pair_sim, table1, jet_map, t):
    """dw = 2 F r t / I within 1e-6 relative, at the default physics step, for any t."""
    pr = pairs(jet_map)
    on = np.zeros((6, 16))
    for i, (_, _, jets) in enumerate(pr):
        on[i, jets] = t
    duration = (math.ceil(t / CYCLE_S) + 1) * CYCLE_S  # the pulse has ended
    hist = pair_sim.run(
        OpenLoopController(on, PAPER_CYCLE_S), Guidance.attitude(np.zeros((6, 3))), duration
    )
    assert not hist.failed.any()
    # Delivered on-time equals the command (no valve limit at min_pulse 0).
    np.testing.assert_allclose(hist.propulsion.on_time_s, on, rtol=1e-12)
    for i, (a, s, _) in enumerate(pr):
        expected = s * 2 * table1.thrust_n * ARM_M[a] * t / table1.inertia_kgm2[a]
        dw = hist.final.omega_B[i]
        assert dw[a] == pytest.approx(expected, rel=PULSE_RTOL), (a, s, t)
        np.testing.assert_allclose(np.delete(dw, a), 0.0, atol=ZERO_RTOL * abs(expected))
