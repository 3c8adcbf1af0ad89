"""A vehicle file's own ``[failure]``: the defaults of a campaign of it (a spec's ``[failure]``
still wins), and where the paper's 0.04 deg/s (Gambone sec. III) judges another vehicle the
manifest, the summary line and the report say so."""

from __future__ import annotations

import math

import pytest

from rcsim.analysis.engine.campaign.runner import _new_manifest
from rcsim.analysis.engine.campaign.spec import (
    DEFAULT_RATE_ERROR_DEG_S,
    SPEC_FAILURE_SOURCE,
    failure_note,
    load_spec,
)
from rcsim.analysis.results.drivers.report_sections import _criterion
from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle import Vehicle

# A 100 kg cube with one yaw pair: any layout flies a spec here (it is only read, not flown).
VEHICLE = (
    '[vehicle]\nname = "cube"\n[mass]\nmass_kg = 100.0\ncg_m = [0.0, 0.0, 0.0]\n'
    "inertia_kg_m2 = [10.0, 10.0, 10.0]\n[jet_defaults]\nthrust_n = 10.0\n"
    "[[jet]]\nposition_m = [1.0, 0.0, 0.0]\ndirection = [0, 1, 0]\n"
    "[[jet]]\nposition_m = [1.0, 0.0, 0.0]\ndirection = [0, -1, 0]\n"
)
SPEC = """
vehicle = "{vehicle}"
runs_per_case = 1
[scenario]
kind = "maneuver"
attitude_deg = [0.0, 0.0, 1.0]
duration_s = 1.0
[controller]
name = "allocator"
"""


def _spec(tmp_path, vehicle_extra: str = "", spec_extra: str = "", vehicle: str | None = None):
    if vehicle is None:
        path = tmp_path / "cube.toml"
        path.write_text(VEHICLE + vehicle_extra)
        vehicle = str(path)
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC.format(vehicle=vehicle) + spec_extra)
    return load_spec(spec)


def test_the_vehicle_files_failure_is_the_campaigns_default(tmp_path):
    spec = _spec(tmp_path, "[failure]\nrate_error_deg_s = 0.01\nattitude_error_deg = 2.0\n")
    assert spec.rate_threshold_rad_s == pytest.approx(math.radians(0.01), rel=1e-12)
    assert spec.attitude_threshold_rad == pytest.approx(math.radians(2.0), rel=1e-12)
    assert spec.resolved["failure"] == {"rate_error_deg_s": 0.01, "attitude_error_deg": 2.0}
    assert "cube.toml's own [failure]" in spec.failure_source
    assert failure_note(spec) == spec.failure_source  # a summary line says it


def test_a_specs_failure_still_wins(tmp_path):
    spec = _spec(
        tmp_path,
        "[failure]\nrate_error_deg_s = 0.01\n",
        "[failure]\nrate_error_deg_s = 0.02\n",
    )
    assert spec.resolved["failure"]["rate_error_deg_s"] == 0.02
    assert spec.failure_source == SPEC_FAILURE_SOURCE and failure_note(spec) == ""


def test_the_papers_threshold_on_another_vehicle_is_said(tmp_path):
    spec = _spec(tmp_path)
    assert spec.resolved["failure"]["rate_error_deg_s"] == DEFAULT_RATE_ERROR_DEG_S
    note = failure_note(spec)
    assert "the paper's 0.04 deg/s (Gambone sec. III" in note and "applied to cube" in note
    manifest = _new_manifest(spec, None)
    assert manifest["thresholds"]["source"] == note
    # The report's criterion line (rcsim analyze) carries it from the manifest.
    assert _criterion(manifest).endswith(f"({note})")


def test_the_papers_threshold_on_the_papers_vehicle_is_not_remarked(tmp_path):
    spec = _spec(tmp_path, vehicle="paper")
    assert spec.rate_threshold_rad_s == pytest.approx(math.radians(0.04), rel=1e-12)
    assert failure_note(spec) == ""
    assert spec.failure_source == "rate threshold from the paper's (Gambone sec. III)"


@pytest.mark.parametrize(
    ("failure", "match"),
    [
        # The paper's maneuver rate is 0.2 deg/s (Table 4): a run ending at it still turns.
        ("rate_error_deg_s = 0.2", r"failure.rate_error_deg_s: must be below the maneuver rate"),
        ("rate_error_deg_s = 0.0", r"failure.rate_error_deg_s: must be > 0"),
        # No attitude error exceeds 180 deg.
        ("attitude_error_deg = 180.0", r"failure.attitude_error_deg: must be below 180 deg"),
        ("max_failed_pct = 5", r"unknown key 'failure.max_failed_pct'"),
    ],
)
def test_a_vehicle_files_failure_keeps_its_ranges(tmp_path, failure, match):
    path = tmp_path / "v.toml"
    path.write_text(VEHICLE + "[failure]\n" + failure + "\n")
    with pytest.raises(InputError, match=match):
        Vehicle.load(path)
