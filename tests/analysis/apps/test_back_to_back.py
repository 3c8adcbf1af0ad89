"""Back-to-back comparison of two controllers (rcsim compare controllers).

Oracles: the built-in lookup controller flown through the plug-in path must command the same
on-times in every run (zero divergences); a copy with one threshold changed (the rate-error
deadband, 0.06 -> 0.01 deg/s) must be caught at the first cycle where two independent flights
of that run (rcsim.fly, one per controller) command differently, recomputed here.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.back_to_back import Side, compare
from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign.chunk import fly_runs
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.models.errors import InputError

ROOT = Path(__file__).resolve().parents[3]
WRAPPED = f"plugin:{ROOT / 'examples' / 'plugins' / 'wrapped_lookup.py'}:make_controller"
SPEC = """
seed = 9
runs_per_case = 4
[scenario]
cases = [3, 13, 22]
duration_s = 6.0
[controller]
name = "lookup"
[output]
histories = "none"
plots = false
"""
# The lookup controller with one threshold changed: a plug-in of a few lines.
NARROW = """
from dataclasses import replace
import math
from rcsim.lookup.pattern_recognition import LookupController

def make_controller(vehicle, params):
    ctl = LookupController.from_files(None, vehicle.control)
    ctl.params = replace(ctl.params, rate_error_limit_rad_s=math.radians(params["deadband_deg_s"]))
    return ctl
"""


@pytest.fixture()
def spec(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SPEC)
    return load_spec(path)


def test_the_same_controller_never_diverges(spec):
    result = compare(spec, Side("lookup"), Side(WRAPPED))
    runs, s = result["runs"], result["summary"]
    assert len(runs) == 12 and s["diverged"] == 0 and not runs["diverged"].any()
    assert s["failed_only_a"] == s["failed_only_b"] == 0 and s["mcnemar_p"] == 1.0
    assert s["propellant_diff_kg"] == 0.0


def test_a_changed_threshold_is_caught_at_its_first_divergent_cycle(spec, tmp_path):
    (tmp_path / "narrow.py").write_text(NARROW)
    b = Side(f"plugin:{tmp_path / 'narrow.py'}:make_controller", {"deadband_deg_s": 0.01})
    runs = compare(spec, Side("lookup"), b)["runs"]
    assert runs["diverged"].any()
    # Independent flights of the same runs, one per controller: the first differing cycle.
    ids = runs["run_id"].to_numpy()
    ha, _ = fly_runs(Side("lookup").spec_for(spec), ids)
    hb, _ = fly_runs(b.spec_for(spec), ids)
    differ = (ha.on_time_s != hb.on_time_s).any(axis=2)
    for i, row in runs.iterrows():
        if not differ[i].any():
            assert not row["diverged"]
            continue
        k = int(differ[i].argmax())
        assert row["first_cycle"] == k and row["first_t_s"] == ha.t_s[k]
        jet = int(row["first_jet"]) - 1
        assert row["a_on_s"] == ha.on_time_s[i, k, jet] != hb.on_time_s[i, k, jet]
        assert np.array_equal(ha.on_time_s[i, :k], hb.on_time_s[i, :k])
        # The errors reported are what both saw there: the deadband lies between them.
        assert np.isclose(row["rate_err_roll_deg_s"], np.degrees(ha.rate_err_B[i, k, 0]))


def test_the_command_writes_and_prints(tmp_path, capsys):
    (tmp_path / "s.toml").write_text(SPEC)
    argv = ["compare", "controllers", str(tmp_path / "s.toml"), "--a", "lookup",
            "--b", WRAPPED, "--out", str(tmp_path / "o")]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "0 of 12 runs commanded differently" in out and "bit for bit" in out
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["runs"] == 12 and summary["seed"] == 9
    assert len(pd.read_csv(tmp_path / "o" / "divergence.csv")) == 12


def test_a_side_that_cannot_build_is_one_error(spec):
    with pytest.raises(InputError, match="not found"):
        compare(spec, Side("lookup"), Side("plugin:no_such_fsw_mod:make"))
