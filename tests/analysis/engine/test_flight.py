"""rcsim.fly refuses what the CLI refuses, and a flight that loses control says so."""

from __future__ import annotations

import numpy as np
import pytest

import rcsim
from rcsim.analysis.engine.flight import Scenario, flight_summary, fly_batch
from rcsim.lookup.registry import make_controller
from rcsim.models.errors import InputError
from rcsim.spacecraft.history import CONTROL_LOST_DEG

SMALLSAT = "docs/examples/smallsat8.toml"


@pytest.fixture(scope="module")
def smallsat():
    from rcsim.spacecraft.vehicle import resolve_vehicle

    return rcsim.Vehicle.load(resolve_vehicle("paper").parents[3] / SMALLSAT)


def test_fly_refuses_a_disturbance_beyond_the_jets_as_the_campaign_does(smallsat):
    """smallsat8's largest yaw torque is 0.3087 N m (all jets of one sign, nominal thrust:
    ``rcsim vehicle check``; tests/analysis/engine/campaign/test_campaign_spec.py pins the
    same figure for a campaign's hold): 5 N m is 16 times it."""
    hold = Scenario(name="h", duration_s=30.0, disturbance_n_m=np.array([0.0, 0.0, 5.0]))
    with pytest.raises(InputError, match=r"Scenario 'h': disturbance_n_m: .*0\.3087\] N m"):
        rcsim.fly(hold, "allocator", vehicle=smallsat)
    # The one rule: the vehicle's, as the campaign spec and `scenario run` apply it.
    assert smallsat.disturbance_problem([0.0, 0.0, 5.0])
    assert smallsat.disturbance_problem([0.0, 0.0, 0.3]) == ""


def test_a_flight_that_loses_control_says_so(smallsat):
    """The same disturbance flown below the API's check (fly_batch, what campaigns use after
    their own): the attitude error sweeps to ~180 deg (the issue measured 179.9), far over the
    CONTROL_LOST_DEG line above its start of 0; the simulation itself did not fail."""
    hold = Scenario(name="h", duration_s=5.0, disturbance_n_m=np.array([0.0, 0.0, 5.0]))
    ctl = make_controller("allocator", smallsat)
    history = fly_batch([hold], smallsat.nominal(1), ctl, vehicle=smallsat)
    assert history.control_lost().tolist() == [True]
    summary = flight_summary(history)
    assert summary["control_lost"] and not summary["sim_failed"]
    assert summary["reason"].startswith("control lost at t = ")
    assert f"more than {CONTROL_LOST_DEG:g} deg above it" in summary["reason"]


def test_a_maneuver_that_reaches_its_target_keeps_control(smallsat):
    """A 5 deg yaw maneuver: its error falls from 5 deg, never rises 30 deg above it."""
    turn = Scenario(name="m", duration_s=30.0, att_cmd_rad=np.radians([0.0, 0.0, 5.0]))
    history = rcsim.fly(turn, "allocator", vehicle=smallsat)
    assert history.control_lost().tolist() == [False]
    summary = flight_summary(history)
    assert summary["control_lost"] is False and summary["reason"] == ""
