"""MuJoCo's stage timers read the zero clock in rcsim's simulations
(rcsim/spacecraft/mujoco_timers.py).

The claims: the physics does not change (the timers feed only ``MjData.timer``), the timers
stay at zero duration, and a callback the user installed is never replaced.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rcsim.spacecraft import mujoco_timers
from rcsim.spacecraft.vehicle import build_model, load_vehicle

pytestmark = pytest.mark.skipif(
    not mujoco_timers.zero_clock_available(),
    reason="the optional zero-clock extension was not built (no C compiler at install)",
)


@pytest.fixture
def no_callback():
    """Run with MuJoCo's default timers, and leave them as the test found them."""
    before = mujoco.get_mjcb_time()
    mujoco.set_mjcb_time(None)
    mujoco_timers._callback = None
    yield
    mujoco.set_mjcb_time(before)
    mujoco_timers._callback = before


def _fly(model: mujoco.MjModel, steps: int = 50) -> tuple[np.ndarray, mujoco.MjData]:
    data = mujoco.MjData(model)
    data.qvel[3:6] = [0.01, -0.02, 0.03]
    data.ctrl[:] = 0.0
    data.ctrl[0] = 1.0  # one jet on: a torque and a force, so every RK4 stage has work
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return np.concatenate([data.qpos, data.qvel]), data


def test_zero_clock_changes_no_state_and_reads_zero(no_callback):
    """Same model, same steps, with MuJoCo's clock and with the zero clock: the state must be
    bit-identical (the timers are bookkeeping only, so the tolerance is 0), and with the zero
    clock every stage timer's accumulated duration is 0 s while it still counts its calls."""
    model = build_model(load_vehicle("paper"))
    with_clock, timed = _fly(model)
    assert any(t.duration > 0.0 for t in timed.timer), "MuJoCo's own timers should measure time"
    assert mujoco_timers.quiet_stage_timers()
    with_zero, quiet = _fly(model)
    np.testing.assert_array_equal(with_zero, with_clock)
    assert all(t.duration == 0.0 for t in quiet.timer)
    assert sum(t.number for t in quiet.timer) == sum(t.number for t in timed.timer)


def test_a_users_callback_is_kept(no_callback):
    """A process that already times MuJoCo keeps its own callback."""
    mine = mujoco_timers._ZeroClock(lambda: 1.0)
    mujoco.set_mjcb_time(mine)
    assert not mujoco_timers.quiet_stage_timers()
    assert mujoco.get_mjcb_time() is mine


def test_simulations_install_it(paper, no_callback):
    """Building a batch simulation is enough: campaigns, scenarios and studies all do."""
    from rcsim.spacecraft.simulation import BatchSimulation

    build_model(load_vehicle("paper"))
    BatchSimulation(paper.nominal(2), vehicle=paper, nthread=1)
    assert mujoco.get_mjcb_time() is not None
