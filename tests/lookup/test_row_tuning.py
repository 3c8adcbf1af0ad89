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
from rcsim.spacecraft.vehicle import Vehicle

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


class Watched:
    """The lookup controller, keeping what it decided each cycle (``axis_new``: it starts a
    firing on the axis)."""

    def __init__(self, controller):
        self.controller, self.new = controller, []

    @property
    def cycle_s(self):
        return self.controller.cycle_s

    def initial_state(self, n_runs):
        return self.controller.initial_state(n_runs)

    def step(self, nav, state):
        on, state, detail = self.controller.step_detail(nav, state)
        self.new.append(detail["axis_new"].copy())
        return on, state


def fly_first_firing(table, vehicle, flight_s):
    """Per case: each axis's rate error [deg/s] (26, 3) just before the controller fires it
    a second time (else at the end), the cycles in which it started a firing, and the end
    error [deg/s] (26, 3)."""
    watched = Watched(LookupController(table, LookupParams.from_profile(vehicle.control)))
    hist = simulate_batch(
        vehicle.nominal(26), watched, Guidance.rate(table.rate_cmd), flight_s, vehicle=vehicle
    )
    new = np.array(watched.new)  # (K, 26, 3)
    err = np.concatenate([hist.rate_err_B, hist.final.rate_err_B[:, None]], axis=1)
    left = np.empty((26, 3))
    firings = np.empty(26, int)
    for i in range(26):
        firings[i] = sum(bool(new[k, i].any()) for k in range(new.shape[0]))
        for a in range(3):
            again = [k for k in range(1, new.shape[0]) if new[k, i, a]]
            left[i, a] = err[i, again[0] if again else new.shape[0], a]
    return np.degrees(left), firings, np.degrees(hist.final.rate_err_B)


def test_failure_threshold_is_the_campaigns():
    assert FAILURE_RATE_ERROR_DEG_S == DEFAULT_RATE_ERROR_DEG_S


def test_every_case_within_target_or_named(generated):
    name, vehicle, gen, target_deg_s = generated
    frame = gen.settling_frame()
    flight_s = float(frame["nominal_flight_s"].iloc[0])
    err, firings, end = fly_first_firing(gen.table, vehicle, flight_s)
    for a, axis in enumerate(("roll", "pitch", "yaw")):
        np.testing.assert_allclose(frame[f"nominal_err_{axis}_deg_s"], err[:, a], atol=1e-9)
    worst = np.abs(err).max(axis=1)
    np.testing.assert_allclose(frame["nominal_err_deg_s"], worst, atol=1e-9)
    np.testing.assert_array_equal(frame["nominal_firings"], firings)
    np.testing.assert_allclose(frame["nominal_end_err_deg_s"], np.abs(end).max(axis=1), atol=1e-9)
    np.testing.assert_allclose(frame["nominal_target_deg_s"], target_deg_s, rtol=1e-12)
    met = worst <= target_deg_s
    np.testing.assert_array_equal(frame["nominal_met"], met)
    reasons = frame["unmet_reason"]
    assert all(r == "" for r in reasons[met]), name
    for r, w in zip(reasons[~met], worst[~met]):
        assert r.split(":")[0] in ("cycle coarser than the band", "coupling", "unreachable"), r
        best = float(r.split("best ")[1].split()[0])
        assert best <= round(w, 4) and f"the row kept leaves {w:.4f}" in r, (r, w)


def test_coarse_cycle_reason_is_the_recipes_step():
    """canted16's pitch and yaw channels turn 1.394 and 1.752 deg/s^2 (docs/lookup.md
    section 4): a 40 ms cycle is 0.056 and 0.070 deg/s, more than the 0.04 deg/s band, so a
    single-axis case whose nearest whole-cycle row is farther than 0.02 deg/s is named with
    that step."""
    gen = generate_channel_table(Vehicle.load("canted16"))
    nom = gen.nominal
    accel = np.abs(gen.table.recipe.accel_rad_s2)  # (6 channels, 3 axes) [rad/s^2]
    rate = np.asarray(gen.table.rate_cmd)
    single = np.flatnonzero(~nom.met & ((rate != 0).sum(axis=1) == 1))
    assert single.size  # the whole-cycle rows cannot all land inside the band
    for i in single:
        reason = nom.reason[i]
        assert reason.startswith("cycle coarser than the band"), reason
        a = int(np.flatnonzero(rate[i])[0])
        axis = ("roll", "pitch", "yaw")[a]
        step_deg_s = float(np.degrees(accel[2 * a + (rate[i, a] < 0), a]) * 0.04)
        stated = float(reason.split(f"changes {axis} ")[1].split()[0].rstrip(","))
        assert stated == pytest.approx(step_deg_s, rel=0.03)
        assert stated > 2 * TARGET_DEG_S


def test_unreachable_direction_is_named():
    """The paper's vehicle without jets 13 and 15 has no -yaw jet (Table 2): every case
    commanding -yaw misses by at least its yaw command and says so."""
    gen = generate_table(Vehicle.load(), jets_off=(13, 15))
    nom = gen.nominal
    minus_yaw = np.asarray(gen.table.rate_cmd)[:, 2] < 0
    assert not nom.met[minus_yaw].any()
    for i in np.flatnonzero(minus_yaw):
        assert nom.reason[i].startswith("unreachable: no jet left turns -yaw"), nom.reason[i]
        # The yaw command stays unmet: 1 % for the gyroscopic coupling of the axes that fire.
        assert nom.worst_rad_s[i] >= abs(gen.table.rate_cmd[i, 2]) * 0.99
    assert nom.met[~minus_yaw].all()


def test_tuning_finds_rows_that_meet_the_target():
    """Started two cycles long on every axis (about 0.05-0.06 deg/s past each command: two
    cycles of a Table 2 pair), the search brings every case of the paper's vehicle back
    within the 0.02 deg/s target in one batched flight -- to within a cycle of the rule's
    rows, which are the nearest whole cycles (test_table_generation.py)."""
    from rcsim.lookup.row_tuning import RowTuner
    from rcsim.lookup.table_generation import firing_times
    from rcsim.models.tables import LookupTable

    vehicle = Vehicle.load("paper")
    rule = generate_table(vehicle)
    rate = np.asarray(rule.table.rate_cmd)
    jet_map = np.asarray(vehicle.axis_signs, int)
    tuner = RowTuner(
        LookupTable(case=rule.table.case, rate_cmd=rate, firing_time_s=np.zeros((26, 16))),
        rate != 0,
        lambda c, d: firing_times(c, d, jet_map, 0.04),
        vehicle=vehicle,
        stretch=1.0,
        settle_window_s=2.0,
    )
    start = rule.command.cycles + 2 * (rule.command.cycles > 0)
    cycles, check = tuner.tune(start)
    assert check.met.all() and check.tuned.all()
    assert np.abs(cycles - rule.command.cycles).max() <= 1
    assert (check.firings == 1).all()


def test_paper_vehicle_keeps_its_rows():
    gen = generate_table(Vehicle.load())
    assert gen.nominal.met.all() and not gen.nominal.tuned.any()
    assert np.degrees(gen.nominal.worst_rad_s).max() <= 0.0151


@pytest.mark.parametrize("bad", [0.0, -0.5, 1.5, float("nan")])
def test_target_fraction_outside_0_1_is_refused(bad):
    with pytest.raises(InputError, match=r"\(0, 1\]"):
        generate_table(Vehicle.load(), target_fraction=bad)


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
        assert (line.split()[5] == "met") == bool(row["nominal_met"])
        assert row["unmet_reason"] in line
    missed = frame.loc[~frame["nominal_met"], "case"].tolist()
    assert missed and f"cases {', '.join(map(str, missed))}" in captured.err


def test_the_tuning_threshold_is_the_vehicle_files_own(tmp_path):
    """A vehicle file's [failure] rate_error_deg_s is the threshold its table is tuned to (the
    criterion its campaigns are judged by); without one, the paper's 0.04 deg/s; a caller's
    value wins."""
    from pathlib import Path

    from rcsim.lookup.row_tuning import vehicle_threshold_deg_s
    from rcsim.spacecraft.vehicle import Vehicle

    source = Path(__file__).with_name("vehicles") / "lander900.toml"
    own = tmp_path / "lander900_own.toml"
    own.write_text(source.read_text() + "\n[failure]\nrate_error_deg_s = 0.03\n")
    assert vehicle_threshold_deg_s(Vehicle.load(own), None) == 0.03
    assert vehicle_threshold_deg_s(Vehicle.load(source), None) == 0.04
    assert vehicle_threshold_deg_s(Vehicle.load(own), 0.05) == 0.05
