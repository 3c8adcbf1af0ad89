"""Campaigns of vehicle files, whatever their jet count (issue 18): ``vehicle = "FILE"``.

Oracles
-------
* The paper's vehicle file is the packaged vehicle (``tests/spacecraft/vehicle/
  test_paper_vehicle.py``: every model array equal), so a campaign flying it must give the
  packaged campaign's ``runs.parquet`` and envelopes exactly -- with the allocator, Table 5
  dispersions, sensor noise, valve delays and jet faults, i.e. every per-jet draw and record
  sized by the vehicle's own jet count.
* A vehicle file's own valve timing is the nominal about which ``[dispersions.timing]``
  disperses (``rcsim/analysis/engine/campaign/effects.py``): the draw is ``max(0, nominal + sigma
  z)`` per jet, the same numbers as a spec mean equal to the nominal gives
  (``tests/spacecraft/test_sensors.py``).  So canted12 with uniform delays in its file flies,
  run for run, what canted12 without them flies with those delays as the spec's means: the
  same ``runs.parquet``, envelopes and histories exactly (without a spec table, the same but
  the spec's delay columns).
* Propellant accounting (``runs.parquet`` ``propellant_kg``: ``F t / (Isp g0)`` summed over the
  jets): on a seven-jet vehicle it equals the sum over the run's seven recorded per-jet
  on-times and thrusts, to 1e-12 relative (rounding of the sum's order only) -- which holds
  only if every per-jet column is the jet it names.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign.results import history_path
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec, parse_dict
from rcsim.analysis.engine.runs_table import PRODUCT_NAMES, recorded_jets, run_columns
from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle import resolve_vehicle
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2

SPEC = """
seed = 18
runs_per_case = {runs}
{vehicle}
[scenario]
kind = "rate-cases"
cases = {cases}
duration_s = {duration}
[controller]
name = "allocator"
[dispersions.three_sigma]
thrust_n = 2.0
thruster_angle_deg = 5.0
[dispersions.sensor]
rate_noise_deg_s = 0.0005
[dispersions.timing]
command_delay_s = 0.005
open_delay_s = 0.008
open_delay_sigma_s = 0.001
[dispersions.fault]
mode = "off"
probability = 0.5
time_s = [0.0, 2.0]
[output]
histories = "first"
first_k = 1
plots = false
"""


def _campaign(tmp_path: Path, name: str, vehicle: str, **kw) -> Path:
    spec = tmp_path / f"{name}.toml"
    values = {"runs": 3, "cases": "[5, 13]", "duration": 3.0, **kw}
    spec.write_text(SPEC.format(vehicle=vehicle, **values))
    out = tmp_path / name
    run_campaign(load_spec(spec), out, progress=False)
    return out


def test_paper_vehicle_file_campaign_is_the_packaged_one(tmp_path):
    packaged = _campaign(tmp_path, "packaged", "")
    file = _campaign(tmp_path, "file", 'vehicle = "paper"')
    for name in ("runs.parquet", "envelopes.parquet"):
        pd.testing.assert_frame_equal(
            pd.read_parquet(packaged / name), pd.read_parquet(file / name), check_exact=True
        )
    runs = pd.read_parquet(file / "runs.parquet")
    assert recorded_jets(runs.columns) == 16
    # paper.toml gives no valve timing: nothing about it enters the resolved spec (the digest
    # of every vehicle without delays is what it was).
    assert "vehicle_timing" not in json.loads((file / "manifest.json").read_text())["spec"]
    assert not set(PRODUCT_NAMES) & set(runs.columns)  # principal axes along B: no products
    assert runs["fault_jet"].between(0, 16).all() and (runs["fault_jet"] > 0).any()


@pytest.fixture(scope="module")
def seven_jets(tmp_path_factory) -> Path:
    """canted12.toml's first seven jets (triads A and B, and C's forward jet): every axis
    direction is still reachable (``rcsim vehicle check``), with seven jets; its dispersions
    (products of inertia among them) are canted12's."""
    text = resolve_vehicle("canted12").read_text()
    head, *jets = text.split("\n[[jet]]\n")
    assert len(jets) == 12
    path = tmp_path_factory.mktemp("seven") / "seven.toml"
    path.write_text("\n[[jet]]\n".join([head, *jets[:7]]) + "\n")
    return path


def test_a_seven_jet_vehicle_flies_a_campaign_and_is_analysed(tmp_path, seven_jets):
    out = _campaign(tmp_path, "seven", f'vehicle = "{seven_jets}"', runs=5, cases="[5, 13, 17, 22]")
    runs = pd.read_parquet(out / "runs.parquet")
    assert tuple(runs.columns) == tuple(
        c.name for c in run_columns(("sensor", "timing", "fault"), True, n_jets=7)
    )
    assert recorded_jets(runs.columns) == 7 and "jet_08_thrust_n" not in runs.columns
    for kind in ("thrust_n", "tilt_deg", "azimuth_deg", "on_time_s"):
        assert len(runs.filter(regex=rf"^jet_\d\d_{kind}$").columns) == 7
    assert not runs["sim_failed"].any()
    assert set(runs["fault_jet"]) <= set(range(8)) and (runs["fault_jet"] > 0).any()
    on = runs.filter(regex=r"^jet_\d\d_on_time_s$").to_numpy()
    thrust = runs.filter(regex=r"^jet_\d\d_thrust_n$").to_numpy()
    np.testing.assert_allclose(
        runs["propellant_kg"], (on * thrust).sum(axis=1) / (280.0 * G0_M_S2), rtol=1e-12
    )
    history = pd.read_parquet(next((out / "histories").glob("*.parquet")))
    assert len(history.filter(regex=r"^jet_\d\d_on_s$").columns) == 7

    # rcsim analyze: the authority factors come from the seven-jet matrix.
    assert (
        main(["analyze", str(out), "--out", str(tmp_path / "drivers"), "--permutations", "19"]) == 0
    )
    drivers = pd.read_csv(tmp_path / "drivers" / "drivers.csv")
    factors = set(drivers.iloc[:, 0])
    assert {"authority_roll_pos_rad_s2", "jet_07_thrust_n"} <= factors

    # Traceable (issue 18 review): the manifest and the report name the vehicle (its
    # [vehicle] name, file and SHA-256) and which dispersion table "default" was.
    import hashlib
    import json

    manifest = json.loads((out / "manifest.json").read_text())
    digest = hashlib.sha256(seven_jets.read_bytes()).hexdigest()
    assert manifest["vehicle_name"] == "canted-triads-12"  # canted12.toml's [vehicle] name
    assert manifest["dispersions_source"] == "the vehicle file's [dispersions]"
    html = (tmp_path / "drivers" / "report.html").read_text()
    assert "canted-triads-12" in html and digest in html
    assert (
        "the vehicle file&#x27;s [dispersions]" in html
        or "the vehicle file's [dispersions]" in html
    )
    assert "table default" not in html


def test_a_channel_table_flies_a_twelve_jet_vehicle(tmp_path):
    """A channel table (six axis channels, the recipe per jet of the vehicle it was solved for)
    is not a 16-jet table: generated for canted12 it flies canted12's twelve jets in a campaign.
    Oracle: the delivery maps channels through the recipe, so only jets some recipe fires may
    be on, and the run reaches its commanded rate (the generated table's rows are flown to
    within 0.04 deg/s nominally, ``tests/lookup/test_channel_generation.py``)."""
    table = tmp_path / "c12.csv"
    assert main(["lookup", "generate", "--vehicle", "canted12", "--out", str(table)]) == 0
    spec = tmp_path / "spec.toml"
    spec.write_text(
        'seed = 4\nruns_per_case = 2\nvehicle = "canted12"\n[scenario]\ncases = [5, 26]\n'
        f'duration_s = 10\n[controller]\nname = "lookup"\ntable = "{table.name}"\n'
        "[output]\nplots = false\n"
    )
    out = tmp_path / "C"
    run_campaign(load_spec(spec), out, progress=False)
    runs = pd.read_parquet(out / "runs.parquet")
    assert recorded_jets(runs.columns) == 12
    recipe = pd.read_csv(tmp_path / "c12_recipe.csv")
    fired_by_recipe = recipe.filter(regex=r"^jet_\d\d$").to_numpy().max(axis=0) > 0
    on = runs.filter(regex=r"^jet_\d\d_on_time_s$").to_numpy()
    assert (on.sum(axis=0) > 0).any()
    assert not (on[:, ~fired_by_recipe] > 0).any()
    assert not runs["sim_failed"].any()
    assert (
        (runs[[f"final_rate_err_{a}_deg_s" for a in ("roll", "pitch", "yaw")]].abs() < 0.06)
        .all()
        .all()
    )


def test_propellant_exhaustion_is_a_failure_and_ends_the_firing_count(tmp_path):
    """Issue 18 review: canted12 with 2 g of propellant runs dry in the first second of a
    rate case; the run fails with ``propellant exhausted at t = T s`` and counts no firing
    commanded after T (the jets deliver nothing).  Oracle: the firings counted from the kept
    history's commands by rcsim.spacecraft.propulsion's rule (a new firing: a command > 0 to a jet
    that did not fill the previous cycle) in the cycles starting before T -- while the
    allocator, its rate never reached, keeps commanding far more after T."""
    text = resolve_vehicle("canted12").read_text()
    assert "mass_kg = 40.0" in text
    vehicle = tmp_path / "dry.toml"
    vehicle.write_text(text.replace("mass_kg = 40.0", "mass_kg = 0.002", 1))
    spec = tmp_path / "spec.toml"
    spec.write_text(
        f'seed = 3\nruns_per_case = 2\nvehicle = "{vehicle.name}"\n[scenario]\ncases = [13]\n'
        'duration_s = 6\n[controller]\nname = "allocator"\n[output]\nhistories = "all"\n'
        "plots = false\n"
    )
    out = tmp_path / "C"
    run_campaign(load_spec(spec), out, progress=False)
    runs = pd.read_parquet(out / "runs.parquet")
    assert runs["failed"].all() and not runs["sim_failed"].any()
    for _, run in runs.iterrows():
        reason = str(run["reason"])
        assert "propellant exhausted at t = " in reason
        t_out = float(reason.split("propellant exhausted at t = ")[1].split(" s")[0])
        history = pd.read_parquet(history_path(out, int(run["run_id"])))
        on = history.filter(regex=r"^jet_\d\d_on_s$").to_numpy()
        full = on >= 0.04 * (1 - 1e-12)
        starts = (on > 0) & ~np.vstack([np.zeros((1, on.shape[1]), bool), full[:-1]])
        # t_out is printed to 0.1 ms; no cycle starts within that of it here.
        before = history["t_s"].to_numpy() < t_out
        assert run["firings_total"] == starts[before].sum()
        assert starts[~before].sum() > starts[before].sum()


DELAY_SPEC = """
seed = 7
runs_per_case = 3
vehicle = "{vehicle}"
[scenario]
kind = "rate-cases"
cases = [5, 13]
duration_s = 3.0
[controller]
name = "allocator"
[dispersions.three_sigma]
thrust_n = 2.0
{timing}
[output]
histories = "first"
first_k = 1
plots = false
"""
#: The delays canted12 gets in its file, or in the spec.
DELAYS = {"command_delay_s": 0.005, "open_delay_s": 0.008, "close_delay_s": 0.005}
SIGMAS = {
    "command_delay_sigma_s": 0.0005,
    "open_delay_sigma_s": 0.001,
    "close_delay_sigma_s": 0.001,
}


@pytest.fixture(scope="module")
def delayed12(tmp_path_factory) -> Path:
    """canted12.toml with DELAYS: the command delay in [timing], the valve latencies in
    [jet_defaults] (every jet)."""
    text = resolve_vehicle("canted12").read_text()
    valves = "".join(f"{k} = {v}\n" for k, v in DELAYS.items() if k != "command_delay_s")
    text = text.replace(
        "[jet_defaults]\n", f"[timing]\ncommand_delay_s = 0.005\n\n[jet_defaults]\n{valves}"
    )
    path = tmp_path_factory.mktemp("delayed") / "delayed12.toml"
    path.write_text(text)
    return path


def _delay_campaign(tmp_path: Path, name: str, vehicle, timing: dict) -> Path:
    table = "[dispersions.timing]\n" + "".join(f"{k} = {v}\n" for k, v in timing.items())
    spec = tmp_path / f"{name}.toml"
    spec.write_text(DELAY_SPEC.format(vehicle=vehicle, timing=table if timing else ""))
    out = tmp_path / name
    run_campaign(load_spec(spec), out, progress=False)
    return out


def _same_delays(a: Path, b: Path) -> None:
    """The valves of both campaigns flew the same delays (the runs tables' delay columns).
    Since issue 28 the allocator plans with the vehicle file's delays (its flight software
    knows its valves) and not with a spec's (a dispersion it does not know), so the flights
    themselves differ: the delays flown are what must agree."""
    runs_a, runs_b = pd.read_parquet(a / "runs.parquet"), pd.read_parquet(b / "runs.parquet")
    columns = ["command_delay_s", "open_delay_max_s", "close_delay_max_s"]
    pd.testing.assert_frame_equal(runs_a[columns], runs_b[columns], check_exact=True)


def test_a_vehicles_delays_fly_as_the_same_delays_in_the_spec(tmp_path, delayed12):
    # Dispersed: the file's nominal + the spec's sigmas == the spec's means + sigmas.
    own = _delay_campaign(tmp_path, "own", delayed12, SIGMAS)
    spec = _delay_campaign(tmp_path, "spec", "canted12", {**DELAYS, **SIGMAS})
    _same_delays(own, spec)
    runs = pd.read_parquet(own / "runs.parquet")
    assert runs["open_delay_max_s"].std() > 0 and not runs["sim_failed"].any()
    history = pd.read_parquet(own / "histories/run-0000000.parquet")
    assert "jet_01_delivered_s" in history  # what the jets delivered, recorded with timing
    # Nominal only: every run flies the file's delays; the spec's way has its delay columns.
    fixed = _delay_campaign(tmp_path, "fixed", delayed12, {})
    means = _delay_campaign(tmp_path, "means", "canted12", DELAYS)
    columns = ["command_delay_s", "open_delay_max_s", "close_delay_max_s"]
    assert not pd.read_parquet(fixed / "runs.parquet")["sim_failed"].any()
    assert (
        pd.read_parquet(means / "runs.parquet")[columns].to_numpy() == [0.005, 0.008, 0.005]
    ).all()
    # The manifest says which delays are the vehicle's (per jet) and what the spec adds.
    resolved = json.loads((own / "manifest.json").read_text())["spec"]
    assert resolved["vehicle_timing"] == {
        "command_delay_s": 0.005,
        "open_delay_s": [0.008] * 12,
        "close_delay_s": [0.005] * 12,
    }
    assert resolved["dispersions"]["timing"] == SIGMAS
    assert "vehicle_timing" not in json.loads((means / "manifest.json").read_text())["spec"]
    # A resolved spec whose vehicle_timing is not the file's is refused (resume, replay).
    stale = dict(resolved, vehicle_timing={**resolved["vehicle_timing"], "command_delay_s": 0.0})
    with pytest.raises(InputError, match="vehicle_timing.*not the valve timing"):
        parse_dict(stale, source="manifest")
    assert (
        parse_dict(resolved, source="manifest").digest()
        == load_spec(tmp_path / "own.toml").digest()
    )


@pytest.mark.parametrize("key", list(DELAYS))
def test_a_spec_mean_of_a_delay_the_vehicle_gives_is_refused(tmp_path, delayed12, key):
    spec = tmp_path / "s.toml"
    spec.write_text(
        DELAY_SPEC.format(vehicle=delayed12, timing=f"[dispersions.timing]\n{key} = 0.002")
    )
    with pytest.raises(InputError) as err:
        load_spec(spec)
    message = str(err.value)
    for part in (str(spec), f"[dispersions.timing]: {key}", str(delayed12), "0.002", "sigma"):
        assert part in message
