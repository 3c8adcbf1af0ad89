"""Generated tables tuned in closed loop until each nominal rate case ends near its command
(``rcsim/lookup/row_tuning.py``).

Oracles and limits:

* **recomputed independently**: each generated table is flown here by the lookup controller
  (one controller for all runs, not the tuner's per-run tables) on the nominal vehicle, from
  rest, each of the 26 rate commands, for the flight the companion states; the rate error
  the row's firing left (read at the cycle a second firing starts, else at the end -- this
  test finds the firings itself) must equal the companion's ``nominal_err_*`` to 1e-9 deg/s
  (the same simulation; the tolerance allows for summation order only), and every case is
  either within the target (half the campaigns' 0.04 deg/s failure threshold, Gambone
  sec. III) or named with a reason;
* **reasons are true**: a "cycle coarser than the band" names one cycle's rate change, which
  for a channel is its recipe's nominal angular acceleration x the cycle (a rigid body under
  constant torque: delta omega = alpha T), within 3 % (gyroscopic coupling and the valves'
  minimum pulses, which the formula has not); an "unreachable" case is one whose commanded
  direction has no jet left;
* **tuning never makes a case worse** than the paper's rule's row, and the paper's vehicle,
  which the rule already brings within half a cycle's rate change (at most 0.0151 deg/s,
  ``test_table_generation.py``), keeps its rows (Table 6's pattern).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign.spec import DEFAULT_RATE_ERROR_DEG_S
from rcsim.lookup.channel_generation import generate_channel_table
from rcsim.lookup.generation import generate_table
from rcsim.lookup.pattern_recognition import LookupController, LookupParams
from rcsim.lookup.row_tuning import FAILURE_RATE_ERROR_DEG_S
from rcsim.models.errors import InputError
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.vehicle_file import Vehicle

ROOT = Path(__file__).resolve().parents[2]
VEHICLES = {
    "canted16": "canted16",
    "service16": str(ROOT / "docs" / "examples" / "service16.toml"),
    "smallsat150": str(Path(__file__).parent / "vehicles" / "smallsat150.toml"),
    "paper": "paper",
}
TARGET_DEG_S = 0.5 * 0.04  # the default: half the campaigns' failure threshold
#: Vehicle and target fraction: the default on the three vehicles of the brief, and a quarter
#: on the paper's jet table (0.01 deg/s, finer than its 0.023-0.030 deg/s cycles: rows tuned
#: and cases named on a jet table).
GENERATED = [("canted16", 0.5), ("service16", 0.5), ("smallsat150", 0.5), ("paper", 0.25)]


@pytest.fixture(scope="module", params=GENERATED, ids=[f"{v}-{f}" for v, f in GENERATED])
def generated(request):
    name, fraction = request.param
    vehicle = Vehicle.load(VEHICLES[name])
    return name, vehicle, generate_table(vehicle, target_fraction=fraction), fraction * 0.04


def fly_first_firing(table, vehicle, flight_s):
    """Per case the rate error [deg/s] (26, 3) the row's firing left and the firings."""
    controller = LookupController(table, LookupParams.from_profile(vehicle.control))
    hist = simulate_batch(
        vehicle.nominal(26), controller, Guidance.rate(table.rate_cmd), flight_s, vehicle=vehicle
    )
    if table.recipe is None:
        main_jets = table.firing_time_s.max(axis=0) > 0
    else:  # a channel's main jets (its trims fire short pulses of their own)
        main_jets = (table.recipe.fractions >= 0.5).any(axis=0)
    on = hist.on_time_s[:, :, main_jets].max(axis=2) > 0
    err = np.concatenate([hist.rate_err_B, hist.final.rate_err_B[:, None]], axis=1)
    left, firings = [], []
    for i in range(26):
        starts = [k for k in range(on.shape[1]) if on[i, k] and (k == 0 or not on[i, k - 1])]
        left.append(err[i, starts[1] if len(starts) > 1 else on.shape[1]])
        firings.append(len(starts))
    return np.degrees(np.array(left)), np.array(firings)


def test_failure_threshold_is_the_campaigns():
    assert FAILURE_RATE_ERROR_DEG_S == DEFAULT_RATE_ERROR_DEG_S


def test_every_case_within_target_or_named(generated):
    name, vehicle, gen, target_deg_s = generated
    frame = gen.settling_frame()
    flight_s = float(frame["nominal_flight_s"].iloc[0])
    err, firings = fly_first_firing(gen.table, vehicle, flight_s)
    for a, axis in enumerate(("roll", "pitch", "yaw")):
        np.testing.assert_allclose(frame[f"nominal_err_{axis}_deg_s"], err[:, a], atol=1e-9)
    worst = np.abs(err).max(axis=1)
    np.testing.assert_allclose(frame["nominal_err_deg_s"], worst, atol=1e-9)
    np.testing.assert_array_equal(frame["nominal_firings"], firings)
    np.testing.assert_allclose(frame["nominal_target_deg_s"], target_deg_s, rtol=1e-12)
    met = worst <= target_deg_s
    np.testing.assert_array_equal(frame["nominal_met"], met)
    reasons = frame["unmet_reason"]
    assert all(r == "" for r in reasons[met]), name
    for r, w in zip(reasons[~met], worst[~met]):
        assert r.split(":")[0] in ("cycle coarser than the band", "coupling", "unreachable"), r
        assert f"best {w:.4f} deg/s" in r, (r, w)


def test_coarse_cycle_reason_is_the_recipes_step():
    """canted16's pitch channels turn 1.394 deg/s^2 (docs/lookup.md section 4): a 40 ms cycle
    is 0.0558 deg/s, more than the 0.04 deg/s band, so a single-axis pitch case whose nearest
    whole-cycle row is farther than 0.02 deg/s is named with that step."""
    gen = generate_channel_table("canted16")
    nom = gen.nominal
    accel = np.abs(gen.table.recipe.accel_rad_s2)  # (6 channels, 3 axes) [rad/s^2]
    missed = np.flatnonzero(~nom.met)
    assert missed.size  # the whole-cycle rows cannot all land inside the band
    for i in missed:
        reason = nom.reason[i]
        assert reason.startswith("cycle coarser than the band"), reason
        pitch = gen.table.rate_cmd[i, 1]
        assert pitch != 0
        step_deg_s = float(np.degrees(accel[2 if pitch > 0 else 3, 1]) * 0.04)
        stated = float(reason.split("pitch ")[1].split()[0].rstrip(","))
        assert stated == pytest.approx(step_deg_s, rel=0.03)
        assert stated > 2 * TARGET_DEG_S


def test_unreachable_direction_is_named():
    """The paper's vehicle without jets 13 and 15 has no -yaw jet (Table 2): every case
    commanding -yaw misses by at least its yaw command and says so."""
    gen = generate_table(jets_off=(13, 15))
    nom = gen.nominal
    minus_yaw = np.asarray(gen.table.rate_cmd)[:, 2] < 0
    assert not nom.met[minus_yaw].any()
    for i in np.flatnonzero(minus_yaw):
        assert nom.reason[i].startswith("unreachable: no jet left turns -yaw"), nom.reason[i]
        # The yaw command stays unmet: 1 % for the gyroscopic coupling of the axes that fire.
        assert nom.worst_rad_s[i] >= abs(gen.table.rate_cmd[i, 2]) * 0.99
    assert nom.met[~minus_yaw].all()


@pytest.mark.parametrize("name, fraction", [("service16", 0.5), ("paper", 0.25)])
def test_tuning_never_worse(name, fraction):
    """Tuning changes rows where the rule's miss (service16's leave 16 of 26 cases beyond
    0.02 deg/s, the paper's 16 beyond 0.01 deg/s: measured, docs/lookup.md) and never makes a
    case worse: its search includes the rule's row (1e-6 deg/s for the flights' differing
    lengths).  On service16 it also brings more cases within the target."""
    from rcsim.lookup.channel_generation import generate_channel_table as channel
    from rcsim.lookup.table_generation import generate_jet_table as jet

    vehicle = Vehicle.load(VEHICLES[name])
    generate = jet if name == "paper" else channel
    before = generate(vehicle, target_fraction=fraction, tune_rounds=0).nominal
    after = generate(vehicle, target_fraction=fraction).nominal
    assert not before.tuned.any() and after.tuned.any()
    assert (np.degrees(after.worst_rad_s) <= np.degrees(before.worst_rad_s) + 1e-6).all()
    assert after.met.sum() >= before.met.sum()
    if name == "service16":
        assert after.met.sum() > before.met.sum()


def test_paper_vehicle_keeps_its_rows():
    gen = generate_table()
    assert gen.nominal.met.all() and not gen.nominal.tuned.any()
    assert np.degrees(gen.nominal.worst_rad_s).max() <= 0.0151


@pytest.mark.parametrize("bad", [0.0, -0.5, 1.5, float("nan")])
def test_target_fraction_outside_0_1_is_refused(bad):
    with pytest.raises(InputError, match=r"\(0, 1\]"):
        generate_table(target_fraction=bad)


def test_cli_prints_every_case_and_warns_on_misses(tmp_path, capsys):
    out = tmp_path / "T.csv"
    assert main(["lookup", "generate", "--vehicle", "canted16", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    frame = pd.read_csv(tmp_path / "T_settling.csv", dtype={"unmet_reason": str}).fillna(
        {"unmet_reason": ""}
    )
    lines = {
        int(line.split()[0]): line
        for line in captured.out.splitlines()
        if line[:4].strip().isdigit()
    }
    assert sorted(lines) == list(range(1, 27))
    for _, row in frame.iterrows():
        line = lines[int(row["case"])]
        assert f"{row['nominal_err_deg_s']:.4f}" in line
        assert (line.split()[4] == "met") == bool(row["nominal_met"])
        assert row["unmet_reason"] in line
    missed = frame.loc[~frame["nominal_met"], "case"].tolist()
    assert missed and f"cases {', '.join(map(str, missed))}" in captured.err
