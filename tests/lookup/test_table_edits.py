"""Lookup-table edits in whole control cycles (rcsim.lookup.table_edits).

Oracles: the paper's Table 6 (jet pairs of an axis share one firing time, all times are whole
40 ms cycles, Gambone sec. II) and the arithmetic of a shift.
"""

import numpy as np
import pytest

from rcsim.lookup.table_edits import axis_cycles, jet_axes, shift_axes
from rcsim.models.tables import PAPER_CYCLE_S, load_lookup_table


@pytest.fixture(scope="module")
def table6():
    return load_lookup_table(which="table6")


def test_axis_cycles_of_table6(table6):
    """Table 6: case 26 (+,+,+) fires roll 0.28 s, pitch 0.28 s, yaw 0.24 s (7, 7, 6 cycles of
    40 ms); case 22 (+,0,0) fires roll only, 0.52 s (13 cycles)."""
    cycles = axis_cycles(table6.firing_time_s, jet_axes(table6), PAPER_CYCLE_S)
    row = {int(c): i for i, c in enumerate(table6.case)}
    np.testing.assert_array_equal(cycles[row[26]], [7, 7, 6])
    np.testing.assert_array_equal(cycles[row[22]], [13, 0, 0])


def test_shift_moves_the_whole_pair_by_whole_cycles(table6):
    jet_axis = jet_axes(table6)
    shift = np.zeros((26, 3), int)
    shift[25, 2] = -1  # case 26, yaw one cycle shorter
    new = shift_axes(table6.firing_time_s, jet_axis, shift, PAPER_CYCLE_S)
    diff = new - table6.firing_time_s
    yaw_jets = np.flatnonzero((jet_axis == 2) & (table6.firing_time_s[25] > 0))
    assert yaw_jets.size == 2  # a balanced pair (Table 2)
    np.testing.assert_allclose(diff[25, yaw_jets], -PAPER_CYCLE_S, atol=1e-12)
    diff[25, yaw_jets] = 0.0
    assert np.all(diff == 0.0)  # nothing else moved, no jet started or stopped
    # Shifting back restores the table exactly (times are snapped to whole cycles).
    np.testing.assert_array_equal(
        shift_axes(new, jet_axis, -shift, PAPER_CYCLE_S), table6.firing_time_s
    )


def test_refused_edits(table6):
    jet_axis = jet_axes(table6)
    cycles = axis_cycles(table6.firing_time_s, jet_axis, PAPER_CYCLE_S)
    c, a = np.argwhere(cycles == 0)[0]
    shift = np.zeros((26, 3), int)
    shift[c, a] = 1
    with pytest.raises(ValueError, match="does not fire"):
        shift_axes(table6.firing_time_s, jet_axis, shift, PAPER_CYCLE_S)
    c, a = np.argwhere(cycles > 0)[0]
    shift[:] = 0
    shift[c, a] = -int(cycles[c, a])  # would leave zero cycles
    with pytest.raises(ValueError, match="less than one control cycle"):
        shift_axes(table6.firing_time_s, jet_axis, shift, PAPER_CYCLE_S)
