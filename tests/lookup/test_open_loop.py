"""The open-loop controller (rcsim.lookup.open_loop): the pulses it commands, cycle by cycle.

Oracle: its definition -- jet j on for total_s[j] from t = 0, so cycle k delivers
clip(total - k cycle, 0, cycle) and the on-times sum to total_s.
"""

import numpy as np
import pytest

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.tables import PAPER_CYCLE_S
from rcsim.spacecraft.navigation import NavState


def _nav(n):
    z = np.zeros((n, 3))
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    return NavState(t_s=0.0, q_BN=q, omega_B=z, att_err_B=z, rate_err_B=z, omega_cmd_B=z)


def test_pulses_sum_to_the_total_and_a_row_serves_every_run():
    total = np.zeros(16)
    total[0], total[5] = 0.017, 0.1  # a sub-cycle pulse and one of 2.5 cycles
    ctl = OpenLoopController(total, PAPER_CYCLE_S)
    k, on = ctl.initial_state(3), []
    for _ in range(4):
        step, k = ctl.step(_nav(3), k)
        on.append(step)
    on = np.array(on)  # (cycles, runs, jets)
    assert on.shape == (4, 3, 16)
    np.testing.assert_allclose(on.sum(axis=0), np.tile(total, (3, 1)), atol=1e-15)
    np.testing.assert_allclose(on[:, 0, 5], [0.04, 0.04, 0.02, 0.0], atol=1e-15)


def test_shapes_are_checked():
    with pytest.raises(ValueError, match="shape"):
        OpenLoopController(np.zeros((2, 3, 16)), PAPER_CYCLE_S)
    with pytest.raises(ValueError, match="shape"):
        OpenLoopController(np.zeros(0), PAPER_CYCLE_S)
    with pytest.raises(ValueError, match="2 runs"):
        OpenLoopController(np.zeros((2, 16)), PAPER_CYCLE_S).initial_state(3)
