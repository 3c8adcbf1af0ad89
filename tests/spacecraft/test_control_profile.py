"""The flight-software profile's bounds (rcsim/spacecraft/control_profile.py).

Each bound is physical, from the profile's own values, its cycle and the vehicle's physics
step; every test below states where its edge comes from and checks a value just inside it
flies and one just outside is refused, naming the key.  The paper's profile (Gambone Table 4,
paper.toml) and every packaged or example vehicle keep them all.
"""

from __future__ import annotations

import math
import re

import pytest

from rcsim.models.errors import InputError
from rcsim.spacecraft.control_profile import bound_problems, validated_rate_rad_s, with_values
from rcsim.spacecraft.vehicle import PACKAGED_VEHICLES, Vehicle
from rcsim.spacecraft.vehicle.file_sections import paper_control

# Just outside a bound: 0.1 % over (any real value over the edge is refused; this one is far
# enough from it that rounding in the deg <-> rad conversion cannot decide).
OVER = 1.001
UNDER = 0.999


def _load(**control):
    return Vehicle.load("paper", control=control, control_from="--control")


def test_the_papers_profile_and_every_packaged_vehicle_keep_every_bound():
    assert bound_problems(paper_control()) == []
    for name in PACKAGED_VEHICLES:
        Vehicle.load(name)  # raises when a bound is broken


@pytest.mark.parametrize(
    ("key", "edge", "match"),
    [
        # Table 4: maneuver limit 0.6 deg / maneuver rate 0.2 deg/s = 3 s, the time to cross the
        # region inside the limit at the maneuver rate.
        ("hold_time_s", 0.6 / 0.2, r"control.hold_time_s: must be at most .* = 3 s"),
        # sec. II: the 40 ms cycle; a remaining on-time of a cycle is a firing under way.
        ("on_time_limit_s", 0.04, r"control.on_time_limit_s: must be at most the control cycle"),
        # A rotation's angle is at most 180 deg (no attitude error is larger).
        ("maneuver_limit_deg", 180.0, r"control.maneuver_limit_deg: must be below 180 deg"),
        ("phase_plane.attitude_deadband_deg", 180.0, r"attitude_deadband_deg: must be below 180"),
        # A maneuver from rest along a diagonal: per-axis rate error 0.2 / sqrt(3) deg/s.
        ("rate_deadband_deg_s", 0.2 / math.sqrt(3), r"rate_deadband_deg_s: must be below"),
        ("phase_plane.rate_deadband_deg_s", 0.2 / math.sqrt(3), r"sqrt\(3\) = 0.1155 deg/s"),
        ("allocator.rate_deadband_deg_s", 0.2 / math.sqrt(3), r"no jet firing"),
        ("allocator.trim_deadband_deg_s", 0.2 / math.sqrt(3), r"trim_deadband_deg_s: must be"),
        # docs/convergence.md: the 40 ms RK4 step is validated up to ~3 deg/s.
        ("maneuver_rate_deg_s", 3.0, r"maneuver_rate_deg_s: must be at most 3 deg/s"),
        ("rate_case_deg_s", 3.0, r"rate_case_deg_s: must be at most 3 deg/s.*40 ms physics step"),
    ],
)
def test_each_bound_refuses_just_outside_and_flies_just_inside(key, edge, match):
    # The strict bounds (below 180 deg, below the diagonal rate) refuse the edge itself.
    inside = edge * UNDER
    _load(**{key: inside})
    with pytest.raises(InputError, match=match) as err:
        _load(**{key: edge * OVER})
    assert str(err.value).startswith("--control: control.")


def test_the_key_just_set_is_the_one_named():
    """Lowering the maneuver rate under the paper's 0.06 deg/s lookup deadband (below
    sqrt(3) x 0.06 = 0.1039 deg/s) blames the maneuver rate, the value just set."""
    with pytest.raises(InputError, match=r"control.maneuver_rate_deg_s: must be above sqrt"):
        _load(maneuver_rate_deg_s=0.1)
    # The same rule set in code names the field the code set.
    p = paper_control()
    with pytest.raises(InputError, match=r"^code: maneuver_rate_rad_s: must be above"):
        with_values(p, maneuver_rate_rad_s=math.radians(0.1))
    with pytest.raises(InputError, match=r"^code: hold_time_s: must be at most"):
        with_values(p, hold_time_s=1e9)


def test_the_rate_bound_keeps_the_validated_rotation_per_step(tmp_path):
    """3 deg/s x 40 ms = 0.12 deg per physics step (docs/convergence.md); a vehicle stepping
    at 20 ms is validated up to 6 deg/s, the same rotation per step."""
    assert math.degrees(validated_rate_rad_s(0.04)) == pytest.approx(3.0, rel=1e-12)
    assert math.degrees(validated_rate_rad_s(0.02)) == pytest.approx(6.0, rel=1e-12)
    text = (
        "[mass]\nmass_kg = 100.0\ncg_m = [0.0, 0.0, 0.0]\ninertia_kg_m2 = [10.0, 10.0, 10.0]\n"
        "[physics]\ntimestep_s = 0.02\n[jet_defaults]\nthrust_n = 10.0\n[[jet]]\n"
        "position_m = [1.0, 0.0, 0.0]\ndirection = [0, 1, 0]\n[control]\n"
        "maneuver_limit_deg = 5.0\n"  # the paper's 0.16 s hold within 5 / 6 s (hold bound)
    )
    fine = tmp_path / "fine.toml"
    fine.write_text(text + "maneuver_rate_deg_s = 5.9\n")
    assert Vehicle.load(fine).control.maneuver_rate_rad_s == math.radians(5.9)
    fine.write_text(text + "maneuver_rate_deg_s = 6.1\n")
    with pytest.raises(InputError, match=r"fine.toml: control.maneuver_rate_deg_s: .* 6 deg/s"):
        Vehicle.load(fine)


def test_the_absurd_values_of_the_issue_are_refused_not_flown():
    """Each was accepted with exit 0 (1e300 deg/s overflowed the sanity warnings' rate^2)."""
    for key, value in [
        ("hold_time_s", 1e9),
        ("on_time_limit_s", 10.0),
        ("maneuver_limit_deg", 1000.0),
        ("rate_case_deg_s", 500.0),
        ("allocator.trim_deadband_deg_s", 1e6),
        ("rate_deadband_deg_s", 1e300),
        ("maneuver_rate_deg_s", 1e300),
    ]:
        got = re.escape(f"(got {value:g})")
        with pytest.raises(InputError, match=rf"control\.{re.escape(key)}: .*{got}"):
            _load(**{key: value})
