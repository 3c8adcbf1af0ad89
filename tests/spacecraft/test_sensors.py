"""Sensors (rcsim.spacecraft.sensors) in the closed loop, and the per-run effect draws
(rcsim.spacecraft.effect_draws).

Oracles
-------
* The measurement model of ``rcsim/spacecraft/sensors.py``: measured rate minus true rate is exactly
  ``bias + walk + sigma z`` with ``z`` the run's stream's standard normals, nine per cycle in a
  fixed order (so the test regenerates them from the same seed sequence: 1e-12 absolute, far
  below sigma).  Sample statistics: the white noise's sample standard deviation over N samples
  is within 10 % of sigma (its relative standard error is 1/sqrt(2N) = 2.2 % for N = 1000: 4.5
  standard errors); the random walk's standard deviation across 400 runs at time t is
  sigma_walk sqrt(t) within 20 % (standard error 3.5 %).  Seeds are fixed: deterministic.
* The controller sees the measured state, the history records both: the navigation state a
  recording controller received equals ``meas_*`` and differs from the true errors.
* Adding sensors/timing/faults draws never changes a run's Table 5 vehicle (the dispersion
  stream is untouched) and a run's draws do not depend on which other runs are drawn with it.
* A vehicle file's nominal delays (``draw_timing(..., nominal)``): the documented draw,
  ``max(0, nominal + mean + sigma z)`` per jet with ``z`` the run's timing stream's normals in
  their fixed order (command, then the opening, then the closing latencies), rebuilt from the
  stream: exact (the same operations on the same numbers).
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.models.errors import InputError
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
from rcsim.spacecraft.effect_draws import (
    SENSOR_NOISE,
    TIMING,
    FaultSpec,
    SensorSpec,
    TimingSpec,
    draw_faults,
    draw_sensors,
    draw_timing,
    effect_stream,
)
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.sensors import SensorParams
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.valves import ValveTiming

CYCLE_S = 0.04


class Recorder:
    """Never fires; records the rate error it is shown."""

    cycle_s = CYCLE_S

    def initial_state(self, n_runs):
        return []

    def step(self, nav, seen):
        seen.append(nav.rate_err_B.copy())
        return np.zeros((nav.n_runs, 16)), seen


def fly_idle(paper, n, duration_s, sensors, streams, w0=None):
    sim = BatchSimulation(
        paper.nominal(n),
        vehicle=paper,
        nthread=1,
        sensors=sensors,
        sensor_streams=streams,
    )
    rec = Recorder()
    seen = []
    hist = sim.run(
        rec, Guidance.attitude(np.zeros((n, 3))), duration_s, omega0_B=w0, ctrl_state=seen
    )
    return hist, np.stack(seen, axis=1)


def test_measured_rate_is_truth_plus_bias_walk_and_the_streams_normals(paper):
    n, cycles = 2, 300  # more than one block of drawn noise (256 cycles)
    sigma, bias, walk = 1e-4, np.array([2e-5, -1e-5, 0.0]), 3e-5
    sensors = SensorParams.of(
        n, rate_noise_rad_s=sigma, rate_bias_rad_s=bias, rate_walk_rad_s_per_sqrt_s=walk
    )
    streams = [effect_stream(7, i, SENSOR_NOISE) for i in range(n)]
    w0 = np.array([[0.01, 0.0, -0.02], [0.0, 0.003, 0.0]])
    hist, seen = fly_idle(paper, n, cycles * CYCLE_S, sensors, streams, w0)
    np.testing.assert_array_equal(seen, hist.meas_rate_err_B)  # what the controller saw
    for i in range(n):
        z = np.random.default_rng(streams[i]).standard_normal((cycles, 9))
        steps = walk * np.sqrt(CYCLE_S) * z[:, 6:9]
        walk_k = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)[:-1]])
        expected = hist.rate_err_B[i] + bias + walk_k + sigma * z[:, 3:6]
        np.testing.assert_allclose(hist.meas_rate_err_B[i], expected, rtol=0, atol=1e-12)
    assert np.abs(hist.meas_rate_err_B - hist.rate_err_B).max() > sigma  # not the truth


def test_white_attitude_noise_has_its_sigma(paper):
    sigma = np.radians(0.01)
    sensors = SensorParams.of(4, att_noise_rad=sigma)
    hist, _ = fly_idle(
        paper,
        4,
        250 * CYCLE_S,
        sensors,
        [effect_stream(3, i, SENSOR_NOISE) for i in range(4)],
    )
    err = (hist.meas_att_err_B - hist.att_err_B).reshape(-1, 3)  # 1000 samples per axis
    assert np.abs(err.std(axis=0) / sigma - 1).max() < 0.10
    np.testing.assert_array_equal(hist.att_err_B, 0.0)  # the truth stays at rest


def test_rate_walk_grows_as_sqrt_time(paper):
    n, cycles, walk = 400, 50, 1e-4
    sensors = SensorParams.of(n, rate_walk_rad_s_per_sqrt_s=walk)
    hist, _ = fly_idle(
        paper,
        n,
        cycles * CYCLE_S,
        sensors,
        [effect_stream(5, i, SENSOR_NOISE) for i in range(n)],
    )
    drift = (hist.meas_rate_err_B - hist.rate_err_B)[:, -1]  # walk after cycles-1 steps
    assert drift.std(axis=0) / (walk * np.sqrt((cycles - 1) * CYCLE_S)) == pytest.approx(
        np.ones(3), rel=0.2
    )


def test_noisy_sensors_need_streams_and_valid_sigmas(paper):
    with pytest.raises(InputError, match="sensor_streams"):
        BatchSimulation(
            paper.nominal(1),
            vehicle=paper,
            sensors=SensorParams.of(1, att_noise_rad=1e-4),
        )
    with pytest.raises(InputError, match="rate_noise_rad_s"):
        BatchSimulation(
            paper.nominal(1),
            vehicle=paper,
            sensors=SensorParams.of(1, rate_noise_rad_s=-1.0),
        )


def test_effect_draws_leave_vehicles_alone_and_do_not_depend_on_the_batch(paper):
    nominal = paper.nominal(1)
    sig = DispersionSigmas(mass_kg=10.0, thrust_n=0.5)
    before = draw_runs(nominal, sig, 11, [0, 1, 2]).params
    spec = SensorSpec(
        att_bias_sigma_rad=np.full(3, np.radians(0.01)),
        rate_noise_rad_s=np.full(3, np.radians(0.001)),
    )
    together, _ = draw_sensors(spec, 11, [0, 1, 2])
    alone, _ = draw_sensors(spec, 11, [2])
    np.testing.assert_array_equal(together.att_bias_rad[2], alone.att_bias_rad[0])
    assert np.abs(together.att_bias_rad).max() > 0
    timing = draw_timing(TimingSpec(open_delay_s=0.01, open_delay_sigma_s=0.002), 11, [0, 1], 16)
    assert (timing.open_delay_s >= 0).all() and timing.open_delay_s.std() > 0
    after = draw_runs(nominal, sig, 11, [0, 1, 2]).params
    np.testing.assert_array_equal(before.thrust_n, after.thrust_n)
    np.testing.assert_array_equal(before.mass_kg, after.mass_kg)


def test_timing_draws_disperse_about_a_vehicles_own_delays():
    n_jets, runs = 5, [3, 8, 9, 10, 11, 12]
    nominal = ValveTiming.of(
        1,
        command_delay_s=0.004,
        open_delay_s=[[0.001, 0.002, 0.003, 0.004, 0.0]],
        close_delay_s=[[0.005, 0.004, 0.003, 0.002, 0.001]],
    )
    spec = TimingSpec(
        command_delay_sigma_s=0.001,
        open_delay_sigma_s=0.002,
        close_delay_s=0.0,
        close_delay_sigma_s=0.0015,
    )
    got = draw_timing(spec, 11, runs, n_jets, nominal)
    z = np.array(
        [np.random.default_rng(effect_stream(11, i, TIMING)).standard_normal(11) for i in runs]
    )
    np.testing.assert_array_equal(got.command_delay_s, np.maximum(0.004 + 0.001 * z[:, 0], 0))
    np.testing.assert_array_equal(
        got.open_delay_s, np.maximum(nominal.open_delay_s + 0.002 * z[:, 1:6], 0)
    )
    np.testing.assert_array_equal(
        got.close_delay_s, np.maximum(nominal.close_delay_s + 0.0015 * z[:, 6:], 0)
    )
    assert (got.open_delay_s[:, 4] == 0).any()  # a zero nominal clips: the clip is exercised
    # A uniform nominal is the spec's mean: the same draws either way.
    uniform = ValveTiming.of(1, n_jets=n_jets, open_delay_s=0.003)
    np.testing.assert_array_equal(
        draw_timing(spec, 11, runs, n_jets, uniform).open_delay_s,
        draw_timing(TimingSpec(**{**spec.__dict__, "open_delay_s": 0.003}), 11, runs, n_jets)
        .open_delay_s,
    )  # fmt: skip


def test_fault_draw_fails_one_listed_jet_per_run_in_the_window():
    spec = FaultSpec(mode="off", jets=(13, 15), time_s=(1.0, 2.0))
    faults, drawn = draw_faults(spec, 4, np.arange(200), 16)
    failed = np.isfinite(faults.off_from_s)
    np.testing.assert_array_equal(failed.sum(axis=1), 1)
    assert set(np.flatnonzero(failed.any(axis=0)) + 1) == {13, 15}
    t = faults.off_from_s[failed]
    assert ((t >= 1.0) & (t <= 2.0)).all()
    np.testing.assert_array_equal(drawn.fault_jet.to_numpy(), np.argmax(failed, axis=1) + 1)
