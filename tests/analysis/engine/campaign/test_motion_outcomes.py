"""Propellant, delta-v and pulse outcomes (:mod:`rcsim.analysis.engine.campaign.motion`).

Oracles
-------
* Impulse: a jet of thrust F on for t gives the CG ``F t / m`` along the jet's direction
  (Newton's second law; the wrench model applies the force at the body origin, the CG's
  acceleration is F / m wherever the CG is).  Body axes: exact to rounding (1e-12 relative,
  a sum of a few products).  Inertial: the direction is the body's turned by the attitude
  during the firing; from rest the body turns by at most ``alpha t^2 / 2`` in it (alpha =
  |torque| / smallest principal moment), so the inertial delta-v is the body one to within
  that angle (tolerance 10x that bound, itself ~1e-7 rad here).
* Propellant: ``F t / (Isp g0)`` (Sutton & Biblarz, eq. 2-5), 1e-12 relative.
* Pulses on a scripted on-time pattern, counted by hand (exact integers); duty = on-time
  over the duration, pulses per minute = pulses over minutes (exact to rounding).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rcsim.analysis.engine.campaign.motion import min_pulse_count, motion_outcomes
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2

PAPER = Vehicle.load()
JET = 2  # jet_03
PULSE_S = 0.02  # half a 40 ms cycle


class _OnePulse:
    """Jet ``JET`` on for ``PULSE_S`` in the first cycle, nothing after."""

    cycle_s = 0.04

    def initial_state(self, n_runs):
        return 0

    def step(self, nav, k):
        on = np.zeros((nav.att_err_B.shape[0], PAPER.nominal(1).n_jets))
        if k == 0:
            on[:, JET] = PULSE_S
        return on, k + 1


def _fly_one_pulse():
    params = PAPER.nominal(1)
    # A CG off the body origin: the inertial delta-v must be the CG's, not the origin's
    # (after the pulse the body spins, and the origin's velocity turns with it).
    params = replace(params, cg_B=np.array([[0.05, -0.03, 0.04]]))
    sim = BatchSimulation(params, vehicle=PAPER, nthread=1)
    history = sim.run(_OnePulse(), Guidance.rate(np.zeros((1, 3))), 0.4)
    return sim, history


def test_one_pulse_delta_v_and_propellant_are_F_t_over_m_and_F_t_over_Isp_g0():
    sim, history = _fly_one_pulse()
    flown = history.flown_params
    cols = motion_outcomes(history)
    thrust = flown.thrust_n[0, JET]
    direction_B = sim.physics.jet_directions_B()[0, JET]
    expected_B = thrust * PULSE_S / flown.mass_kg[0] * direction_B
    got_B = np.array([cols[f"delta_v_{a}_B_m_s"][0] for a in "xyz"])
    np.testing.assert_allclose(got_B, expected_B, rtol=1e-12, atol=1e-15)
    assert np.isclose(cols["delta_v_B_m_s"][0], np.linalg.norm(expected_B), rtol=1e-12)
    # The inertial one starts at rest in N = B (identity attitude) and turns by <= alpha t^2 / 2.
    torque = np.linalg.norm(sim.physics._wrench[0, 3:6, JET])
    alpha = torque / flown.inertia_B[0].min()
    angle = alpha * PULSE_S**2 / 2
    got_N = np.array([cols[f"delta_v_{a}_N_m_s"][0] for a in "xyz"])
    np.testing.assert_allclose(
        got_N, expected_B, rtol=0, atol=10 * angle * np.linalg.norm(expected_B)
    )
    kg = thrust * PULSE_S / (flown.isp_s * G0_M_S2)
    assert np.isclose(cols[f"jet_{JET + 1:02d}_propellant_kg"][0], kg, rtol=1e-12)
    others = [cols[f"jet_{j + 1:02d}_propellant_kg"][0] for j in range(16) if j != JET]
    assert others == [0.0] * 15
    assert np.isclose(cols[f"jet_{JET + 1:02d}_duty"][0], PULSE_S / 0.4, rtol=1e-12)
    assert cols["pulses"][0] == 1.0
    assert np.isclose(cols["pulses_per_min"][0], 1 / (0.4 / 60), rtol=1e-12)


def test_min_pulses_count_new_firings_at_the_minimum_on_time_only():
    _, history = _fly_one_pulse()
    cycle, min_s = history.cycle_s, 0.01
    n_cycles = history.on_time_s.shape[1]
    on = np.zeros((1, n_cycles, 16))
    on[0, [0, 2, 4], 0] = min_s  # three minimum pulses of jet_01
    on[0, 5, 1] = 0.015  # a longer pulse: not minimum
    on[0, 6, 1] = cycle  # a firing filling cycle 6 ...
    on[0, 7, 1] = min_s  # ... continued for min_s in cycle 7: not a new pulse
    scripted = replace(history, on_time_s=on, min_pulse_s=min_s)
    assert min_pulse_count(scripted).tolist() == [3]
    assert min_pulse_count(replace(scripted, min_pulse_s=0.0)).tolist() == [0]
    # Exhaustion at the start of cycle 3: the minimum pulse of cycle 4 is no firing.
    dead = replace(scripted, propellant_exhausted_s=np.array([3 * cycle]))
    assert min_pulse_count(dead).tolist() == [2]
