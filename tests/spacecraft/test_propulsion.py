"""Jet on-time -> per-step duty, and valve limits / bookkeeping (rcsim.spacecraft.propulsion).

Oracles: the definitions in the module docstring (duty in step k is the on-fraction of that step
of a firing that starts at the cycle's start), Tsiolkovsky's propellant accounting
``m = impulse / (Isp g0)`` with g0 = 9.80665 m/s^2 (CGPM 1901), and the valve rules of
:class:`PropulsionParams` (a new firing shorter than the minimum pulse is dropped; a firing
continuing from a full previous cycle is never cut).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rcsim.models.tables import PAPER_CYCLE_S
from rcsim.spacecraft.propulsion import (
    PropulsionParams,
    PropulsionState,
    apply_valve_limits,
    duty_profile,
)

CYCLE_S = 0.04
STEPS_MS = (1, 2, 4, 5, 8, 10, 20, 40)  # the physics steps that divide the 40 ms cycle
# Standard gravity, CGPM 1901 (independent of rcsim.spacecraft.vehicle.run_parameters.G0_M_S2).
G0 = 9.80665
# Summing n_sub <= 40 duties times dt: each term exact or one rounding, so the total is within
# a few ulp of on_time (<= 0.04 s, ulp 7e-18 s); 1e-16 s is ~15 ulp and 1e-14 of a cycle.
SUM_ATOL_S = 1e-16


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    dt_ms=st.sampled_from(STEPS_MS),
    on=st.lists(
        st.floats(min_value=0.0, max_value=CYCLE_S, allow_nan=False), min_size=1, max_size=16
    ),
)
def test_duty_sums_to_on_time(dt_ms, on):
    dt = dt_ms * 1e-3
    n_sub = round(CYCLE_S / dt)
    on_time = np.array([on])
    duty = duty_profile(on_time, dt, n_sub)
    assert duty.shape == (1, n_sub, len(on))
    assert np.all((duty >= 0) & (duty <= 1))
    np.testing.assert_allclose(duty.sum(axis=1) * dt, on_time, rtol=0, atol=SUM_ATOL_S)


@pytest.mark.parametrize("dt_ms", STEPS_MS)
def test_duty_is_on_from_cycle_start_then_off(dt_ms):
    """Full steps first, one fractional step, then zeros (the jet opens at the cycle start)."""
    dt = dt_ms * 1e-3
    n_sub = round(CYCLE_S / dt)
    t_on = 0.017  # not a multiple of any step
    duty = duty_profile(np.array([[t_on]]), dt, n_sub)[0, :, 0]
    k_full = int(t_on // dt)
    np.testing.assert_array_equal(duty[:k_full], 1.0)
    if k_full < n_sub:
        assert duty[k_full] == pytest.approx(t_on / dt - k_full, rel=1e-12)
        np.testing.assert_array_equal(duty[k_full + 1 :], 0.0)


def test_duty_full_and_zero_cycles():
    duty = duty_profile(np.array([[0.0, CYCLE_S]]), 0.005, 8)
    np.testing.assert_array_equal(duty[0, :, 0], 0.0)
    # (0.04 - 7 * 0.005) / 0.005 rounds to 1 - 6e-16: "exact" means to float rounding.
    np.testing.assert_allclose(duty[0, :, 1], 1.0, rtol=0, atol=1e-15)


def _state(n=1):
    return PropulsionState.zeros(n, 16)  # the paper vehicle's 16 jets


def test_valve_clips_commands_to_cycle_and_nonnegative():
    p = PropulsionParams(cycle_s=PAPER_CYCLE_S)
    st_ = _state()
    cmd = np.zeros((1, 16))
    cmd[0, :4] = [-0.01, 0.1, np.nan, 0.02]
    on = apply_valve_limits(cmd, st_, p, np.full((1, 16), 22.24))
    np.testing.assert_array_equal(on[0, :4], [0.0, CYCLE_S, 0.0, 0.02])


def test_min_pulse_drops_new_short_firing_and_counts_it():
    p = PropulsionParams(cycle_s=PAPER_CYCLE_S, min_pulse_s=0.01)
    st_ = _state()
    cmd = np.zeros((1, 16))
    cmd[0, 0], cmd[0, 1], cmd[0, 2] = 0.005, 0.01, 0.02
    on = apply_valve_limits(cmd, st_, p, np.full((1, 16), 22.24))
    # Below the limit: dropped; at the limit and above: made.
    np.testing.assert_array_equal(on[0, :3], [0.0, 0.01, 0.02])
    np.testing.assert_array_equal(st_.dropped[0, :3], [1, 0, 0])
    np.testing.assert_array_equal(st_.firings[0, :3], [0, 1, 1])


def test_continuing_firing_is_never_cut_by_min_pulse():
    """A firing that filled the last cycle continues: its short tail is delivered, not dropped."""
    p = PropulsionParams(cycle_s=PAPER_CYCLE_S, min_pulse_s=0.01)
    st_ = _state()
    thrust = np.full((1, 16), 22.24)
    cmd = np.zeros((1, 16))
    cmd[0, 0] = CYCLE_S
    apply_valve_limits(cmd, st_, p, thrust)
    assert st_.on_at_end[0, 0]
    cmd[0, 0] = 0.003  # tail of a 43 ms firing, below min pulse
    on = apply_valve_limits(cmd, st_, p, thrust)
    assert on[0, 0] == 0.003
    assert st_.firings[0, 0] == 1 and st_.dropped[0, 0] == 0
    assert not st_.on_at_end[0, 0]
    # The next short command is a new firing again and is dropped.
    on = apply_valve_limits(cmd, st_, p, thrust)
    assert on[0, 0] == 0.0 and st_.dropped[0, 0] == 1


def test_firing_counts_one_per_contiguous_firing():
    """A 0.52 s firing over 13 cycles is one firing; a gap starts a new one."""
    p = PropulsionParams(cycle_s=PAPER_CYCLE_S)
    st_ = _state()
    thrust = np.full((1, 16), 22.24)
    schedule = [CYCLE_S] * 12 + [0.0] + [0.0, 0.02, 0.0, CYCLE_S, 0.01]
    for c in schedule:
        cmd = np.zeros((1, 16))
        cmd[0, 3] = c
        apply_valve_limits(cmd, st_, p, thrust)
    # Firings: cycles 0-11 (one), 14 (0.02 s, ends inside its cycle), 16-17 (continues).
    assert st_.firings[0, 3] == 3
    assert st_.on_time_s[0, 3] == pytest.approx(sum(schedule), rel=1e-12)


def test_partial_cycle_then_new_command_is_a_new_firing():
    # A firing shorter than the cycle closes the valve before the cycle ends; the next cycle's
    # command opens it again, so it counts as a second firing.
    p = PropulsionParams(cycle_s=PAPER_CYCLE_S)
    st_ = _state()
    thrust = np.full((1, 16), 22.24)
    for c in (0.03, 0.03):
        cmd = np.zeros((1, 16))
        cmd[0, 0] = c
        apply_valve_limits(cmd, st_, p, thrust)
    assert st_.firings[0, 0] == 2


@settings(max_examples=50, deadline=None, derandomize=True)
@given(
    cmds=st.lists(
        st.lists(st.floats(0.0, CYCLE_S), min_size=16, max_size=16), min_size=1, max_size=20
    ),
    thrust=st.floats(1.0, 50.0),
    isp=st.floats(100.0, 450.0),
)
def test_impulse_and_propellant(cmds, thrust, isp):
    p = PropulsionParams(cycle_s=PAPER_CYCLE_S)
    st_ = _state()
    thrust_arr = np.full((1, 16), thrust)
    for row in cmds:
        apply_valve_limits(np.array([row]), st_, p, thrust_arr)
    total_on = np.sum(cmds, axis=0)
    np.testing.assert_allclose(st_.on_time_s[0], total_on, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(st_.impulse_ns[0], thrust * total_on, rtol=1e-12, atol=1e-13)
    expected_kg = thrust * total_on.sum() / (isp * G0)
    assert st_.propellant_kg(isp)[0] == pytest.approx(expected_kg, rel=1e-12, abs=1e-18)


def test_runs_are_independent():
    p = PropulsionParams(cycle_s=PAPER_CYCLE_S, min_pulse_s=0.01)
    st_ = _state(2)
    cmd = np.zeros((2, 16))
    cmd[0, 0], cmd[1, 0] = 0.005, 0.02
    on = apply_valve_limits(cmd, st_, p, np.full((2, 16), 22.24))
    np.testing.assert_array_equal(on[:, 0], [0.0, 0.02])
    np.testing.assert_array_equal(st_.dropped[:, 0], [1, 0])
    np.testing.assert_array_equal(st_.firings[:, 0], [0, 1])


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(cycle_s=0.0),
        dict(cycle_s=-1.0),
        dict(cycle_s=PAPER_CYCLE_S, min_pulse_s=-0.001),
        dict(cycle_s=PAPER_CYCLE_S, min_pulse_s=0.04),
    ],
)
def test_invalid_params_rejected(kwargs):
    with pytest.raises(ValueError):
        PropulsionParams(**kwargs)
