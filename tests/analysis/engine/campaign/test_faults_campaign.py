"""Sensors, delays and jet faults in campaigns (issue 11): the spec's [dispersions.sensor],
[dispersions.timing] and [dispersions.fault] tables, their draws in runs.parquet, replay, and
tables for failed jets."""

import math
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign import chunk as chunk_mod
from rcsim.analysis.engine.campaign import limits as limits_mod
from rcsim.analysis.engine.campaign.replay import replay
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec, parse_dict
from rcsim.analysis.engine.runs_table import EFFECT_COLUMNS, input_names, outcome_names
from rcsim.models.errors import InputError
from rcsim.spacecraft.guards import history_bytes

# Two yaw cases (13: +yaw, 14: -yaw; jets 13-16 fire), short runs: a firing and its settling.
BASE = """
seed = 5
runs_per_case = 3
chunk_size = {chunk}
[scenario]
cases = [13, 14]
duration_s = 3.0
[controller]
name = "{controller}"
[output]
histories = "all"
plots = false
"""
# docs/faults.md's plausible levels (star tracker ~10 arcsec, gyro 0.001 deg/s per sample,
# 5 ms sensor-to-actuator, 8 / 5 ms valve latencies).
SENSOR = """
[dispersions.sensor]
att_noise_deg = 0.003
rate_noise_deg_s = 0.001
att_bias_sigma_deg = 0.003
rate_bias_sigma_deg_s = 0.003
rate_walk_deg_s_per_sqrt_s = 0.0005
"""
TIMING = """
[dispersions.timing]
command_delay_s = 0.005
open_delay_s = 0.008
open_delay_sigma_s = 0.001
close_delay_s = 0.005
close_delay_sigma_s = 0.001
"""
FAULT_OFF = """
[dispersions.fault]
mode = "off"
jets = [13, 14, 15, 16]
time_s = 0.0
"""


def _spec(tmp_path, extra="", *, chunk=512, controller="lookup", name="spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(BASE.format(chunk=chunk, controller=controller) + extra)
    return path


def test_spec_without_effect_tables_resolves_as_before(tmp_path):
    """A spec without the new tables must keep its digest, or campaigns run before issue 11
    could not be resumed.  Oracle: the digest of this spec computed by the code before issue 11
    (the campaign spec module of commit d972f6a, run on the same text); all-zero tables fly
    nothing different and resolve to the same digest.  Issue 18's 3-sigma keys (CG y, z,
    products of inertia) are recorded only when written, so this spec keeps the digest too
    (their draws: tests/analysis/engine/campaign/test_mass_dispersions_campaign.py)."""
    text = """
seed = 7
runs_per_case = 3
[scenario]
cases = [13, 22]
duration_s = 2.0
[controller]
name = "phase-plane"
[dispersions]
scale = 2.0
[dispersions.three_sigma]
thrust_n = 1.5
[failure]
rate_error_deg_s = 0.05
"""
    before_issue_11 = "9b78964b830c5912fce51d91d13b5cd51861c0cc5fbeffe5cf55357f3e8d8217"
    spec = parse_dict(tomllib.loads(text), source="x.toml", base_dir=None)
    assert spec.digest() == before_issue_11
    assert set(spec.resolved["dispersions"]) == {"table", "table_sha256", "scale", "three_sigma"}
    assert spec.resolved["dispersions"]["three_sigma"] == {"thrust_n": 1.5}
    assert not spec.sigmas.has_mass_extras
    zeros = text + (
        "[dispersions.sensor]\nrate_noise_deg_s = 0.0\n[dispersions.timing]\n"
        'open_delay_s = 0.0\n[dispersions.fault]\nmode = "off"\nprobability = 0.0\n'
    )
    assert (
        parse_dict(tomllib.loads(zeros), source="x.toml", base_dir=None).digest() == before_issue_11
    )
    # With an effect, the manifest records it as written, and reading that back gives the
    # same specs (what --resume and replay rebuild from).
    noisy = load_spec(_spec(tmp_path, SENSOR + TIMING + FAULT_OFF))
    assert noisy.resolved["dispersions"]["sensor"]["rate_noise_deg_s"] == 0.001
    again = parse_dict(noisy.resolved, source="manifest", base_dir=None)
    assert again.digest() == noisy.digest()
    assert np.array_equal(again.sensor.rate_noise_rad_s, noisy.sensor.rate_noise_rad_s)
    assert again.timing == noisy.timing and again.fault == noisy.fault
    assert noisy.sensor.rate_noise_rad_s[0] == math.radians(0.001)


def test_effects_leave_the_vehicle_draws_unchanged(tmp_path):
    """Issue 11: noise draws come from the run's noise stream, so adding sensors, delays and
    faults must not shift the dispersion draws.  Oracle: the same spec with and without them
    gives identical vehicle columns, bit for bit; the outcomes differ (the effects were flown:
    every yaw run has one of its yaw jets failed off from t = 0)."""
    plain = load_spec(_spec(tmp_path, name="plain.toml"))
    noisy = load_spec(_spec(tmp_path, SENSOR + TIMING + FAULT_OFF, name="noisy.toml"))
    ids = chunk_mod.Chunk(0, plain.n_runs)
    a = chunk_mod.simulate_chunk(plain, ids).runs
    b = chunk_mod.simulate_chunk(noisy, ids).runs
    inputs, outcomes = list(input_names(16)), list(outcome_names(16))  # the packaged vehicle
    pd.testing.assert_frame_equal(a[inputs], b[inputs], check_exact=True)
    added = [c.name for g in ("sensor", "timing", "fault") for c in EFFECT_COLUMNS[g]]
    assert list(b.columns) == list(a.columns[: len(a.columns) - len(outcomes)]) + added + outcomes
    assert not a["propellant_kg"].equals(b["propellant_kg"])
    # The draws are those of rcsim.spacecraft.effect_draws: delays about their means (8 ms
    # +- 1 ms 1-sigma, the largest of 16 jets), the fault among the candidates.
    assert (b["command_delay_s"] == 0.005).all()
    assert b["open_delay_max_s"].between(0.008, 0.008 + 6 * 0.001).all()
    assert set(b["fault_jet"]) <= {13, 14, 15, 16} and (b["fault_time_s"] == 0.0).all()
    # A jet failed off from t = 0 delivers no on-time at all (F's oracle, through a campaign).
    for _, row in b.iterrows():
        assert row[f"jet_{int(row['fault_jet']):02d}_on_time_s"] == 0.0
    assert (b["fault_thrust_factor"] == 1.0).all()


def test_replay_of_a_noisy_faulty_run_matches_its_row(tmp_path, capsys):
    """A run is a function of (spec, run id): the replay draws the same sensor noise, delays
    and fault and must match its runs.parquet row exactly; so must a campaign flown in chunks of
    one run (a run's draws do not depend on its chunk).  Kept histories record what the
    controller measured and what the jets delivered."""
    extra = (
        SENSOR
        + TIMING
        + FAULT_OFF.replace('"off"', '"degraded"').replace(
            "time_s = 0.0", "thrust_factor = [0.7, 0.9]"
        )
    )
    spec_file = _spec(tmp_path, extra, controller="adaptive")
    out = tmp_path / "mc"
    assert main(["campaign", "run", str(spec_file), "--out", str(out)]) == 0
    assert "with sensor noise" in capsys.readouterr().out
    runs = pd.read_parquet(out / "runs.parquet")
    assert runs["fault_thrust_factor"].between(0.7, 0.9).all()
    for run_id in (0, 4):
        result = replay(out, run_id, tmp_path / f"replay-{run_id}")
        assert result["matches"] is True
    one = tmp_path / "mc1"
    run_campaign(
        load_spec(_spec(tmp_path, extra, chunk=1, controller="adaptive", name="one.toml")),
        one,
        local_workers=1,
        progress=False,
    )
    pd.testing.assert_frame_equal(pd.read_parquet(one / "runs.parquet"), runs, check_exact=True)
    hist = pd.read_parquet(out / "histories" / "run-0000000.parquet")
    assert {"meas_rate_err_yaw_deg_s", "meas_att_err_roll_deg", "jet_13_delivered_s"} <= set(
        hist.columns
    )
    # The measurement is not the truth (noise of 0.001 deg/s 1-sigma per sample).
    assert not np.array_equal(hist["meas_rate_err_yaw_deg_s"], hist["rate_err_yaw_deg_s"])


def test_adaptive_controller_is_told_the_rate_noise(tmp_path, monkeypatch):
    """The adaptive controller's confidence rule needs the rate sensor's white noise
    (rcsim.lookup.adaptive.AdaptParams.rate_noise_rad_s): the campaign passes the spec's,
    the largest axis's, in rad/s."""
    from rcsim.lookup import registry

    seen = {}
    real = registry.make_controller

    def spy(name, vehicle, **kw):
        seen.update(name=name, **kw)
        return real(name, vehicle, **kw)

    monkeypatch.setattr(registry, "make_controller", spy)
    spec = load_spec(
        _spec(
            tmp_path,
            SENSOR.replace("rate_noise_deg_s = 0.001", "rate_noise_deg_s = [0.001, 0.002, 0.0005]"),
            controller="adaptive",
        )
    )
    chunk_mod.fly_runs(spec, np.array([0]))
    assert seen["name"] == "adaptive"
    assert seen["adapt_options"] == {"rate_noise_rad_s": math.radians(0.002)}


def test_chunks_count_the_effect_records(tmp_path):
    """Oracle: rcsim.spacecraft.guards.history_bytes with the measured errors (sensors) and the
    delivered on-times (timing, faults): the largest chunk of a 500 s case fits the budget and
    one run more would not."""
    long = BASE.replace("duration_s = 3.0", "duration_s = 500.0")
    path = tmp_path / "long.toml"
    path.write_text(long.format(chunk=512, controller="lookup") + SENSOR + TIMING)
    spec = load_spec(path)
    limit = chunk_mod.max_chunk_runs(spec, 500.0)
    cycles = 12_500
    budget = limits_mod.HISTORY_BUDGET_BYTES
    assert history_bytes(limit, cycles, True, True, n_jets=16) <= budget
    assert history_bytes(limit + 1, cycles, True, True, n_jets=16) > budget
    plain = load_spec(_spec(tmp_path, name="plain.toml"))
    assert limit < chunk_mod.max_chunk_runs(plain, 500.0)


def test_table_for_failed_jets_flies_in_a_campaign(tmp_path, capsys):
    """`rcsim lookup generate --jets-off 13` writes a table for the jets left; a campaign spec
    loads it by its companion file (which names the jets off), records the jet set, and a
    table whose companion is gone is refused (checked against all 16 jets, it is not a table
    of this vehicle)."""
    table = tmp_path / "no13.csv"
    assert main(["lookup", "generate", "--jets-off", "13", "--out", str(table)]) == 0
    assert "for jets 13 off" in capsys.readouterr().out
    extra = FAULT_OFF.replace("[13, 14, 15, 16]", "[13]")
    path = _spec(tmp_path, extra)
    path.write_text(
        path.read_text().replace('name = "lookup"', f'name = "lookup"\ntable = "{table.name}"')
    )
    spec = load_spec(path)
    assert spec.resolved["controller"]["jets_off"] == [13]
    runs = chunk_mod.simulate_chunk(spec, chunk_mod.Chunk(0, spec.n_runs)).runs
    # The table never commands jet 13 (nor does the failed jet deliver anything).
    assert (runs["jet_13_on_time_s"] == 0).all() and (runs["fault_jet"] == 13).all()
    assert not runs["sim_failed"].any()
    (tmp_path / "no13_settling.csv").unlink()
    with pytest.raises(InputError, match="no13.csv"):
        load_spec(path)
