"""Physics-aware factors are computed from what the simulator flew.

Oracle: the simulator's own vehicle model -- :func:`rcsim.spacecraft.dispersions.draw_runs` builds
the dispersed vehicles the campaign flies and
:func:`rcsim.spacecraft.vehicle.run_parameters.torque_per_jet_B`
their jet torques; the factors are computed from the vehicles the runs table rebuilds from
the *recorded* columns (:func:`rcsim.analysis.engine.runs_table.input_frame`; the round trip itself
is ``tests/analysis/engine/test_runs_table.py``).
"""

import numpy as np
import pytest

from rcsim.analysis.engine.runs_table import input_frame
from rcsim.analysis.results.drivers.factors import fire_signs, physics_factors
from rcsim.models.tables import load_dispersions, load_jet_map
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.run_parameters import torque_per_jet_B

#: The paper's vehicle (paper.toml).
PAPER = Vehicle.load()


@pytest.fixture(scope="module")
def drawn(paper):
    sigmas = DispersionSigmas.from_table(load_dispersions(), scale=3.0)
    runs = draw_runs(paper.nominal(1), sigmas, seed=11, run_ids=np.arange(40))
    return runs, input_frame(runs)


def test_authority_is_group_torque_over_inertia(drawn, paper):
    runs, frame = drawn
    f = physics_factors(frame, PAPER)
    torque = torque_per_jet_B(runs.params, paper.model)
    jet_map = load_jet_map()
    for a, axis in enumerate(("roll", "pitch", "yaw")):
        jets = np.flatnonzero(jet_map[:, a] == -1)
        expected = -torque[:, jets, a].sum(axis=1) / runs.params.inertia_B[:, a]
        np.testing.assert_allclose(f[f"authority_{axis}_neg_rad_s2"], expected, rtol=1e-9)
        assert np.all(f[f"authority_{axis}_neg_rad_s2"] > 0)  # signed toward the group's way
        np.testing.assert_allclose(
            f[f"thrust_{axis}_neg_n"], runs.params.thrust_n[:, jets].sum(axis=1), rtol=1e-12
        )


def test_pointing_loss_is_zero_without_tilt(drawn):
    frame = drawn[1].copy()
    frame[[c for c in frame if c.endswith("_tilt_deg")]] = 0.0
    f = physics_factors(frame, PAPER)
    losses = f[[c for c in f if c.startswith("pointing_loss")]].to_numpy()
    np.testing.assert_allclose(losses, 0.0, atol=1e-12)


def test_fire_signs_follow_table3():
    # Table 3 case 13 is -0.3 deg/s yaw only; damping it fires the other way.
    np.testing.assert_array_equal(fire_signs(["rate-13"])[0], [0, 0, -1])
    np.testing.assert_array_equal(fire_signs(["damp-13"])[0], [0, 0, 1])
    assert fire_signs(["yaw-5deg"]) is None


def test_fire_factors_pick_the_firing_group(drawn):
    frame = drawn[1]
    signs = fire_signs(["rate-13"] * len(frame))
    f = physics_factors(frame, PAPER, signs)
    np.testing.assert_array_equal(f["authority_yaw_fire_rad_s2"], f["authority_yaw_neg_rad_s2"])
    # Roll not commanded in case 13: the mean of both groups.
    np.testing.assert_allclose(
        f["thrust_roll_fire_n"], 0.5 * (f["thrust_roll_pos_n"] + f["thrust_roll_neg_n"])
    )
