"""The compiled per-cycle passes (rcsim/spacecraft/_cycle_kernel.c) are the numpy forms bit for bit.

Oracles: the numpy forms the kernel transcribes -- :func:`rcsim.spacecraft.navigation.navigate`,
:func:`rcsim.spacecraft.propulsion.apply_valve_limits` with
:func:`rcsim.spacecraft.valves.command_valves`,
:func:`rcsim.spacecraft.pieces.cycle_pieces`, ``Pieces.on_time_s`` and
:func:`rcsim.spacecraft.valves.end_cycle` (``RCSIM_NUMPY_CYCLE=1`` switches the kernel off in a
flight).  Equality is exact (bytes, signed zeros included), not a tolerance: the kernel claims the
same operations in the same order, and campaigns must give the same ``runs.parquet`` with or without
it.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from rcsim.spacecraft import cycle_kernel
from rcsim.spacecraft.navigation import CommandBlocks, Guidance, navigate, quat_from_rotvec
from rcsim.spacecraft.pieces import cycle_pieces
from rcsim.spacecraft.propulsion import PropulsionParams, PropulsionState, apply_valve_limits
from rcsim.spacecraft.valves import ValveState, ValveTiming, command_valves, end_cycle

pytestmark = pytest.mark.skipif(
    cycle_kernel._cycle_kernel is None, reason="the optional extension was not built"
)

CYCLE_S = 0.04


def _same(a, b, name=""):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype, name
    assert a.tobytes() == b.tobytes(), name


def _unit_quats(rng, n):
    """Attitudes that reach every branch of the rotation vector: w < 0 (the longer way
    round), exactly the command (angle 0, the s <= 1e-12 guard), tiny and large angles."""
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    small = rng.random(n) < 0.3
    q[small] = quat_from_rotvec(rng.normal(size=(small.sum(), 3)) * 1e-7)
    q[rng.random(n) < 0.05] = [1.0, 0.0, 0.0, 0.0]
    q[rng.random(n) < 0.05] = [-1.0, 0.0, 0.0, 0.0]
    return q


@pytest.mark.parametrize("per_run", [True, False])
def test_navigation_is_numpys(per_run):
    rng = np.random.default_rng(1)
    n = 2000
    q = _unit_quats(rng, n)
    w = rng.normal(size=(n, 3)) * 0.01
    m = n if per_run else 1
    att = rng.normal(size=(m, 3))
    for rate in (np.zeros((m, 3)), rng.normal(size=(m, 3)) * 0.003):
        guidance = Guidance(quat_from_rotvec(att), rate)
        reference = navigate(0.8, q, w, guidance)
        q_cmd, omega_cmd = guidance.at(0.8)
        compiled = cycle_kernel.navigate(0.8, q, w, q_cmd, omega_cmd)
        _same(compiled.att_err_B, reference.att_err_B, "att_err_B")
        _same(compiled.rate_err_B, reference.rate_err_B, "rate_err_B")


def test_command_blocks_are_guidance_at_every_cycle():
    """A block of cycles' commanded attitudes at once, per distinct command, equals
    Guidance.at cycle by cycle (a signed zero is a command of its own)."""
    rng = np.random.default_rng(2)
    rates = np.radians([[0.3, 0, 0], [-0.0, 0.2, 0.2], [0.0, 0.2, 0.2], [0, 0, 0]])
    omega = rates[rng.integers(0, 4, 300)]
    guidance = Guidance(quat_from_rotvec(np.zeros((300, 3))), omega)
    commands = CommandBlocks(guidance, CYCLE_S)
    assert commands.distinct.omega_cmd_B.shape[0] == 4
    for k in list(range(0, 200)) + [1000, 1063, 1064, 5]:  # across blocks, and back
        _same(commands.at(k), guidance.at(k * CYCLE_S)[0], f"cycle {k}")


def _valve_inputs(rng, n, n_jets, cycle):
    """Commands that reach every rule: NaN, negative, above the cycle, a full cycle, short
    pulses under the minimum, zero; and runs that failed."""
    cmd = rng.choice(
        [np.nan, -0.01, 0.0, -0.0, 0.001, 0.004, 0.02, cycle, cycle * (1 - 1e-13), 0.07],
        size=(n, n_jets),
    )
    failed = rng.random(n) < 0.05
    return cmd, failed


@pytest.mark.parametrize("delays", [False, True])
def test_valve_cycles_are_numpys(delays):
    """60 cycles of commands through both forms in lockstep: delivered on-times, propulsion
    counters and every valve slot equal after each cycle (with command and valve delays the
    slots fill, overlap and close before they open)."""
    rng = np.random.default_rng(3)
    n, n_jets = 400, 16
    params = PropulsionParams(cycle_s=CYCLE_S, min_pulse_s=0.003)
    if delays:
        timing = ValveTiming.of(
            n,
            n_jets=n_jets,
            command_delay_s=rng.uniform(0, 0.01, n),
            open_delay_s=rng.uniform(0, 0.02, (n, n_jets)),
            close_delay_s=rng.uniform(0, 0.025, (n, n_jets)),
        )
    else:
        timing = ValveTiming.of(n, n_jets=n_jets)
    prop_r, valves_r = PropulsionState.zeros(n, n_jets), ValveState.closed(n, n_jets)
    prop_c, valves_c = copy.deepcopy(prop_r), copy.deepcopy(valves_r)
    thrust = np.full((n, n_jets), 22.24)
    for k in range(60):
        cmd, failed = _valve_inputs(rng, n, n_jets, CYCLE_S)
        on_r = apply_valve_limits(
            np.where(failed[:, None], 0.0, cmd), prop_r, params, thrust, account=False
        )
        command_valves(valves_r, on_r, timing, CYCLE_S)
        on_c = cycle_kernel.command_valves(cmd, failed, prop_c, params, valves_c, timing)
        _same(on_c, on_r, f"on, cycle {k}")
        for name in ("on_at_end", "firings", "dropped"):
            _same(getattr(prop_c, name), getattr(prop_r, name), f"{name}, cycle {k}")
        for name in ("start", "end", "was_on"):
            _same(getattr(valves_c, name), getattr(valves_r, name), f"{name}, cycle {k}")
        tail = 0.004 if delays else 0.0
        end_cycle(valves_r, CYCLE_S, tail)
        cycle_kernel.end_cycle(valves_c, CYCLE_S, tail)
        _same(valves_c.start, valves_r.start, f"start after the cycle {k}")
        _same(valves_c.end, valves_r.end, f"end after the cycle {k}")
    assert prop_r.dropped.sum() > 0 and prop_r.firings.sum() > 0  # the rules were reached


def test_the_no_switch_test_and_the_totals_are_cycle_pieces():
    """Intervals with and without a switch inside the cycle: the kernel says uniform exactly
    when cycle_pieces does, with the same jets on, and adds the same on-time and impulse."""
    rng = np.random.default_rng(4)
    n, n_jets = 300, 16
    seen = set()
    for trial in range(200):
        full = rng.random((n, n_jets, 3)) < 0.1
        start = np.where(full, rng.choice([0.0, -0.01, -np.inf], size=full.shape), np.nan)
        end = np.where(full, rng.choice([CYCLE_S, 0.05, np.inf], size=full.shape), np.nan)
        if trial % 2:  # a few intervals that start, end or lie inside the cycle
            k = rng.integers(0, n, 3)
            start[k, 0, 0] = rng.choice([0.001, -0.02, 0.0])
            end[k, 0, 0] = rng.choice([0.03, 0.0, -0.001, CYCLE_S])
        pieces = cycle_pieces(start, end, CYCLE_S)
        on = cycle_kernel.uniform_on(start, end, CYCLE_S)
        assert (on is not None) == pieces.uniform
        seen.add(pieces.uniform)
        if on is None:
            continue
        _same(on, pieces.on[:, 0], "on")
        prop_r, prop_c = PropulsionState.zeros(n, n_jets), PropulsionState.zeros(n, n_jets)
        prop_r.on_time_s[:] = prop_c.on_time_s[:] = rng.random((n, n_jets))
        thrust = rng.uniform(20, 24, (n, n_jets))
        delivered_r = pieces.on_time_s()
        prop_r.on_time_s += delivered_r
        prop_r.impulse_ns += pieces.thrust_time_s() * thrust
        delivered_c = cycle_kernel.account(on, CYCLE_S, thrust, prop_c)
        _same(delivered_c, delivered_r, "delivered")
        _same(prop_c.on_time_s, prop_r.on_time_s, "on_time_s")
        _same(prop_c.impulse_ns, prop_r.impulse_ns, "impulse_ns")
    assert seen == {True, False}


def test_bounded_state_decides_as_the_finite_sum_does():
    """Finite states below 1e300 pass; a NaN, an infinity or a huge entry sends the check to
    the numpy form (which alone names the runs)."""
    rng = np.random.default_rng(5)
    state = rng.normal(size=(50, 30))
    qpos, qvel = state[:, 1:8], state[:, 8:14]
    assert cycle_kernel.bounded_state(state, qpos, qvel)
    for bad in (np.nan, np.inf, -np.inf, 1e301):
        state[17, 10] = bad
        assert not cycle_kernel.bounded_state(state, qpos, qvel)
    state[17, 10] = 0.0
    state[17, 20] = np.nan  # outside qpos and qvel: not looked at
    assert cycle_kernel.bounded_state(state, qpos, qvel)


def _fly(monkeypatch, numpy_form, **kw):
    from rcsim.analysis.engine.campaign.chunk import fly_runs

    if numpy_form:
        monkeypatch.setenv("RCSIM_NUMPY_CYCLE", "1")
    else:
        monkeypatch.delenv("RCSIM_NUMPY_CYCLE", raising=False)
    return fly_runs(**kw)[0]


SENSORS_AND_TIMING = """
[dispersions.sensor]
att_noise_deg = 0.003
rate_noise_deg_s = 0.001
rate_bias_sigma_deg_s = 0.003
[dispersions.timing]
command_delay_s = 0.005
open_delay_s = 0.008
open_delay_sigma_s = 0.002
close_delay_s = 0.005
close_delay_sigma_s = 0.002
"""
SPECS = {
    "lookup": "",
    # Noisy sensors, valve delays (switches mid-cycle: the numpy cut), stuck-on windows and
    # failures mid-flight (more intervals per jet), degraded thrust (the level factors).
    "stuck": SENSORS_AND_TIMING
    + '[dispersions.fault]\nmode = "stuck"\ntime_s = [0.0, 3.0]\nstuck_for_s = [0.1, 0.5]\n',
    "off": '[dispersions.fault]\nmode = "off"\ntime_s = [0.0, 3.0]\n',
    "degraded": '[dispersions.fault]\nmode = "degraded"\nthrust_factor = [0.6, 0.9]\n',
}


@pytest.mark.parametrize("kind", sorted(SPECS))
def test_a_campaign_flight_is_the_same_with_and_without_the_kernel(monkeypatch, tmp_path, kind):
    """26 rate cases x 2 runs under Table 5 dispersions, 20 s: every recorded array of the
    history equal byte for byte."""
    from rcsim.analysis.engine.campaign.spec import load_spec

    path = tmp_path / "spec.toml"
    path.write_text(
        'seed = 11\nruns_per_case = 2\n[scenario]\ncases = "all"\nduration_s = 20\n'
        '[controller]\nname = "lookup"\n' + SPECS[kind]
    )
    spec = load_spec(path)
    ids = np.arange(spec.n_runs)
    compiled = _fly(monkeypatch, False, spec=spec, run_ids=ids)
    reference = _fly(monkeypatch, True, spec=spec, run_ids=ids)
    for name, value in vars(reference).items():
        if isinstance(value, np.ndarray):
            _same(getattr(compiled, name), value, name)
    for name in ("on_time_s", "impulse_ns", "firings", "dropped"):
        _same(getattr(compiled.propulsion, name), getattr(reference.propulsion, name), name)
    _same(compiled.final.att_err_B, reference.final.att_err_B, "final att_err_B")
    assert compiled.reason == reference.reason
    assert np.asarray(compiled.on_time_s).sum() > 0  # the controller fired


def test_phase_plane_partial_pulses_are_the_same(paper, monkeypatch):
    """The phase-plane controller fires pulses shorter than a cycle (cycles cut into pieces,
    the numpy cut) and the propellant of a vehicle file runs out in some runs."""
    from rcsim.lookup.phase_plane import PhasePlaneController, PhasePlaneParams
    from rcsim.spacecraft.propellant import PropellantTank
    from rcsim.spacecraft.simulation import simulate_batch
    from rcsim.spacecraft.vehicle import build_model, load_vehicle

    build_model(load_vehicle("paper"))
    controller = PhasePlaneController(PhasePlaneParams.for_vehicle(paper))
    n = 6
    params = paper.nominal(n)
    att = np.radians([[5, 0, 0], [0, -5, 0], [3, 4, -5], [5, 5, 5], [-2, 1, 0], [0, 0, 8]])
    tank = PropellantTank.of(n, [1.0, 1.0, 0.02, 1.0, 0.005, 1.0], [1.0, 0.1, 0.0])
    histories = []
    for numpy_form in (False, True):
        if numpy_form:
            monkeypatch.setenv("RCSIM_NUMPY_CYCLE", "1")
        histories.append(
            simulate_batch(
                params, controller, Guidance.attitude(att), 12.0, vehicle=paper, tank=tank
            )
        )
    compiled, reference = histories
    for name in ("q_BN", "omega_B", "att_err_B", "rate_err_B", "on_time_s"):
        _same(getattr(compiled, name), getattr(reference, name), name)
    _same(compiled.propellant_exhausted_s, reference.propellant_exhausted_s, "exhausted")
    assert np.isfinite(reference.propellant_exhausted_s).any()
