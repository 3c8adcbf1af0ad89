"""Vehicle-file sanity (issue 31 item 7): range messages name the right key, and physically odd
but legal values earn a warning (:mod:`rcsim.spacecraft.vehicle.sanity`).

Oracles: Newton's second law (a jet's acceleration of the whole vehicle, ``F / m / g0``), the
valve model's dead pulse (``open_delay - close_delay``, rcsim/spacecraft/valves.py docstring),
constant-acceleration braking ``rate^2 / (2 alpha)`` and a pulse's rate change ``alpha t``,
with ``alpha`` each direction's pure-axis authority as ``rcsim vehicle check`` prints it.
"""

from __future__ import annotations

import math

import pytest

from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle import Vehicle, resolve_vehicle
from rcsim.spacecraft.vehicle.axis_authority import axis_authorities
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2
from rcsim.spacecraft.vehicle.sanity import MAX_JET_ACCEL_G

EXAMPLES = resolve_vehicle("paper").parents[3] / "docs" / "examples"


def _paper_with(tmp_path, old: str, new: str, count: int = 1):
    text = resolve_vehicle("paper").read_text()
    assert old in text
    path = tmp_path / "edited.toml"
    path.write_text(text.replace(old, new, count))
    return path


def test_a_cg_in_mm_is_blamed_on_the_cg_not_on_a_jet(tmp_path):
    path = _paper_with(tmp_path, "cg_m = [1.41, 0.0, 0.0]", "cg_m = [1410.0, 0.0, 0.0]")
    with pytest.raises(InputError) as err:
        Vehicle.load(path)
    message = str(err.value)
    assert "mass.cg_m" in message and "a CG in mm?" in message and "jet[" not in message


def test_one_jet_in_mm_is_still_blamed_on_that_jet(tmp_path):
    path = _paper_with(tmp_path, "position_m = [1.41, 0.812", "position_m = [1.41, 812.0")
    with pytest.raises(InputError, match=r"jet\[1\].*position_m.*from the CG"):
        Vehicle.load(path)


@pytest.mark.parametrize("name", ["paper", "canted16", "canted12", "service_module"])
def test_the_packaged_vehicles_and_the_examples_earn_no_warning(name):
    assert Vehicle.load(name).warnings() == []


def test_the_service_module_example_earns_no_warning():
    assert Vehicle.load(EXAMPLES / "service16.toml").warnings() == []


def test_a_1000_n_jet_on_150_kg_is_said_with_its_acceleration(tmp_path):
    """The issue's case: 1,000 N on a 150 kg satellite, F / m / g0 = 0.680 g."""
    jets = "\n".join(
        f"[[jet]]\nposition_m = {pos}\ndirection = {d}"
        for pos, d in (([0.0, 0.4, 0.0], [0, 0, 1]), ([0.0, -0.4, 0.0], [0, 0, -1]))
    )
    path = tmp_path / "strong.toml"
    path.write_text(
        '[vehicle]\nname = "strong"\n[mass]\nmass_kg = 150.0\ncg_m = [0.0, 0.0, 0.0]\n'
        f"inertia_kg_m2 = [15.0, 13.0, 11.0]\n[jet_defaults]\nthrust_n = 1000.0\n{jets}\n"
    )
    warnings = Vehicle.load(path).warnings()
    expected = 1000.0 / 150.0 / G0_M_S2
    assert expected > MAX_JET_ACCEL_G
    (line,) = [w for w in warnings if " g, over " in w]
    assert f"{expected:.3g} g" in line and "1000 N on 150 kg" in line
    assert line.startswith("jet_01, jet_02:")


def test_a_minimum_pulse_the_valve_never_opens_for_is_said(tmp_path):
    """open 12 ms, close 2 ms: a pulse under 10 ms never opens the valve; min_on_s 5 ms lets
    the controllers command one (valves.py docstring)."""
    path = _paper_with(
        tmp_path,
        "min_on_s = 0.0 ",
        "min_on_s = 0.005\nopen_delay_s = 0.012\nclose_delay_s = 0.002 ",
    )
    (line,) = [w for w in Vehicle.load(path).warnings() if "never opens" in w]
    assert "= 10 ms never opens" in line and "min_on_s = 5 ms" in line
    assert line.startswith("jet_01, jet_02 and 14 more")


def test_a_maneuver_rate_the_jets_cannot_brake_within_the_limit_is_said():
    """The paper's vehicle at 2 deg/s: braking at the weakest authority takes
    rate^2 / (2 alpha) of turn, over the 0.6 deg maneuver limit."""
    vehicle = Vehicle.load("paper", control={"maneuver_rate_deg_s": 2.0}, control_from="a test")
    alpha = axis_authorities(vehicle.definition)
    braking_deg = math.degrees(math.radians(2.0) ** 2 / (2 * alpha.min()))
    assert braking_deg > 0.6
    (line,) = [w for w in vehicle.warnings() if "braking" in w]
    assert f"takes {braking_deg:.3g} deg of turn" in line
    assert "control.maneuver_limit_deg = 0.6" in line


def test_a_minimum_pulse_coarser_than_the_maneuver_rate_is_said():
    """smallsat8: 20 ms minimum pulses of 1 N jets on 30 kg; alpha * min_on at the strongest
    direction against the 0.2 deg/s maneuver rate."""
    vehicle = Vehicle.load(EXAMPLES / "smallsat8.toml")
    alpha = axis_authorities(vehicle.definition)
    step_deg_s = math.degrees(alpha.max() * 0.02)
    (line,) = vehicle.warnings()
    assert f"changes its rate by {step_deg_s:.3g} deg/s" in line
    assert f"{step_deg_s / 0.2:.2g} times the maneuver rate" in line
    # Retuned in its profile (a smallsat maneuvers faster), the warning goes.
    fast = vehicle.with_control({"maneuver_rate_deg_s": 1.0}, "a test")
    assert fast.warnings() == []
