"""The vehicle flown, resolved once (issue 27): one :class:`Vehicle` with its profile.

Oracles: Table 2 (the paper vehicle's jet-to-axis signs, ``rcsim/models/data/table2_jet_map.csv``),
Table 4 and sec. II (the paper's profile: ``table4_lookup_inputs.csv``, 40 ms, 0.3 deg/s), the
vehicle file's own keys (a profile key it gives wins, one it leaves out is the paper's), and
the SHA-256 of the file's bytes (hashlib).
"""

from __future__ import annotations

import hashlib
import math
import pickle

import pytest

from rcsim.models.errors import InputError
from rcsim.models.tables import (
    PAPER_CYCLE_S,
    PAPER_TOTAL_RATE_DEG_S,
    load_jet_map,
    load_lookup_inputs,
)
from rcsim.spacecraft.control_profile import CONTROL_KEYS, read_control
from rcsim.spacecraft.vehicle import Vehicle, resolve_vehicle
from rcsim.spacecraft.vehicle import vehicle as vehicle_module

SMALL = """
[vehicle]
name = "small"
[mass]
mass_kg = 30.0
cg_m = [0.0, 0.0, 0.0]
inertia_kg_m2 = [1.2, 1.0, 0.9]
[jet_defaults]
thrust_n = 1.0
{jets}
{control}
"""
#: Six jets, two per axis, torquing one axis each (a decoupled layout the phase plane flies).
JETS = "\n".join(
    f"[[jet]]\nposition_m = {pos}\ndirection = {d}"
    for pos, d in (
        ([0.0, 0.2, 0.0], [0, 0, 1]),
        ([0.0, 0.2, 0.0], [0, 0, -1]),
        ([0.0, 0.0, 0.2], [1, 0, 0]),
        ([0.0, 0.0, 0.2], [-1, 0, 0]),
        ([0.2, 0.0, 0.0], [0, 1, 0]),
        ([0.2, 0.0, 0.0], [0, -1, 0]),
    )
)


def _file(tmp_path, control: str = "", jets: str = JETS):
    path = tmp_path / "small.toml"
    path.write_text(SMALL.format(jets=jets, control=control))
    return path


def test_the_paper_profile_is_table_4_and_section_2(paper):
    """paper.toml's [control] transcribes the paper: Table 4 (its CSV, the one transcription
    of the table), the 40 ms cycle and the 0.3 deg/s rate cases of sec. II.  Exact: the same
    decimal numbers converted by the same factor."""
    table4, c = load_lookup_inputs(), paper.control
    assert c.maneuver_limit_rad == table4.maneuver_limit_rad
    assert c.maneuver_rate_rad_s == table4.maneuver_rate_rad_s
    assert c.rate_deadband_rad_s == table4.rate_error_limit_rad_s
    assert c.on_time_limit_s == table4.on_time_limit_s
    assert c.hold_time_s == table4.hold_time_s
    assert c.cycle_s == PAPER_CYCLE_S
    assert c.rate_case_rad_s == math.radians(PAPER_TOTAL_RATE_DEG_S)


def test_axis_signs_from_geometry_are_table_2(paper):
    """The jet-to-axis signs come from geometry for every vehicle; the paper's are Table 2."""
    assert (paper.axis_signs == load_jet_map()).all()


def test_a_vehicle_is_resolved_once_and_pickles_without_its_model(paper):
    """The compiled model is cached per process (one build however often it is asked for), and
    a vehicle pickles as its text and numbers: a spec travels to workers small."""
    vehicle_module._MODELS.pop(paper.model_key, None)
    before = vehicle_module.MODEL_BUILDS["count"]
    first = paper.model
    assert paper.model is first and Vehicle.load("paper").model is first
    assert vehicle_module.MODEL_BUILDS["count"] == before + 1
    blob = pickle.dumps(paper)
    assert len(blob) < 64_000  # text, definition and numbers; an MjModel is ~10x more
    back = pickle.loads(blob)
    assert back.model is first and back.sha256 == paper.sha256
    assert paper.sha256 == hashlib.sha256(resolve_vehicle("paper").read_bytes()).hexdigest()


def test_a_file_without_control_takes_the_paper_profile_and_says_so(tmp_path, paper):
    vehicle = Vehicle.load(_file(tmp_path))
    assert vehicle.control.values() == paper.control.values()
    assert "no [control]" in vehicle.control.source and "paper" in vehicle.control.source


def test_a_key_the_file_gives_wins_and_the_source_names_the_rest(tmp_path, paper):
    vehicle = Vehicle.load(
        _file(tmp_path, "[control]\nmaneuver_limit_deg = 1.5\n[control.phase_plane]\n"
              "attitude_deadband_deg = 0.5\n")
    )  # fmt: skip
    assert vehicle.control.maneuver_limit_rad == math.radians(1.5)
    assert vehicle.control.phase_plane_att_deadband_rad == math.radians(0.5)
    assert vehicle.control.cycle_s == paper.control.cycle_s
    assert "maneuver_limit_deg" not in vehicle.control.source.split("profile for")[-1]
    assert "cycle_s" in vehicle.control.source.split("profile for")[-1]


def test_overrides_apply_on_top_and_every_cycle_check_runs_again(tmp_path):
    vehicle = Vehicle.load(_file(tmp_path))
    slow = vehicle.with_control({"cycle_s": 0.08}, "a test")
    assert slow.control.cycle_s == 0.08 and slow.propulsion().cycle_s == 0.08
    assert "cycle_s from a test" in slow.control.source
    # paper.toml's physics step (40 ms) does not divide 100 ms: refused, naming both.
    with pytest.raises(InputError, match=r"physics.timestep_s.*100 ms.*with control cycle_s"):
        Vehicle.load("paper").with_control({"cycle_s": 0.1}, "a test")
    # A valve that opens 30 ms late cannot act within a 20 ms cycle (the on-time limit
    # lowered with the cycle: the paper's 30 ms is over a 20 ms cycle, refused first).
    delayed = _file(
        tmp_path,
        jets=JETS.replace("direction = [0, 0, 1]", "direction = [0, 0, 1]\nopen_delay_s = 0.03", 1),
    )  # noqa: E501
    with pytest.raises(InputError, match=r"open_delay_s.*20 ms control cycle"):
        Vehicle.load(
            delayed,
            control={"cycle_s": 0.02, "on_time_limit_s": 0.015},
            control_from="--control",
        )


@pytest.mark.parametrize(
    ("control", "match"),
    [
        ({"maneuver_limit": 0.8}, r"unknown key 'control.maneuver_limit'.*maneuver_limit_deg"),
        ({"cycle_s": 40.0}, r"control.cycle_s: must be within .* \(a cycle in ms\?\)"),
        ({"maneuver_band_deg": 0.7}, r"maneuver_band_deg: must be below the maneuver limit"),
        ({"hold_time_s": -1.0}, r"hold_time_s: must be >= 0"),
        ({"rate_deadband_deg_s": 0.0}, r"rate_deadband_deg_s: must be > 0"),
        ({"min_pulse": "round"}, r"control.min_pulse: must be one of accumulate, round-up, drop"),
        ({"min_pulse": 1.0}, r"control.min_pulse: must be one of .* \(got 1.0\)"),
    ],
)
def test_bad_profile_values_are_named(control, match):
    with pytest.raises(InputError, match=match):
        Vehicle.load("paper", control=control, control_from="--control")


def test_every_key_is_documented_and_round_trips(paper):
    """The record a manifest keeps reads back into the same profile (every key in it)."""
    record = paper.control.record()
    assert set(record) == {*CONTROL_KEYS, "source"}
    record.pop("source")
    back = read_control(record, None, where="a manifest")
    assert back.values() == paper.control.values()


def test_an_edited_vehicle_compiles_its_own_model(paper):
    from dataclasses import replace

    jets = tuple(replace(j, thrust_n=2 * j.thrust_n) for j in paper.definition.jets)
    strong = paper.edited(replace(paper.definition, jets=jets), "thrust doubled")
    assert strong.model_key != paper.model_key
    assert strong.nominal(1).thrust_n[0, 0] == 2 * paper.nominal(1).thrust_n[0, 0]
    assert "(thrust doubled)" in strong.ref


def test_the_minimum_pulse_policy_is_a_word_from_the_file_or_the_command_line(tmp_path, paper):
    """``min_pulse`` takes a word (the paper's ``accumulate``, paper.toml); ``--control``
    passes it as written, and the record keeps it (a manifest names the policy flown)."""
    from rcsim.spacecraft.control_profile import parse_assignments

    assert paper.control.min_pulse == "accumulate"
    file = Vehicle.load(_file(tmp_path, '[control]\nmin_pulse = "drop"\n'))
    assert file.control.min_pulse == "drop"
    flags = parse_assignments(["min_pulse=round-up", "cycle_s=0.08"])
    assert flags == {"min_pulse": "round-up", "cycle_s": 0.08}
    flown = Vehicle.load("paper", control=flags, control_from="--control")
    assert flown.control.min_pulse == "round-up" and flown.control.record()["min_pulse"] == (
        "round-up"
    )
    assert "min_pulse = round-up" in flown.control.describe()
