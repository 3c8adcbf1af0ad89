"""Lookup tables regenerated for a vehicle with failed jets (generate_table(vehicle, jets_off=...)).

Oracles
-------
* Table 2 and the MJCF geometry: jets 13 and 15 are the yaw- pair, each with the same arm
  (0.724 m) and thrust, so with jet 13 failed, jet 15 alone gives half the pair's torque: the
  continuous firing time to reach a rate doubles.  Tables hold whole 40 ms cycles chosen as the
  nearest to the command, so the regenerated time is within one cycle of twice the full
  table's; the other axes' jets and times are unchanged (the same flights).
* Newton: jet 15 alone pushes the CG along +y (its force direction); the recorded velocity
  change is impulse / mass = F t / m (Table 1 thrust and mass), to rounding.
* With both yaw- jets off no jet serves yaw-: those cases (9 of the 26 have a negative yaw
  command) fire nothing on yaw and are recorded unreachable.
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.lookup.generation import generate_table
from rcsim.lookup.jet_sets import jets_off_of
from rcsim.lookup.pattern_recognition import LookupController
from rcsim.models.errors import InputError
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.valves import JetFaults
from rcsim.spacecraft.vehicle import Vehicle

#: The paper's vehicle (paper.toml).
PAPER = Vehicle.load()

CYCLE_S = 0.04
J13, J15 = 12, 14  # 0-based columns of jets 13, 15


@pytest.fixture(scope="module")
def full():
    return generate_table(Vehicle.load())


@pytest.fixture(scope="module")
def without_13():
    return generate_table(Vehicle.load(), jets_off=(13,))


def test_single_jet_fires_twice_as_long_and_the_rest_is_unchanged(full, without_13):
    t_full = full.table.firing_time_s
    t_off = without_13.table.firing_time_s
    yaw_minus = np.asarray(full.table.rate_cmd)[:, 2] < 0
    assert yaw_minus.sum() == 9
    np.testing.assert_array_equal(t_off[:, J13], 0.0)
    assert np.abs(t_off[yaw_minus, J15] - 2 * t_full[yaw_minus, J15]).max() <= CYCLE_S + 1e-9
    others = [j for j in range(16) if j not in (J13, J15)]
    np.testing.assert_array_equal(t_off[:, others], t_full[:, others])
    assert not without_13.unreachable.any()


def test_translation_side_effect_is_recorded(without_13, table1):
    yaw_only = (np.sign(np.asarray(without_13.table.rate_cmd)) == [0, 0, -1]).all(axis=1)
    t15 = without_13.table.firing_time_s[yaw_only, J15]
    np.testing.assert_allclose(
        without_13.dv_B_m_s[yaw_only, 1], table1.thrust_n * t15 / table1.mass_kg, rtol=1e-12
    )
    frame = without_13.settling_frame()
    assert set(frame.jets_off) == {"13"}
    assert {"dv_x_m_s", "dv_y_m_s", "dv_z_m_s", "unreachable_yaw"} <= set(frame.columns)


def test_both_yaw_minus_jets_off_makes_yaw_minus_unreachable():
    gen = generate_table(Vehicle.load(), jets_off=(15, 13))
    yaw_minus = np.asarray(gen.table.rate_cmd)[:, 2] < 0
    np.testing.assert_array_equal(gen.unreachable[:, 2], yaw_minus)
    np.testing.assert_array_equal(gen.table.firing_time_s[:, [J13, J15]], 0.0)
    assert gen.jets_off == (13, 15)


def test_regenerated_table_loads_by_its_companion_and_flies(without_13, tmp_path, paper):
    path = tmp_path / "t13.csv"
    without_13.table.to_csv(path)
    without_13.settling_frame().to_csv(tmp_path / "t13_settling.csv", index=False)
    assert jets_off_of(path) == (13,)
    ctl = LookupController.from_files(path, PAPER.control)
    assert ctl.jets_off == (13,)
    off = np.full((1, 16), np.inf)
    off[0, J13] = 0.0
    hist = simulate_batch(
        paper.nominal(1),
        ctl,
        Guidance.attitude(np.radians([[0.0, 0.0, -5.0]])),
        40.0,
        vehicle=paper,
        faults=JetFaults.of(1, off_from_s=off),
    )
    assert hist.propulsion.impulse_ns[0, J13] == 0.0
    assert hist.propulsion.impulse_ns[0, J15] > 0.0
    # Without its companion the same file is checked against Table 2, and refused.
    (tmp_path / "t13_settling.csv").unlink()
    with pytest.raises(InputError):
        LookupController.from_files(path, PAPER.control)


@pytest.mark.parametrize("bad", [(0,), (17,), (13, 13), ("x",)])
def test_bad_jets_off_is_refused(bad):
    with pytest.raises(InputError, match="jets_off"):
        generate_table(Vehicle.load(), jets_off=bad)
