"""The runs table's owner: a dispersed vehicle written to its row and rebuilt from it.

Oracle: the simulator's own draw (:func:`rcsim.spacecraft.dispersions.draw_runs`, whose jet pointing
is :func:`rcsim.spacecraft.dispersions.pointing`) and
:func:`rcsim.spacecraft.vehicle.run_parameters.torque_per_jet_B`: rebuilding the vehicles from the
*recorded* columns must give the drawn directions to 1e-12 (the degree conversion of tilt and
azimuth is the only round-off) and the same torques to rtol 1e-9.
"""

import numpy as np
import pytest

from rcsim.analysis.engine.runs_table import (
    MANIFEST,
    input_frame,
    input_names,
    is_campaign,
    recorded_jets,
    vehicles_from_runs,
)
from rcsim.models.tables import load_dispersions
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
from rcsim.spacecraft.vehicle.run_parameters import torque_per_jet_B


@pytest.fixture(scope="module")
def drawn(paper):
    sigmas = DispersionSigmas.from_table(load_dispersions(), scale=3.0)
    runs = draw_runs(paper.nominal(1), sigmas, seed=11, run_ids=np.arange(40))
    return runs, input_frame(runs)


def test_input_columns_are_the_schemas(drawn):
    # One owner: the frame a draw writes has exactly the schema's input columns, in order.
    assert tuple(drawn[1].columns) == input_names(16)  # the packaged vehicle's 16 jets
    assert recorded_jets(drawn[1].columns) == 16


def test_rebuilt_vehicles_give_the_simulators_torques(drawn, paper):
    runs, frame = drawn
    rebuilt, straight = vehicles_from_runs(frame, paper.nominal(1))
    np.testing.assert_allclose(rebuilt.jet_dir_S, runs.params.jet_dir_S, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        torque_per_jet_B(rebuilt, paper.model),
        torque_per_jet_B(runs.params, paper.model),
        rtol=1e-9,
        atol=1e-12,
    )
    # Nominal pointing: every jet along its site z axis (0, 0, 1).
    np.testing.assert_array_equal(straight.jet_dir_S[..., 2], 1.0)


def test_a_campaign_is_recognised_by_its_manifest(tmp_path):
    assert not is_campaign(tmp_path)
    (tmp_path / MANIFEST).write_text("{}")
    assert is_campaign(tmp_path)
