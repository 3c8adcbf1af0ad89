"""The refinement flies each run as the campaign flew it, with the effects the run draws from
the vehicle file (here the service module's dispersed slosh and wing modes,
examples/service_module/service_module_modal.toml): the search's baseline of a table is the
campaign's own runs, outcome for outcome (rcsim/analysis/apps/refinement/parameters.py: "the
same runs only if both come from here")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.evaluate import Trials, evaluate, runs_from_campaign
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import parse_dict
from rcsim.lookup.pattern_recognition import load_default_table

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "service_module"


def test_the_search_flies_the_campaigns_runs_with_their_drawn_modes(tmp_path):
    spec = parse_dict(
        {
            "seed": 3,
            "runs_per_case": 3,
            "vehicle": str(EXAMPLE / "service_module_modal.toml"),
            "scenario": {"kind": "rate-cases", "cases": "all", "duration_s": 8.0},
            "controller": {"name": "lookup", "table": "default"},
        },
        source="test",
        base_dir=None,
    )
    assert spec.effects.vehicle_modes is not None  # the modes, dispersed per run
    run_campaign(spec, tmp_path / "c", progress=False)
    campaign = pd.read_parquet(tmp_path / "c" / "runs.parquet")
    table = load_default_table()
    cases = np.array([3, 17])  # rate cases 4 and 18: the wings ring in both
    trials = Trials(
        np.repeat(np.asarray(table.firing_time_s)[None], cases.size, axis=0),
        cases,
        ("case 4", "case 18"),
    )
    flown = evaluate(spec, table, trials, threads=1, progress=False)
    theirs = runs_from_campaign(campaign, cases, spec.runs_per_case)
    cols = ["failed", "final_rate_err_roll_deg_s", "final_rate_err_yaw_deg_s", "propellant_kg"]
    pd.testing.assert_frame_equal(
        flown[cols].reset_index(drop=True), theirs[cols].reset_index(drop=True)
    )
    # and the modes did matter: their draws differ run to run
    assert campaign["mode_wing_plus_y_damping"].nunique() == len(campaign)
