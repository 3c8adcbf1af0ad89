"""A vehicle with modes flies through rcsim.fly, and its history records each mode's
coordinate and rate (history.parquet's columns)."""

from __future__ import annotations

import numpy as np
import pytest

import rcsim
from rcsim.analysis.engine.flight import Scenario, history_frame
from rcsim.spacecraft.modes.linear import mode_table

WING = """
[[appendage]]
name = "wing"
mass_kg = 30.0
inertia_kg_m2 = [15.0, 2.5, 12.5]
hinge_m = [1.41, 0.9, 0.0]
axis = [1.0, 0.0, 0.0]
cg_offset_m = [0.0, 1.6, 0.0]
frequency_hz = 0.4
damping_ratio = 0.002
"""


@pytest.fixture(scope="module")
def winged(tmp_path_factory):
    """canted16 with one solar wing (one flexible mode, coupled to roll)."""
    from rcsim.spacecraft.vehicle import resolve_vehicle

    path = tmp_path_factory.mktemp("winged") / "winged.toml"
    path.write_text(resolve_vehicle("canted16").read_text(encoding="utf-8") + WING)
    return rcsim.Vehicle.load(path)


def test_the_recorded_wing_rings_at_its_coupled_frequency(winged):
    """After the last firing of a 2 deg roll maneuver the wing swings freely: its recorded
    angle oscillates at the coupled (free-hub) frequency of the linearised vehicle
    (rcsim.spacecraft.modes.linear, itself checked against hand-derived eigenproblems in
    tests/spacecraft/modes/test_modes_oracles.py).  Measured from the record's crossings of
    its mean (40 ms samples, linear interpolation) over ~45 periods: 9e-6 relative; tolerance
    1e-4 (damping 0.2 % lowers the frequency by 2e-6, and the decaying amplitude biases the
    crossings of a fixed mean by less than 1e-5)."""
    turn = Scenario(name="m", duration_s=120.0, att_cmd_rad=np.radians([2.0, 0.0, 0.0]))
    history = rcsim.fly(turn, "allocator", vehicle=winged)
    assert history.mode_names == ("wing_hinge",) and history.mode_kinds == ("angle",)
    assert history.mode_q is not None and history.mode_qd is not None
    assert history.mode_q[0, 0, 0] == 0.0 and history.mode_qd[0, 0, 0] == 0.0  # at rest
    fired = np.flatnonzero(history.on_time_s[0].sum(axis=1) > 0)
    free = slice(fired.max() + 1, None)
    assert history.t_s[free][0] < 20.0  # the maneuver is over early: ~100 s of free swing
    q, t = history.mode_q[0, free, 0], history.t_s[free]
    x = q - q.mean()
    i = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    crossings = t[i] + x[i] / (x[i] - x[i + 1]) * history.cycle_s
    measured = (len(crossings) - 1) / (2 * (crossings[-1] - crossings[0]))
    (expected,) = mode_table(winged.model).coupled_hz
    assert measured == pytest.approx(expected, rel=1e-4)
    # history.parquet's columns: the angle and its rate in degrees
    frame = history_frame(history)
    np.testing.assert_array_equal(frame["wing_hinge_deg"], np.degrees(history.mode_q[0, :, 0]))
    np.testing.assert_array_equal(frame["wing_hinge_deg_s"], np.degrees(history.mode_qd[0, :, 0]))


def test_spring_slosh_columns_are_metres():
    """A spring slosh mode's columns are ``<joint>_m`` and ``<joint>_m_s``; a rigid vehicle
    records no mode."""
    from rcsim.spacecraft.vehicle import resolve_vehicle

    example = resolve_vehicle("paper").parents[3] / "docs/examples/canted16_modes.toml"
    v = rcsim.Vehicle.load(example)
    turn = Scenario(name="m", duration_s=2.0, att_cmd_rad=np.radians([0.0, 1.0, 0.0]))
    frame = history_frame(rcsim.fly(turn, "allocator", vehicle=v))
    for name in ("tank_lateral_1", "tank_lateral_2"):
        assert f"{name}_m" in frame and f"{name}_m_s" in frame
    for name in ("wing_plus_y_hinge", "wing_minus_y_hinge"):
        assert f"{name}_deg" in frame and f"{name}_deg_s" in frame
    rigid = rcsim.fly(turn, "allocator", vehicle="canted16")
    assert rigid.mode_q is None and rigid.mode_names == ()
    assert not [c for c in history_frame(rigid).columns if c.endswith("_m_s")]
