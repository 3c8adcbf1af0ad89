"""Propellant that runs out (:mod:`rcsim.spacecraft.propellant`), flown in the closed loop.

Oracles
-------
* Rocket mass flow: a jet of thrust F firing for t uses ``F t / (Isp g0)`` of propellant
  (``g0`` = 9.80665 m/s^2, the definition of Isp in seconds; e.g. Sutton & Biblarz, *Rocket
  Propulsion Elements*, eq. 2-5: ``I_s = I_t / (g0 m_p)``).  Compared to 1e-9 relative: the
  flight adds per-cycle doubles (200 cycles, each exact to ~1e-16 relative).
* The stated point-mass model (module docstring): the inertia after using ``u`` kg equals the
  dry body plus the remaining propellant as a point mass at the tank, built independently
  by the parallel-axis theorem (1e-12 relative: a few float operations on ~1e3 kg m^2).
* Exhaustion: with propellant left ``L`` and one jet of flow ``mdot`` firing from t = 0,
  the jets stop at ``L / mdot`` exactly (rounding only, 1e-12 s).
"""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.propellant import (
    PropellantTank,
    exhaustion_time_s,
    full_inertia,
    mass_properties,
    principal,
)
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle import Vehicle, build_model, load_vehicle
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2, RunParameters

#: The paper's vehicle (paper.toml), for helpers outside the fixtures.
PAPER = Vehicle.load()


class _Constant:
    """Fire the jets of ``on`` (n_runs, 16) bool for whole cycles, every cycle."""

    cycle_s = 0.04

    def __init__(self, on):
        self.on = np.asarray(on, bool)

    def initial_state(self, n_runs):
        return None

    def step(self, nav, state):
        return np.where(self.on, self.cycle_s, 0.0), None


@pytest.fixture(scope="module")
def canted():
    vehicle = load_vehicle("canted16")
    return vehicle, build_model(vehicle)


def _fly(vehicle, model, on, initial_kg, duration_s):
    n = on.shape[0]
    params = PAPER.nominal(n)
    params = RunParameters(**{**params.__dict__, "isp_s": vehicle.isp_s})
    tank = PropellantTank.of(n, initial_kg, vehicle.tank_position_m)
    sim = BatchSimulation(params, vehicle=PAPER, nthread=1, tank=tank)
    history = sim.run(_Constant(on), Guidance.rate(np.zeros((n, 3))), duration_s)
    return sim, history


def test_constant_firing_uses_F_t_over_Isp_g0(canted):
    vehicle, model = canted
    on = np.zeros((2, 16), bool)
    on[0, 2] = True  # jet_03 alone
    on[1, [0, 4]] = True  # two jets
    duration = 8.0
    sim, history = _fly(vehicle, model, on, vehicle.propellant_kg, duration)
    thrust = vehicle.thrusts_n()
    expected = (on * thrust).sum(axis=1) * duration / (vehicle.isp_s * G0_M_S2)
    used = history.propulsion.propellant_kg(vehicle.isp_s)
    np.testing.assert_allclose(used, expected, rtol=1e-9, atol=0)
    # The mass MuJoCo flies at the end is the wet mass minus what was used.
    flown_mass = sim.physics.batch.expanded("body_mass")[:, 1]
    np.testing.assert_allclose(vehicle.mass_kg - flown_mass, expected, rtol=1e-9, atol=0)
    assert np.isinf(history.propellant_exhausted_s).all()


def test_inertia_follows_the_point_mass_model(canted):
    vehicle, _ = canted
    m0, c0, i0 = vehicle.mass_kg, np.array(vehicle.cg_m), vehicle.inertia_kg_m2
    tank, p0, used = np.array(vehicle.tank_position_m), vehicle.propellant_kg, 12.5
    m, c, inertia = mass_properties(np.array([m0]), c0[None], i0[None], tank, np.array([used]))

    def point(v):  # inertia of a unit point mass at v about the origin
        return v @ v * np.eye(3) - np.outer(v, v)

    # Independent construction: dry body about its own CG, plus the propellant left.
    dry_m = m0 - p0
    dry_c = (m0 * c0 - p0 * tank) / dry_m
    dry_i = i0 + m0 * point(c0) - p0 * point(tank) - dry_m * point(dry_c)
    left = p0 - used
    m_exp = dry_m + left
    c_exp = (dry_m * dry_c + left * tank) / m_exp
    i_exp = dry_i + dry_m * point(dry_c - c_exp) + left * point(tank - c_exp)
    assert m[0] == pytest.approx(m_exp, rel=1e-12)
    np.testing.assert_allclose(c[0], c_exp, rtol=0, atol=1e-12)
    np.testing.assert_allclose(inertia[0], i_exp, rtol=0, atol=1e-12 * np.abs(i_exp).max())
    # What MuJoCo is given (principal moments + frame) rebuilds the same tensor.
    moments, quat = principal(inertia)
    rebuilt = full_inertia(moments, quat[0])
    np.testing.assert_allclose(rebuilt[0], inertia[0], atol=1e-9 * np.abs(i_exp).max())


def test_each_runs_own_principal_frame_follows_the_propellant(paper, canted):
    """Issue 18: runs with dispersed products of inertia have their own wet tensors (their
    own principal frames).  After 2 s of one jet, the tensor MuJoCo flies in each run (its
    principal moments and frame, rebuilt) is that run's wet tensor moved by the point-mass
    model with the propellant the run used: 1e-9 of the largest moment (eigen round trips on
    ~3.5e3 kg m^2)."""
    vehicle, model = canted
    wet = np.repeat(vehicle.inertia_kg_m2[None], 2, axis=0)
    wet[0, 0, 1] = wet[0, 1, 0] = 60.0  # run 0: Ixy moved from -25 to 60 kg m^2
    wet[1, 1, 2] = wet[1, 2, 1] = -90.0  # run 1: Iyz from -15 to -90
    moments, iquat = principal(wet)
    params = paper.nominal(2)
    params = replace(params, inertia_B=moments, iquat=iquat, isp_s=vehicle.isp_s)
    tank = PropellantTank.of(2, vehicle.propellant_kg, vehicle.tank_position_m)
    sim = BatchSimulation(params, vehicle=paper, nthread=1, tank=tank)
    on = np.zeros((2, 16), bool)
    on[:, 2] = True
    history = sim.run(_Constant(on), Guidance.rate(np.zeros((2, 3))), 2.0)
    used = history.propulsion.propellant_kg(vehicle.isp_s)
    assert (used > 0).all()
    _, _, expect = mass_properties(
        np.full(2, vehicle.mass_kg),
        np.repeat(np.array(vehicle.cg_m)[None], 2, axis=0),
        wet,
        np.array(vehicle.tank_position_m),
        used,
    )
    flown = full_inertia(
        sim.physics.batch.expanded("body_inertia")[:, 1],
        sim.physics.batch.expanded("body_iquat")[:, 1],
    )
    np.testing.assert_allclose(flown, expect, rtol=0, atol=1e-9 * np.abs(expect).max())
    # The wet vehicle is what the history records as flown (the draw, read back).
    np.testing.assert_array_equal(history.flown_params.iquat, iquat)


def test_exhaustion_stops_the_jets_at_the_exact_instant(canted):
    vehicle, model = canted
    on = np.zeros((1, 16), bool)
    on[0, 2] = True
    mdot = vehicle.thrusts_n()[2] / (vehicle.isp_s * G0_M_S2)
    left = 0.0123  # kg: runs out at left / mdot = 1.5186 s, inside cycle 37
    sim, history = _fly(vehicle, model, on, left, 3.0)
    assert history.propellant_exhausted_s[0] == pytest.approx(left / mdot, abs=1e-12)
    assert history.propulsion.propellant_kg(vehicle.isp_s)[0] == pytest.approx(left, rel=1e-9)
    assert history.propulsion.on_time_s[0, 2] == pytest.approx(left / mdot, abs=1e-12)
    # The run flies on: not a simulation failure.
    assert not history.failed[0]


class _Pulses:
    """Command ``pulse_s`` (under a cycle, so every pulse starts a new firing) to the jets of
    ``on`` (n_runs, n_jets) bool, every cycle."""

    cycle_s = 0.04

    def __init__(self, on, pulse_s):
        self.on, self.pulse_s = np.asarray(on, bool), pulse_s

    def initial_state(self, n_runs):
        return None

    def step(self, nav, state):
        return np.where(self.on, self.pulse_s, 0.0), None


def test_commands_after_exhaustion_are_no_firings(paper, canted):
    """Issue 18 review: a jet without propellant delivers nothing, so its commands are not
    counted as firings.  Oracle: jet_03 fires a 20 ms pulse at the start of every 40 ms cycle
    (each a new firing, mass flow ``mdot = F / (Isp g0)``); with ``L`` kg the propellant runs
    out in pulse ``k = floor(L / (mdot 0.02))`` (0-based) at ``k 0.04 + (L - k mdot 0.02) /
    mdot`` s, so exactly ``k + 1`` firings are counted (the pulses commanded with propellant
    left) against 75 commands in 3 s; a run with plenty of propellant counts all 75."""
    vehicle, model = canted
    on = np.zeros((2, 16), bool)
    on[:, 2] = True
    n, pulse, cycle, duration = 2, 0.02, 0.04, 3.0
    mdot = vehicle.thrusts_n()[2] / (vehicle.isp_s * G0_M_S2)
    left = np.array([0.006, vehicle.propellant_kg])  # runs out in the 38th of 75 pulses
    params = paper.nominal(n)
    params = RunParameters(**{**params.__dict__, "isp_s": vehicle.isp_s})
    tank = PropellantTank.of(n, left, vehicle.tank_position_m)
    sim = BatchSimulation(params, vehicle=paper, nthread=1, tank=tank)
    history = sim.run(_Pulses(on, pulse), Guidance.rate(np.zeros((n, 3))), duration)
    k = int(left[0] // (mdot * pulse))
    t_out = k * cycle + (left[0] - k * mdot * pulse) / mdot
    assert history.propellant_exhausted_s[0] == pytest.approx(t_out, abs=1e-12)
    assert history.propulsion.firings[0, 2] == k + 1
    assert history.propulsion.firings[1, 2] == round(duration / cycle)
    assert np.isinf(history.propellant_exhausted_s[1])
    # The commands themselves are recorded as the controller gave them.
    assert (history.on_time_s[0, :, 2] == pulse).all()


def test_exhaustion_time_with_two_jets_in_pieces():
    """Jet 1 from 10 ms, jet 2 from 20 ms: the crossing falls in the third piece."""
    mdot = np.array([[0.008, 0.008]])
    length = np.array([[0.01, 0.01, 0.02]])
    on = np.array([[[0, 0], [1, 0], [1, 1]]], float)
    left = np.array([1e-4])
    t = exhaustion_time_s(length, on, mdot, left)
    exact = 0.02 + (left[0] - 0.008 * 0.01) / 0.016
    assert t[0] == pytest.approx(exact, abs=1e-15)
    assert np.isinf(exhaustion_time_s(length, on, mdot, np.array([1.0])))[0]


def test_untracked_flight_unchanged_by_a_tank_of_zero_use(paper):
    """A tank on a vehicle that never fires leaves every record identical (no set_const)."""
    vehicle = load_vehicle("paper")
    build_model(vehicle)
    params = paper.nominal(2)
    omega0 = np.array([[0.01, -0.02, 0.005], [0.0, 0.003, 0.0]])
    ctl = _Constant(np.zeros((2, 16), bool))
    a = BatchSimulation(params, vehicle=paper, nthread=1).run(
        ctl, Guidance.rate(np.zeros((2, 3))), 2.0, omega0_B=omega0
    )
    b = BatchSimulation(
        params, vehicle=paper, nthread=1, tank=PropellantTank.of(2, 10.0, (1.0, 0, 0))
    ).run(ctl, Guidance.rate(np.zeros((2, 3))), 2.0, omega0_B=omega0)
    assert np.array_equal(a.q_BN, b.q_BN) and np.array_equal(a.omega_B, b.omega_B)


def test_mujoco_quaternion_convention():
    """principal() returns MuJoCo body_iquat: the frame rotates principal axes into B."""
    inertia = np.array([[[3583.09, -25.0, 40.0], [-25.0, 3160.22, -15.0], [40.0, -15.0, 2457.06]]])
    moments, quat = principal(inertia)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, quat[0])
    rot = rot.reshape(3, 3)
    np.testing.assert_allclose(rot @ np.diag(moments[0]) @ rot.T, inertia[0], atol=1e-9)


def test_batched_mat2quat_is_mujocos_bit_for_bit():
    """Oracle: MuJoCo's own ``mju_mat2Quat``, run by run.  Bit for bit (not a tolerance): the
    frames go into MuJoCo's ``body_iquat``, and campaigns must fly as they did with the loop.
    Random rotations reach all four branches; nearly diagonal tensors (the propellant's
    frames: a vehicle with small products) stay near the identity."""
    from rcsim.spacecraft.propellant import mat2quat

    rng = np.random.default_rng(3)
    tensors = rng.normal(size=(100_000, 3, 3))
    near = np.diag([3583.09, 3160.22, 2457.06]) + rng.normal(scale=30.0, size=(100_000, 3, 3))
    for a in (tensors, near):
        a = a + np.swapaxes(a, 1, 2)
        _, vecs = np.linalg.eigh(a)
        vecs = vecs * np.sign(np.linalg.det(vecs))[:, None, None]
        flat = np.ascontiguousarray(vecs.reshape(-1, 9))
        expected = np.empty((flat.shape[0], 4))
        for k in range(flat.shape[0]):
            mujoco.mju_mat2Quat(expected[k], flat[k])
        got = mat2quat(flat)
        assert got.tobytes() == expected.tobytes()
