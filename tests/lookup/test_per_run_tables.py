"""Per-run candidate tables in one batch (LookupController.for_runs), used by refinement.

Oracle: batched equals scalar (dm_control's vectorization test): a batch in which run i flies
table i gives, run by run, exactly what flying each table alone gives.
"""

import numpy as np
import pytest

from rcsim.analysis.engine.flight import Scenario, fly_batch
from rcsim.lookup.pattern_recognition import LookupController, LookupParams
from rcsim.lookup.table_edits import jet_axes, shift_axes, with_times
from rcsim.models.tables import PAPER_CYCLE_S, load_lookup_table
from rcsim.spacecraft.vehicle import Vehicle, build_model, load_vehicle

#: The lookup logic's inputs from the paper vehicle's profile (paper.toml [control]).
LOOKUP_PARAMS = LookupParams.from_profile(Vehicle.load().control)


def test_batch_of_candidates_equals_each_table_alone(paper):
    build_model(load_vehicle("paper"))
    table = load_lookup_table(which="table6")
    shift = np.zeros((26, 3), int)
    shift[25, 2] = -1  # case 26, yaw one cycle shorter
    edited = shift_axes(table.firing_time_s, jet_axes(table), shift, PAPER_CYCLE_S)
    times = np.stack([table.firing_time_s, edited])
    rate = table.rate_cmd[25]  # case 26 of Table 3: from rest, the scale factor is exactly 1
    scn = Scenario("rate-26", 3.0, rate_cmd_rad_s=rate)
    params = paper.nominal(2)
    batch = fly_batch(
        [scn, scn], params, LookupController.for_runs(table, times, LOOKUP_PARAMS), vehicle=paper
    )
    for i, t in enumerate(times):
        alone = fly_batch(
            [scn],
            paper.nominal(1),
            LookupController(with_times(table, t, "candidate"), LOOKUP_PARAMS),
            vehicle=paper,
        )
        np.testing.assert_array_equal(batch.on_time_s[i], alone.on_time_s[0])
        np.testing.assert_array_equal(batch.omega_B[i], alone.omega_B[0])
    # The edit shows in the first firing (the first 0.4 s, before any correction): the yaw
    # pair fires one 40 ms cycle less in the candidate run, 2 jets x 0.04 s.
    yaw = jet_axes(table) == 2
    first = batch.t_s < 0.4
    on = batch.on_time_s[:, first][:, :, yaw].sum(axis=(1, 2))
    np.testing.assert_allclose(on[0] - on[1], 2 * 0.04, atol=1e-12)


def test_candidates_may_not_change_which_jets_fire():
    table = load_lookup_table(which="table6")
    times = np.array(table.firing_time_s)[None].copy()
    times[0, 0, np.flatnonzero(times[0, 0] == 0)[0]] = 0.04
    with pytest.raises(ValueError, match="which jets fire"):
        LookupController.for_runs(table, times, LOOKUP_PARAMS)
