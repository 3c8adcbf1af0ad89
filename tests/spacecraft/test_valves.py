"""Valve timing and jet faults in the closed loop (rcsim.spacecraft.valves).

Oracles
-------
* Rigid-body mechanics about a principal axis (as in test_exact_time.py): torque on over
  ``[a, b]`` from rest gives ``w(t) = alpha (clip(t, a, b) - a)``, exactly integrated by RK4 on
  pieces cut at ``a`` and ``b``; so a firing delay ``d`` (open = close = d, or a command delay d)
  must shift the rate response by exactly ``d``: ``w_d(t) = w_0(t - d)``.  Tolerance 1e-9
  relative (rounding is ~1e-15; a delay rounded to the 40 ms step would be off by O(1)).
* Valve latencies: a command of length ``u`` thrusts ``u - d_open + d_close`` (nothing if
  that is <= 0).
* Thrust transients (linear ramps): the impulse of a trapezoid, integrated exactly (the
  midpoint of a linear ramp is its mean over each piece).
* Faults: a failed-off jet delivers no impulse (and from its failure time on, none); a stuck-on
  jet delivers ``thrust x duration``; a degraded jet ``factor x thrust x on-time``; the rate
  change is the jet's own torque (MJCF geometry, :func:`torque_per_jet_B`) times that time over
  the inertia.  Impulses are sums of on-times times thrust: 1e-12 relative.
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.errors import InputError
from rcsim.models.tables import PAPER_CYCLE_S, load_jet_map
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.valves import JetFaults, ThrustProfile, ValveTiming
from rcsim.spacecraft.vehicle.run_parameters import torque_per_jet_B

CYCLE_S = 0.04
REL = 1e-9


ROLL_PLUS = np.flatnonzero(load_jet_map()[:, 0] == 1)


def fly(paper, on_total, duration_s, **kw):
    n = on_total.shape[0]
    sim = BatchSimulation(paper.nominal(n), vehicle=paper, nthread=1, **kw)
    hist = sim.run(
        OpenLoopController(on_total, PAPER_CYCLE_S), Guidance.attitude(np.zeros((n, 3))), duration_s
    )
    assert not hist.failed.any()
    return hist


def rates(hist):
    return np.concatenate([hist.omega_B, hist.final.omega_B[:, None]], axis=1)


def roll_alpha(paper, jets=ROLL_PLUS):
    p = paper.nominal(1)
    return torque_per_jet_B(p, paper.model)[0, jets, 0].sum() / p.inertia_B[0, 0]


U_S = 0.1234  # over three cycles: continuation across cycle boundaries is exercised
DELAYS_S = np.array([0.0, 0.0137, 0.0305])


@pytest.mark.parametrize("kind", ["valve", "command"])
def test_a_delay_shifts_the_rate_response_by_exactly_the_delay(paper, kind):
    on = np.zeros((3, 16))
    on[:, ROLL_PLUS] = U_S
    d = DELAYS_S
    timing = (
        ValveTiming.of(3, open_delay_s=d[:, None], close_delay_s=d[:, None])
        if kind == "valve"
        else ValveTiming.of(3, command_delay_s=d)
    )
    hist = fly(paper, on, 0.24, timing=timing)
    t = np.arange(hist.t_s.size + 1) * CYCLE_S
    expected = roll_alpha(paper) * np.clip(t[None] - d[:, None], 0.0, U_S)
    np.testing.assert_allclose(
        rates(hist)[:, :, 0], expected, rtol=REL, atol=REL * np.abs(expected).max()
    )
    np.testing.assert_allclose(hist.propulsion.on_time_s[:, ROLL_PLUS], U_S, rtol=1e-12)
    # The history keeps the commands (firing counts) and, apart, what the jets delivered.
    plain = fly(paper, on, 0.24)
    np.testing.assert_array_equal(hist.on_time_s, plain.on_time_s)
    np.testing.assert_allclose(hist.delivered_s.sum(axis=1)[:, ROLL_PLUS], U_S, rtol=1e-12)
    assert plain.delivered_s is None
    if d[1] > 0:
        assert not np.array_equal(hist.delivered_s[1], plain.on_time_s[1])


def test_open_and_close_latency_change_the_on_time(paper):
    """u = 17 ms; (open, close) = (8, 3) ms -> 12 ms; (8, 0) ms with u = 5 ms -> nothing."""
    on = np.zeros((2, 16))
    on[0, ROLL_PLUS] = 0.017
    on[1, ROLL_PLUS] = 0.005
    timing = ValveTiming.of(2, open_delay_s=0.008, close_delay_s=[[0.003], [0.0]])
    hist = fly(paper, on, 0.12, timing=timing)
    np.testing.assert_allclose(hist.propulsion.on_time_s[0, ROLL_PLUS], 0.012, rtol=1e-12)
    np.testing.assert_array_equal(hist.propulsion.on_time_s[1], 0.0)
    w = hist.final.omega_B[0, 0]
    assert w == pytest.approx(roll_alpha(paper) * 0.012, rel=REL)
    assert hist.propulsion.firings[1].sum() == 2  # commanded firings are still counted


def test_delays_that_reach_a_cycle_are_refused(paper):
    with pytest.raises(InputError, match="open_delay_s"):
        BatchSimulation(
            paper.nominal(1),
            vehicle=paper,
            timing=ValveTiming.of(1, command_delay_s=0.03, open_delay_s=0.01),
        )
    with pytest.raises(InputError, match="close_delay_s"):
        BatchSimulation(
            paper.nominal(1),
            vehicle=paper,
            timing=ValveTiming.of(1, close_delay_s=-0.001),
        )


def test_failed_off_jet_delivers_no_impulse(paper, table1):
    """Roll+ pair on for 0.1 s; run 0: first jet failed from the start; run 1: from 0.05 s."""
    j0, j1 = ROLL_PLUS
    on = np.zeros((2, 16))
    on[:, ROLL_PLUS] = 0.1
    off = np.full((2, 16), np.inf)
    off[0, j0] = 0.0
    off[1, j0] = 0.05
    hist = fly(paper, on, 0.2, faults=JetFaults.of(2, off_from_s=off))
    imp = hist.propulsion.impulse_ns
    assert imp[0, j0] == 0.0
    assert imp[1, j0] == pytest.approx(table1.thrust_n * 0.05, rel=1e-12)
    np.testing.assert_allclose(imp[:, j1], table1.thrust_n * 0.1, rtol=1e-12)
    w = hist.final.omega_B[:, 0]
    expected = np.array(
        [
            roll_alpha(paper, [j1]) * 0.1,
            roll_alpha(paper, [j1]) * 0.1 + roll_alpha(paper, [j0]) * 0.05,
        ]
    )
    np.testing.assert_allclose(w, expected, rtol=REL)


def test_stuck_on_jet_delivers_thrust_times_duration(paper, table1):
    """No command at all; jet stuck on from 0.0213 s for 0.0777 s (mid-cycle both ends)."""
    j = ROLL_PLUS[0]
    faults = JetFaults.of(
        1, stuck_from_s=np.where(np.arange(16) == j, 0.0213, np.inf), stuck_for_s=0.0777
    )
    hist = fly(paper, np.zeros((1, 16)), 0.2, faults=faults)
    assert hist.propulsion.impulse_ns[0, j] == pytest.approx(table1.thrust_n * 0.0777, rel=1e-12)
    assert hist.propulsion.impulse_ns[0].sum() == pytest.approx(table1.thrust_n * 0.0777, rel=1e-12)
    t = np.arange(hist.t_s.size + 1) * CYCLE_S
    expected = roll_alpha(paper, [j]) * np.clip(t - 0.0213, 0.0, 0.0777)
    np.testing.assert_allclose(
        rates(hist)[0, :, 0], expected, rtol=REL, atol=REL * np.abs(expected).max()
    )


def test_degraded_jet_delivers_its_factor(paper, table1):
    j0, j1 = ROLL_PLUS
    on = np.zeros((1, 16))
    on[0, ROLL_PLUS] = 0.0433
    hist = fly(
        paper,
        on,
        0.12,
        faults=JetFaults.of(1, thrust_factor=np.where(np.arange(16) == j0, 0.8, 1.0)),
    )
    assert hist.propulsion.impulse_ns[0, j0] == pytest.approx(
        0.8 * table1.thrust_n * 0.0433, rel=1e-12
    )
    expected = (0.8 * roll_alpha(paper, [j0]) + roll_alpha(paper, [j1])) * 0.0433
    assert hist.final.omega_B[0, 0] == pytest.approx(expected, rel=REL)


def test_bad_faults_are_refused(paper):
    with pytest.raises(InputError, match="thrust_factor"):
        BatchSimulation(paper.nominal(1), vehicle=paper, faults=JetFaults.of(1, thrust_factor=1.2))


def test_zero_delays_and_no_faults_reproduce_the_plain_flight_bit_for_bit(paper):
    on = np.zeros((2, 16))
    on[0, ROLL_PLUS] = 0.0171
    on[1, :4] = 0.0933
    plain = fly(paper, on, 0.2)
    explicit = fly(paper, on, 0.2, timing=ValveTiming.of(2), faults=JetFaults.of(2))
    for name in ("q_BN", "omega_B", "on_time_s"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(explicit, name))
    np.testing.assert_array_equal(plain.final.q_BN, explicit.final.q_BN)


def test_thrust_transients_keep_the_impulse_exact(paper, table1):
    """Linear rise over 8 ms, linear decay over 12 ms: a valve open for u delivers
    u - rise/2 + fall/2 of full thrust (u >= rise), or u^2/(2 rise) + p^2 fall/2 with
    p = u/rise the level reached (u < rise); the rate change is alpha times that."""
    rise, fall = 0.008, 0.012
    u = np.array([0.004, 0.017, 0.0433, 0.1234])
    on = np.zeros((u.size, 16))
    on[:, ROLL_PLUS] = u[:, None]
    hist = fly(paper, on, 0.3, profile=ThrustProfile(rise, fall))
    peak = np.minimum(u / rise, 1.0)
    full_s = np.where(u >= rise, u - rise / 2, u**2 / (2 * rise)) + peak**2 * fall / 2
    np.testing.assert_allclose(hist.final.omega_B[:, 0], roll_alpha(paper) * full_s, rtol=REL)
    np.testing.assert_allclose(
        hist.propulsion.impulse_ns[:, ROLL_PLUS],
        np.repeat(table1.thrust_n * full_s[:, None], 2, axis=1),
        rtol=1e-12,
    )
