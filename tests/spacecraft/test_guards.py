"""What the closed loop refuses and how it records a diverged run (rcsim.spacecraft.simulation,
rcsim.spacecraft.guards).

Oracles
-------
* MuJoCo's documented behaviour (mujoco 4.0, ``mj_checkPos``/``mj_checkVel``/``mj_checkAcc``):
  a NaN, infinite or huge (> 1e10) ``qpos``/``qvel``/``qacc`` raises a warning
  (``mjWARN_BADQPOS`` ...), counts it in ``MjData.warning`` and resets the simulation.  A run
  whose physics diverged must therefore be failed with that warning's name and text, never
  recorded as a flight.  Without a user warning handler MuJoCo appends the text to
  ``MUJOCO_LOG.TXT`` in the current directory; with one it does not.
* Batching must not change a run (tests/spacecraft/test_simulation.py): a healthy run beside a
  diverging one equals that run flown alone, bit for bit.
* The control cycle: a controller and the valves on different clocks cannot both be right,
  so the pair is refused (issue 8: at 80 ms propulsion the 40 ms lookup controller reported
  28 firings instead of 4).
* Memory: the history of the paper vehicle (16 jets) is
  ``history_bytes_per_run_cycle(16)`` = (4 + 3 + 3 + 3 + 16) float64 = 232 bytes per run per
  cycle plus 8 bytes of ``t_s`` per cycle; a flight needing more than the budget is refused
  before anything is allocated, one needing exactly the budget flies.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rcsim.lookup.phase_plane import PhasePlaneController, PhasePlaneParams
from rcsim.lookup.registry import ALL_CONTROLLERS, make_controller
from rcsim.lookup.table_generation import RateFiringLoop
from rcsim.models.errors import InputError
from rcsim.models.tables import PAPER_CYCLE_S, load_jet_map
from rcsim.spacecraft import guards
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import BatchSimulation, simulate_batch

#: The paper's vehicle (paper.toml).

HOLD_S = 2.0  # the 1e8 N m cases diverge within 0.4 s (MuJoCo's own warning times)


@pytest.fixture(scope="module")
def phase_plane(paper):
    return PhasePlaneController(PhasePlaneParams.for_vehicle(paper))


def hold(n):
    return Guidance.attitude(np.zeros((n, 3)))


@pytest.fixture
def default_warning_handler():
    """MuJoCo's default handler (none installed) for the test, restored afterwards: a test that
    relies on rcsim installing its own must not pass because an earlier test did."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(None)
    yield
    mujoco.set_mju_user_warning(previous)


@pytest.mark.parametrize("case", ["disturbance_1e8_n_m", "initial_rate_1e5_deg_s"])
def test_diverged_run_is_failed_with_mujocos_reason(
    case, paper, phase_plane, tmp_path, monkeypatch, default_warning_handler
):
    """The two cases of issue 8, flown in a batch beside a healthy run, in an empty cwd."""
    monkeypatch.chdir(tmp_path)
    params = paper.nominal(2)
    omega0 = np.zeros((2, 3))
    torque = np.zeros((2, 3))
    if case == "disturbance_1e8_n_m":
        torque[1, 0] = 1e8
    else:
        omega0[1, 0] = np.radians(1e5)
    kw = dict(omega0_B=omega0, disturbance_B=torque, vehicle=paper, nthread=2)
    hist = simulate_batch(params, phase_plane, hold(2), HOLD_S, **kw)

    assert hist.failed.tolist() == [False, True]
    assert hist.reason[0] == ""
    why = hist.reason[1]
    assert why.startswith("MuJoCo mjWARN_BADQ"), why
    assert "The simulation is unstable." in why and " at t = " in why
    # Frozen from its failure: no jet fires after the cycle MuJoCo warned in.
    t_fail = float(why.split(" at t = ")[1].split(" .. ")[0])
    assert 0.0 < t_fail < HOLD_S
    k_fail = int(round(t_fail / PAPER_CYCLE_S))
    assert not hist.on_time_s[1, k_fail + 1 :].any()
    # The healthy run is untouched by its neighbour: equal to it flown alone, bit for bit.
    alone = simulate_batch(
        params.take([0]),
        phase_plane,
        hold(1),
        HOLD_S,
        omega0_B=omega0[:1],
        disturbance_B=torque[:1],
        vehicle=paper,
        nthread=1,
    )
    np.testing.assert_array_equal(hist.q_BN[0], alone.q_BN[0])
    np.testing.assert_array_equal(hist.on_time_s[0], alone.on_time_s[0])
    # MuJoCo's message went to the run's record, not to a stray file in the cwd.
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert list(tmp_path.iterdir()) == []


def test_caller_warning_handler_is_kept(paper, phase_plane, tmp_path, monkeypatch):
    """A handler the caller installed gets MuJoCo's text (the same the run's reason quotes)."""
    monkeypatch.chdir(tmp_path)
    seen = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(seen.append)
    try:
        hist = simulate_batch(
            paper.nominal(1),
            phase_plane,
            hold(1),
            HOLD_S,
            disturbance_B=np.array([[1e8, 0.0, 0.0]]),
            vehicle=paper,
        )
    finally:
        mujoco.set_mju_user_warning(previous)
    assert hist.failed[0]
    text = hist.reason[0].split(": ", 1)[1]
    assert len(seen) == 1 and seen[0].startswith(text)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_nan_disturbance_is_mujocos_bad_ctrl(paper, phase_plane):
    """A NaN torque command: MuJoCo zeroes the controls with mjWARN_BADCTRL (and flies on
    without the disturbance); the run is failed, not flown undisturbed."""
    hist = simulate_batch(
        paper.nominal(1),
        phase_plane,
        hold(1),
        0.2,
        disturbance_B=np.array([[np.nan, 0.0, 0.0]]),
        vehicle=paper,
    )
    assert hist.failed[0]
    assert hist.reason[0].startswith("MuJoCo mjWARN_BADCTRL at t = 0 .. 0.04 s: ")


# ------------------------------------------------------------------------------------------
# One control cycle
# ------------------------------------------------------------------------------------------
def test_every_controller_takes_the_vehicles_cycle(paper):
    """Issue 27: the cycle has one owner, the vehicle's profile: every controller built for a
    vehicle, its valve limits and the flight loop take it (the paper's 40 ms, and 80 ms when
    the profile says so).  Oracle: the profile's ``cycle_s``."""
    for vehicle in (paper, paper.with_control({"cycle_s": 0.08}, "test")):
        cycle = vehicle.control.cycle_s
        cycles = {name: make_controller(name, vehicle).cycle_s for name in ALL_CONTROLLERS}
        cycles["PropulsionParams"] = vehicle.propulsion().cycle_s
        cycles["RateFiringLoop"] = RateFiringLoop(load_jet_map(), cycle).cycle_s
        assert cycles == dict.fromkeys(cycles, cycle)
    assert paper.control.cycle_s == PAPER_CYCLE_S  # paper.toml's profile: sec. II's 40 ms


@pytest.mark.parametrize("which", ["lookup", "phase-plane"])
def test_controller_on_another_cycle_is_refused(which, paper):
    """Issue 8: a controller on 40 ms flown on an 80 ms loop must be refused, not fly."""
    slow = paper.with_control({"cycle_s": 0.08}, "test")
    ctl = make_controller(which, paper)  # built for the 40 ms profile
    sim = BatchSimulation(slow.nominal(1), slow)
    with pytest.raises(InputError) as err:
        sim.run(ctl, Guidance.attitude(np.radians([[0.0, 0.0, 5.0]])), 1.0)
    message = str(err.value)
    assert "cycle_s = 0.04 s" in message and "cycle 0.08 s" in message


def test_controller_on_the_same_cycle_flies(paper):
    """The refusal is about disagreement: both at 80 ms is a valid (if coarser) loop."""
    slow = paper.with_control({"cycle_s": 0.08}, "test")
    hist = simulate_batch(
        slow.nominal(1),
        make_controller("lookup", slow),
        Guidance.attitude(np.radians([[0.0, 0.0, 5.0]])),
        0.8,
        vehicle=slow,
    )
    assert hist.t_s.size == 10 and not hist.failed[0]
    assert hist.propulsion.firings[0].sum() > 0


# ------------------------------------------------------------------------------------------
# Memory
# ------------------------------------------------------------------------------------------
def test_history_too_large_is_refused_up_front(paper, phase_plane):
    """Issue 8: --duration-s 1e12 tried to allocate 182 TiB.  Refused with InputError (not
    MemoryError: nothing of that size was attempted), naming the need and what to do."""
    with pytest.raises(InputError) as err:
        simulate_batch(paper.nominal(1), phase_plane, hold(1), 1e12, vehicle=paper)
    message = str(err.value)
    assert err.value.parameter == "duration_s" and message.startswith("duration_s = 1e+12 s")
    n_cycles = 25_000_000_000_000  # 1e12 s / 40 ms
    assert f"{n_cycles} control cycles" in message
    assert f"{n_cycles * (232 + 8)} bytes" in message
    assert "shorten the flight" in message and "smaller batches" in message


def test_memory_budget_boundary(paper, phase_plane, monkeypatch):
    """Exactly the budget flies; one byte less is refused (2 runs, 1 s = 25 cycles)."""
    params = paper.nominal(2)
    need = 25 * (2 * 232 + 8)
    assert guards.history_bytes(2, 25, n_jets=16) == need
    monkeypatch.setattr(guards, "memory_budget_bytes", lambda: need)
    hist = simulate_batch(params, phase_plane, hold(2), 1.0, vehicle=paper)
    assert hist.t_s.size == 25
    recorded = sum(
        getattr(hist, k).nbytes
        for k in ("t_s", "q_BN", "omega_B", "att_err_B", "rate_err_B", "on_time_s")
    )
    assert recorded == need
    monkeypatch.setattr(guards, "memory_budget_bytes", lambda: need - 1)
    with pytest.raises(InputError, match="needs 11.5 KiB"):
        simulate_batch(params, phase_plane, hold(2), 1.0, vehicle=paper)


def test_memory_budget_is_half_the_physical_memory():
    budget = guards.memory_budget_bytes()
    import os

    if not hasattr(os, "sysconf"):
        assert budget is None
        return
    physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    assert budget == physical // 2
