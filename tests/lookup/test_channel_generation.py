"""A channel table generated for the canted-quad vehicle (``canted16``: every jet torques two or
three axes), flown by the lookup controller (issue 18).

Oracles and limits:

* **each case reaches its command**: the 26 rate cases of Table 3, from rest, nominal vehicle,
  20 s (a campaign's duration), closed loop with the table: every axis ends within 0.04 deg/s
  of its command -- the paper's rate-case success threshold (sec. III).  The whole-cycle table
  can leave at most half a cycle's rate change on an axis, 0.035 deg/s for the strongest
  channel (+-yaw, 1.75 deg/s^2 x 40 ms / 2), under the threshold;
* **nearest whole cycle**: for the single-axis cases the table's cycles are the whole number
  nearest the analytic ``|omega| / (alpha cycle)`` (a rigid body from rest: rate change =
  angular acceleration x time; ``alpha`` the recipe's nominal acceleration), i.e. off by at
  most half a cycle, plus 2 % of a cycle for the gyroscopic and valve effects the simulation
  has and the formula not;
* **rate damping** (paper Figs 3-4): the damping flights need the command's cycles on the
  opposing channels in 26/26 cases, as on the paper vehicle;
* **valves**: no pulse the controller commands is dropped by the valves' 10 ms minimum
  on-time (the delivery owes short shares until they reach it);
* **file round trip**: table and recipe read back bit for bit; ``--jets-off`` re-solves the
  recipes without the jet.
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.lookup.channel_generation import generate_channel_table
from rcsim.lookup.pattern_recognition import LookupController, LookupParams
from rcsim.models.tables import PAPER_CYCLE_S, load_lookup_table
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.vehicle import Vehicle

#: The lookup logic's inputs from the paper vehicle's profile (paper.toml [control]).
LOOKUP_PARAMS = LookupParams.from_profile(Vehicle.load().control)


@pytest.fixture(scope="module")
def generated():
    return generate_channel_table(Vehicle.load("canted16"))


def test_table_flies_every_case_to_its_command(generated):
    vehicle = Vehicle.load("canted16")
    rate = np.asarray(generated.table.rate_cmd, float)
    n = rate.shape[0]
    history = simulate_batch(
        vehicle.nominal(n), LookupController(generated.table, LOOKUP_PARAMS),
        Guidance.rate(rate), 20.0, vehicle=vehicle, nthread=1,
    )  # fmt: skip
    assert not history.failed.any()
    final = np.degrees(np.abs(history.final.rate_err_B))
    assert final.max() < 0.04, final.max(axis=1)
    assert history.propulsion.dropped.sum() == 0
    assert history.propulsion.firings.sum() > 0


def test_single_axis_cycles_are_the_nearest_whole_cycle(generated):
    table = generated.table
    accel = np.abs(generated.table.recipe.accel_rad_s2)  # (6, 3)
    single = np.flatnonzero((np.asarray(table.rate_cmd) != 0).sum(axis=1) == 1)
    assert single.size == 6
    for c in single:
        a = int(np.flatnonzero(table.rate_cmd[c])[0])
        k = 2 * a + (0 if table.rate_cmd[c, a] > 0 else 1)
        exact = abs(table.rate_cmd[c, a]) / (accel[k, a] * PAPER_CYCLE_S)
        cycles = table.firing_time_s[c, k] / PAPER_CYCLE_S
        assert abs(cycles - exact) <= 0.5 + 0.02, (c, cycles, exact)


def test_open_loop_verification_and_damping(generated):
    assert np.degrees(np.abs(generated.verify_rate_err_rad_s)).max() < 0.04
    assert generated.damping_equal.all()
    assert (generated.settle_after_firing_s >= 0).all()


def test_files_round_trip_and_jets_off(generated, tmp_path):
    path = generated.table.to_csv(tmp_path / "t.csv")
    back = load_lookup_table(path)
    assert np.array_equal(back.firing_time_s, generated.table.firing_time_s)
    assert np.array_equal(back.recipe.fractions, generated.table.recipe.fractions)
    assert back.recipe.vehicle == "canted16" and back.recipe.min_on_s == 0.010
    off = generate_channel_table(Vehicle.load("canted16"), jets_off=(3,))
    assert off.table.recipe.jets_off == (3,)
    assert off.table.recipe.fractions[:, 2].max() == 0.0
    assert off.table.recipe.served.all()  # canted16 loses no direction to one jet
    # Rows the paper's rule kept end within the failure threshold open loop; a tuned row may
    # not (it may leave the controller's last-cycle re-plan to finish it), but it ends within
    # the target in closed loop, or is named (test_row_tuning.py checks the figures).
    kept = ~off.nominal.tuned
    assert np.degrees(np.abs(off.verify_rate_err_rad_s[kept])).max() < 0.04
    assert all(met or reason for met, reason in zip(off.nominal.met, off.nominal.reason))
