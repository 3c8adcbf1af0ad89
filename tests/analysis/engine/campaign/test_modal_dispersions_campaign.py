"""A campaign of a vehicle whose file disperses its modes: each run's runs.parquet row holds
the modes it flew (the draws of its own stream, whatever the chunk), a replay re-flies a run
exactly, and a vehicle with modes but no modal dispersion has no mode columns."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.spacecraft.modes.draws import draw_modes
from rcsim.spacecraft.vehicle import Vehicle, resolve_vehicle
from tests.analysis.engine.campaign.test_modes_campaign import MODES

SIGMAS = {
    "damping_ratio = 0.01\n\n[[appendage]]": (
        "damping_ratio = 0.01\nmass_kg_3sigma = 3.0\nfrequency_hz_3sigma = 0.06\n"
        "damping_ratio_3sigma = 0.006\n\n[[appendage]]"
    ),
}
WING = "frequency_hz = 0.4\ndamping_ratio = 0.01\n"

SPEC = """
seed = 9
runs_per_case = 2
vehicle = "{vehicle}"
[scenario]
kind = "rate-cases"
cases = [5, 13, 26]
duration_s = 6.0
[controller]
name = "allocator"
[output]
histories = "none"
plots = false
"""


def _vehicle_text(dispersed: bool) -> str:
    modes = MODES
    if dispersed:
        for old, new in SIGMAS.items():
            assert old in modes
            modes = modes.replace(old, new)
        assert modes.endswith(WING)
        modes += "frequency_hz_3sigma = 0.09\n"
    return resolve_vehicle("canted16").read_text(encoding="utf-8") + modes


def _campaign(where, name: str, dispersed: bool) -> pd.DataFrame:
    (where / f"{name}.toml").write_text(_vehicle_text(dispersed), encoding="utf-8")
    spec = where / f"{name}_spec.toml"
    spec.write_text(SPEC.format(vehicle=f"{name}.toml"), encoding="utf-8")
    run_campaign(load_spec(spec), where / name, progress=False)
    return pd.read_parquet(where / name / "runs.parquet")


COLUMNS = [
    f"mode_{m}_{q}"
    for m, qs in (
        ("tank", ("freq_hz", "coupled_freq_hz", "damping", "mass_kg")),
        ("wing", ("freq_hz", "coupled_freq_hz", "damping", "inertia_kg_m2")),
    )
    for q in qs
]


def test_rows_hold_the_modes_each_run_flew(tmp_path, capsys):
    """The mode columns, in the file's order, are each run's draws (drawn here again, alone:
    bit for bit), the panel's inertia its 91.8 kg m^2 about the hinge (15 + 30 x 1.6^2), and
    each coupled frequency above its clamped one (the hub moves against the mode); a replay
    matches its row exactly; without the *_3sigma keys there is no mode column."""
    runs = _campaign(tmp_path, "dispersed", True)
    assert [c for c in runs if c.startswith("mode_")] == COLUMNS
    modes = Vehicle.load(tmp_path / "dispersed.toml").definition.modes
    drawn = draw_modes(modes, 9, runs["run_id"].to_numpy())
    np.testing.assert_array_equal(runs["mode_tank_mass_kg"], drawn.mass_kg[:, 0])
    np.testing.assert_array_equal(runs["mode_tank_freq_hz"], drawn.frequency_hz[:, 0])
    np.testing.assert_array_equal(runs["mode_tank_damping"], drawn.damping_ratio[:, 0])
    np.testing.assert_array_equal(runs["mode_wing_freq_hz"], drawn.frequency_hz[:, 1])
    np.testing.assert_array_equal(runs["mode_wing_damping"], 0.01)  # not dispersed
    assert runs["mode_wing_inertia_kg_m2"].to_numpy() == pytest.approx(91.8, rel=1e-12)
    assert runs["mode_wing_freq_hz"].std() > 0 and runs["mode_tank_mass_kg"].std() > 0
    for m in ("tank", "wing"):
        assert (runs[f"mode_{m}_coupled_freq_hz"] > runs[f"mode_{m}_freq_hz"]).all()
    assert not runs["sim_failed"].any()
    argv = ["campaign", "replay", str(tmp_path / "dispersed"), "3", "--out", str(tmp_path / "R")]
    assert main(argv) == 0
    assert "replay matches the campaign's runs.parquet row exactly" in capsys.readouterr().out
    rigid_modes = _campaign(tmp_path, "plain", False)
    assert not [c for c in rigid_modes if c.startswith("mode_")]
