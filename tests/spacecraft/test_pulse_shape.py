"""Real pulses (rcsim.spacecraft.pulse_shape) against closed forms written here, not the code's.

Oracles
-------
* Delivered impulse of one isolated pulse of commanded on-time ``u`` (valve open ``[0, u]``),
  over the jet's thrust ``F`` (docs/vehicles.md, "Pulses", the laws):

  - first order, ``tau_r``, ``tau_t``, tail cut at ``C = 20`` time constants::

        I / F = u - tau_r (1 - exp(-u / tau_r)) + p tau_t (1 - exp(-C)),  p = 1 - exp(-u / tau_r)

  - linear ramps ``r``, ``f`` (the tail a triangle of height ``p`` and base ``p f``)::

        I / F = u^2 / (2 r) + p^2 f / 2,  p = u / r          (u <= r)
        I / F = u - r / 2 + f / 2                           (u >= r)

  Tolerance 1e-12 relative: the flight sums each piece's exact integral (a few tens of
  pieces, rounding ~1e-16 each), so any error in the law or the cut shows far above it.
* Propellant: ``impulse / (Isp g0)`` (Isp the pulse-mode table's at ``u``, linear between its
  points), to 1e-12.
* The flown vehicle: a pure roll couple (two paper roll jets, arms along y, forces along z, no
  net force) on a body at rest about a principal axis: ``Ixx omega_x = sum r x F dt``, the
  impulse times the couple's arm; RK4 integrates the piecewise-constant torque exactly, so
  1e-12 relative.
* Impulse-bit table: a commanded on-time equal to a table point delivers that point's impulse
  (1e-12; the equivalent square pulse is ``I / F`` long).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle.definition import packaged_vehicle
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2
from rcsim.spacecraft.vehicle.vehicle import Vehicle

CYCLE_S = 0.04
F_N = 22.24  # paper.toml jet_defaults.thrust_n
ISP_S = 280.0  # paper.toml propellant.isp_s
REL = 1e-12
C = 20.0
RISE_S, TAIL_S = 0.012, 0.008
# Shorter than the rise, about it, longer, and spanning two and four cycles.
ON_S = np.array([0.003, 0.0117, 0.02, 0.0391, 0.05, 0.1234])
# jet_01 at y = +0.812 m, force -z; jet_03 at y = -0.812 m, force +z: a couple of torque
# r x F = y F_z = -0.812 F each about x (paper.toml), no net force.
ROLL_JETS = (0, 2)
TORQUE_ARM_M = -0.812


def exponential_impulse_s(u: float, r: float, t: float) -> float:
    p = 1.0 - math.exp(-u / r)
    return u - r * (1.0 - math.exp(-u / r)) + p * t * (1.0 - math.exp(-C))


def linear_impulse_s(u: float, r: float, f: float) -> float:
    if u <= r:
        p = u / r
        return u * u / (2.0 * r) + p * p * f / 2.0
    return u - r / 2.0 + f / 2.0


def vehicle_with(tmp_path, extra: str, propellant: bool = True) -> Vehicle:
    text = packaged_vehicle("paper").read_text(encoding="utf-8")
    if propellant:
        text = text.replace("[propellant]\n", "[propellant]\nmass_kg = 40.0\n", 1)
    path = tmp_path / "v.toml"
    path.write_text(text + extra, encoding="utf-8")
    return Vehicle.load(str(path))


def fly(vehicle: Vehicle, on_s: np.ndarray, duration_s: float = 0.6):
    n = on_s.size
    on = np.zeros((n, vehicle.n_jets))
    on[:, list(ROLL_JETS)] = on_s[:, None]
    sim = BatchSimulation(vehicle.nominal(n), vehicle=vehicle, nthread=1)
    hist = sim.run(OpenLoopController(on, CYCLE_S), Guidance.attitude(np.zeros((n, 3))), duration_s)
    return sim, hist


@pytest.mark.parametrize(
    ("model", "law"), [("exponential", exponential_impulse_s), ("linear", linear_impulse_s)]
)
def test_shaped_pulse_impulse_propellant_and_momentum_match_closed_form(tmp_path, model, law):
    v = vehicle_with(
        tmp_path, f'\n[pulse]\nmodel = "{model}"\nrise_s = {RISE_S}\ntail_s = {TAIL_S}\n'
    )
    sim, hist = fly(v, ON_S)
    expected = np.array([law(u, RISE_S, TAIL_S) for u in ON_S]) * F_N
    for j in ROLL_JETS:
        np.testing.assert_allclose(hist.propulsion.impulse_ns[:, j], expected, rtol=REL)
    np.testing.assert_allclose(sim.physics.used_kg, 2 * expected / (ISP_S * G0_M_S2), rtol=REL)
    # The flown body: Ixx omega_x at the end (the tails are over by 0.6 s) = sum y F_z dt.
    ixx = v.nominal(1).inertia_B[0, 0]
    h = ixx * hist.final.omega_B[:, 0]
    np.testing.assert_allclose(h, 2 * TORQUE_ARM_M * expected, rtol=REL)


def test_shaped_pulse_shorter_than_rise_never_reaches_full_thrust(tmp_path):
    """A 3 ms pulse on a 12 ms linear rise peaks at 1/4 of the thrust: its impulse is
    ``u^2 / (2 r) + p^2 f / 2`` = 0.375 + 0.25 ms of full thrust, a fifth of the square
    pulse's 3 ms (the closed form above; a square-pulse model would be 5x off)."""
    v = vehicle_with(
        tmp_path, f'\n[pulse]\nmodel = "linear"\nrise_s = {RISE_S}\ntail_s = {TAIL_S}\n'
    )
    _, hist = fly(v, np.array([0.003]))
    expected = (0.003**2 / (2 * RISE_S) + 0.25**2 * TAIL_S / 2) * F_N
    assert hist.propulsion.impulse_ns[0, 0] == pytest.approx(expected, rel=REL)
    assert hist.propulsion.impulse_ns[0, 0] < 0.25 * 0.003 * F_N


TABLE_ON_S = [0.005, 0.01, 0.02, 0.03]
TABLE_IMPULSE_NS = [0.05, 0.15, 0.4, 0.62]
ISP_TABLE = ([0.005, 0.03], [150.0, 250.0])


def table_vehicle(tmp_path) -> Vehicle:
    return vehicle_with(
        tmp_path,
        '\n[pulse]\nmodel = "table"\n'
        f"on_time_s = {TABLE_ON_S}\nimpulse_ns = {TABLE_IMPULSE_NS}\n"
        f"isp_on_time_s = {ISP_TABLE[0]}\nisp_s = {ISP_TABLE[1]}\n",
    )


def test_table_point_delivers_its_impulse_and_propellant(tmp_path):
    """On-time at a table point: that point's impulse (data sheet), propellant
    ``I / (Isp(u) g0)`` with Isp interpolated linearly between (5 ms, 150 s), (30 ms, 250 s)."""
    v = table_vehicle(tmp_path)
    sim, hist = fly(v, np.array(TABLE_ON_S))
    for j in ROLL_JETS:
        np.testing.assert_allclose(hist.propulsion.impulse_ns[:, j], TABLE_IMPULSE_NS, rtol=REL)
    isp = [150.0 + (u - 0.005) / 0.025 * 100.0 for u in TABLE_ON_S]
    expected_kg = [2 * i / (s * G0_M_S2) for i, s in zip(TABLE_IMPULSE_NS, isp)]
    np.testing.assert_allclose(sim.physics.used_kg, expected_kg, rtol=REL)
    # What runs.parquet and a maneuver's summary report: the flight's own, per jet.
    np.testing.assert_allclose(hist.propellant_kg, expected_kg, rtol=REL)


def test_table_between_points_and_above_the_table(tmp_path):
    """Between points: linear interpolation (15 ms: halfway from 0.15 to 0.4 N s); from
    (0, 0) to the first point (2.5 ms: 0.025 N s); above the last point, steady state
    ``I_m + F (u - u_m)`` (a 100 ms pulse over three cycles: 0.62 + 22.24 * 0.07 N s)."""
    v = table_vehicle(tmp_path)
    _, hist = fly(v, np.array([0.015, 0.0025, 0.1]))
    expected = [0.275, 0.025, 0.62 + F_N * 0.07]
    np.testing.assert_allclose(hist.propulsion.impulse_ns[:, 0], expected, rtol=REL)


def test_vehicle_without_pulse_has_no_shape(paper):
    """The packaged vehicles give no [pulse]: square pulses, the flight's old path."""
    assert paper.pulse_shape(3) is None and paper.blowdown(3) is None


def test_propellant_runs_out_mid_rise_at_the_closed_form_instant(tmp_path):
    """Two jets on from t = 0 with a first-order rise (tau_r = 12 ms) and 0.3 g of propellant:
    the propellant used by ``t`` is ``2 F / (Isp g0) (t - tau_r (1 - exp(-t / tau_r)))``; it
    reaches 0.3 g at the root ``t*`` (brentq, 1e-15 s), inside the first cycle's rise.  The
    flight must stop there: exhaustion instant to 1e-12 s, propellant used 0.3 g to 1e-12
    relative, impulse ``(Isp g0) 0.3 g`` -- the tail after the instant included in nothing."""
    from scipy.optimize import brentq

    text = packaged_vehicle("paper").read_text(encoding="utf-8")
    text = text.replace("[propellant]\n", "[propellant]\nmass_kg = 0.0003\n", 1)
    path = tmp_path / "v.toml"
    path.write_text(
        text + f'\n[pulse]\nmodel = "exponential"\nrise_s = {RISE_S}\ntail_s = {TAIL_S}\n',
        encoding="utf-8",
    )
    v = Vehicle.load(str(path))
    sim, hist = fly(v, np.array([0.5]))
    rate = 2 * F_N / (ISP_S * G0_M_S2)
    t_star = brentq(
        lambda t: rate * (t - RISE_S * (1 - math.exp(-t / RISE_S))) - 0.0003, 0.0, 0.5, xtol=1e-15
    )
    assert 0.0 < t_star < CYCLE_S  # mid-cycle
    assert sim.physics.exhausted_s[0] == pytest.approx(t_star, abs=1e-12)
    assert sim.physics.used_kg[0] == pytest.approx(0.0003, rel=1e-12)
    assert hist.propulsion.impulse_ns[:, list(ROLL_JETS)].sum() == pytest.approx(
        0.0003 * ISP_S * G0_M_S2, rel=1e-12
    )


def test_linear_pulse_flies_as_the_thrust_profile(tmp_path, paper):
    """``model = "linear"`` is the law of ``ThrustProfile(rise_s, fall_s)`` (flown by
    ``pieces.profile_pieces``, tested against its own closed form in test_exact_time): the
    same pulses on both give the same impulse (1e-12) and the same final attitude and rate
    (1e-12 relative: both cut each ramp in four and fly its exact mean over each piece)."""
    from rcsim.spacecraft.valves import ThrustProfile

    v = vehicle_with(
        tmp_path, f'\n[pulse]\nmodel = "linear"\nrise_s = {RISE_S}\ntail_s = {TAIL_S}\n', False
    )
    _, shaped = fly(v, ON_S)
    n = ON_S.size
    on = np.zeros((n, paper.n_jets))
    on[:, list(ROLL_JETS)] = ON_S[:, None]
    ramps = BatchSimulation(
        paper.nominal(n), vehicle=paper, nthread=1, profile=ThrustProfile(RISE_S, TAIL_S)
    ).run(OpenLoopController(on, CYCLE_S), Guidance.attitude(np.zeros((n, 3))), 0.6)
    np.testing.assert_allclose(shaped.propulsion.impulse_ns, ramps.propulsion.impulse_ns, rtol=REL)
    np.testing.assert_allclose(shaped.final.omega_B, ramps.final.omega_B, rtol=REL, atol=1e-18)
    np.testing.assert_allclose(shaped.final.q_BN, ramps.final.q_BN, rtol=REL, atol=1e-15)


def test_dispersed_impulse_bit_scales_the_table(tmp_path):
    """A run's impulse-bit factor ``s`` (rcsim.spacecraft.pulse_draws) scales every table
    point: a 10 ms pulse delivers ``s I(10 ms)``; a 100 ms one, at steady state above the
    table, ``s I_m + F (u - u_m)`` (docs/vehicles.md, "Pulse and pressure dispersions")."""
    from dataclasses import replace

    v = table_vehicle(tmp_path)
    scale = np.array([0.9, 1.2])
    shape = v.pulse_shape(2)
    shape = replace(shape, impulse_scale=np.repeat(scale[:, None], v.n_jets, axis=1))
    on = np.zeros((2, v.n_jets))
    on[:, 0] = [0.01, 0.1]
    for k in range(2):  # each factor on both pulses
        sim = BatchSimulation(v.nominal(2), vehicle=v, nthread=1, pulse=shape.take([k, k]))
        hist = sim.run(OpenLoopController(on, CYCLE_S), Guidance.attitude(np.zeros((2, 3))), 0.3)
        expected = [scale[k] * 0.15, scale[k] * 0.62 + F_N * 0.07]
        np.testing.assert_allclose(hist.propulsion.impulse_ns[:, 0], expected, rtol=REL)


@pytest.mark.parametrize("model", ["exponential", "linear"])
def test_on_time_is_the_valve_open_time_and_the_tail_is_impulse_only(model):
    """A jet's on-time (runs.parquet's jet_NN_on_time_s) is the time its valve is open: the
    commanded [0, 20 ms] here, whatever the tail (docs/campaigns.md).  Its thrust time is the
    closed-form integral of the shape, tail included: first order, u - tau_r (1 - e^{-u/tau_r})
    + p tau_t with p = 1 - e^{-u/tau_r} the level at closing; linear, u - r/2 + tail/2 (a
    ramp's area is half its length)."""
    from rcsim.spacecraft.pulse_shape import PulseShape, shaped_pieces

    u, rise, tail = 0.020, 0.005, 0.012
    shape = PulseShape(model, np.array([[rise]]), np.array([[tail]]))
    pieces = shaped_pieces(np.array([[[0.0]]]), np.array([[[u]]]), 0.08, None, shape)
    assert pieces.on_time_s()[0, 0] == pytest.approx(u, rel=1e-12)
    if model == "exponential":
        level = 1 - math.exp(-u / rise)
        want = u - rise * level + level * tail * (1 - math.exp(-0.06 / tail))  # tail cut at 80 ms
    else:
        want = u - rise / 2 + tail / 2
    assert pieces.thrust_time_s()[0, 0] == pytest.approx(want, rel=1e-12)
