"""Axis channels for coupled jet layouts (issue 18): the recipes and their per-cycle delivery.

Oracles:

* **recipe, canted pair** -- a vehicle built here whose only yaw jets are canted pairs: jet 9 at
  x = +1 m pushing (0, 1, 0.4), jet 10 at x = -2 m pushing (0, -1, 0.2) (unit-normalised).
  Each torques pitch too (``r x F``: (0, -0.4, 1) / |d9| and (0, 0.4, 2) / |d10| per newton);
  a pure +yaw change needs the 2x2 solution of ``[tau_pitch; tau_yaw] t = [0; 1]``, i.e.
  ``t9 / |d9| = t10 / |d10|``, fractions ``(1, |d10| / |d9|) = (1, sqrt(1.04 / 1.16))``.  The
  arms and cants are chosen so that the pair's y forces cancel too, and no other jet has a z
  force: the pair is the recipe LP's unique optimum (the translation it leaves, along z, no
  other jet could take back).  To 1e-9 (LP round-off);
* **recipe, paper vehicle** -- its jets are Table 2's pure couples: each channel's recipe is the
  Table 2 pair of that axis and sign, both fully on (exactly 1.0), nothing else;
* **delivery** -- jet on-time = channel on-time times the fraction (exact); two channels that ask
  a shared jet for more than the cycle are scaled alike, so the jet gets exactly the cycle and
  the cycle's rate change keeps its direction (parallel to 1e-12); a channel counts down by the
  time delivered, so a firing's total jet on-time is its table time times the fractions,
  whatever the sharing (1e-12 s); short shares are owed and fired as pulses of at least the
  minimum on-time, and their total is conserved up to the end-of-firing rounding (at most half
  the minimum on-time, the allocator's rule).
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.lookup.channels import ChannelMap, axis_jets_of, solve_recipe
from rcsim.models.errors import InputError
from rcsim.models.tables import CHANNEL_MAP, load_jet_map
from rcsim.spacecraft.vehicle import Vehicle

CYCLE = 0.04

_JETS = [
    # roll couples: y forces at z = +-1 m (+roll: jets 1, 2; -roll: 3, 4)
    ((0, 0, 1), (0, -1, 0)),
    ((0, 0, -1), (0, 1, 0)),
    ((0, 0, 1), (0, 1, 0)),
    ((0, 0, -1), (0, -1, 0)),
    # pitch couples: x forces at z = +-1 m (+pitch: 5, 6; -pitch: 7, 8)
    ((0, 0, 1), (1, 0, 0)),
    ((0, 0, -1), (-1, 0, 0)),
    ((0, 0, 1), (-1, 0, 0)),
    ((0, 0, -1), (1, 0, 0)),
    # the canted yaw pairs: +yaw (9, 10), -yaw (11, 12)
    ((1, 0, 0), (0, 1, 0.4)),
    ((-2, 0, 0), (0, -1, 0.2)),
    ((1, 0, 0), (0, -1, 0.4)),
    ((-2, 0, 0), (0, 1, 0.2)),
    # four pushers along their arms: no torque (the paper's translation jets' role)
    ((1, 0, 0), (1, 0, 0)),
    ((-1, 0, 0), (-1, 0, 0)),
    ((2, 0, 0), (1, 0, 0)),
    ((-2, 0, 0), (-1, 0, 0)),
]


def _canted_pair_vehicle(path):
    lines = [
        "[mass]",
        "mass_kg = 1000.0",
        "cg_m = [0.0, 0.0, 0.0]",
        "inertia_kg_m2 = [1000.0, 1200.0, 1500.0]",
        "[jet_defaults]",
        "thrust_n = 20.0",
    ]
    for pos, direction in _JETS:
        lines += ["[[jet]]", f"position_m = {list(pos)}", f"direction = {list(direction)}"]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_recipe_of_a_canted_pair_is_its_2x2_solution(tmp_path):
    recipe = solve_recipe(Vehicle.load(_canted_pair_vehicle(tmp_path / "pair.toml")))
    frac = recipe.fractions
    n9, n10 = np.hypot(1, 0.4), np.hypot(1, 0.2)
    # Per second of firing and newton of thrust: pitch and yaw torques of jets 9 and 10.
    tau = np.array([[-0.4 / n9, 0.4 / n10], [1 / n9, 2 / n10]])
    t = np.linalg.solve(tau, [0.0, 1.0])
    expect = t / t.max()
    assert expect[1] == pytest.approx(np.sqrt(1.04 / 1.16), rel=1e-12)  # as in the docstring
    plus_yaw = np.zeros(16)
    plus_yaw[[8, 9]] = expect
    np.testing.assert_allclose(frac[4], plus_yaw, atol=1e-9)
    minus_yaw = np.zeros(16)
    minus_yaw[[10, 11]] = expect  # the mirror pair
    np.testing.assert_allclose(frac[5], minus_yaw, atol=1e-9)
    # Couples are their own recipes; the pushers are never used.
    for k, jets in enumerate(([0, 1], [2, 3], [4, 5], [6, 7])):
        row = np.zeros(16)
        row[jets] = 1.0
        np.testing.assert_allclose(frac[k], row, atol=1e-9)
    # Pure: each channel's acceleration lies on its own axis, with its sign.
    accel = recipe.accel_rad_s2
    on_axis = (accel * CHANNEL_MAP).sum(axis=1)
    assert (on_axis > 0).all()
    assert np.abs(accel - on_axis[:, None] * CHANNEL_MAP).max() < 1e-12 * on_axis.max()


def test_paper_vehicle_recipe_is_the_table2_pair_fully_on():
    recipe = solve_recipe(Vehicle.load("paper"))
    jet_map = load_jet_map()  # (16, 3) Table 2 torque signs
    for k, (axis, sign) in enumerate((a, s) for a in range(3) for s in (1, -1)):
        pair = (jet_map[:, axis] == sign).astype(float)
        assert pair.sum() == 2
        assert np.array_equal(recipe.fractions[k], pair), k
    assert recipe.vehicle == "paper" and len(recipe.vehicle_sha256) == 64
    # The axis's jets of a paper channel table are Table 2's.
    assert np.array_equal(axis_jets_of(recipe), (jet_map != 0).T)


def _map(fractions, min_on_s=0.0, min_pulse="accumulate"):
    return ChannelMap(np.asarray(fractions, float), min_on_s, CYCLE, min_pulse=min_pulse)


def test_delivery_without_sharing_is_the_fractions():
    frac = np.zeros((6, 4))
    frac[0] = [1.0, 0.5, 0, 0]
    frac[2] = [0, 0, 1.0, 0.25]
    cmap = _map(frac)
    rem = np.array([[0.1, 0, 0.03, 0, 0, 0], [0.01, 0, 0, 0, 0, 0]])
    on, delivered, _ = cmap.deliver(rem, cmap.initial(2))
    expect = np.minimum(rem, CYCLE)
    np.testing.assert_array_equal(delivered, expect)
    np.testing.assert_allclose(on, expect @ frac, rtol=0, atol=1e-15)


def test_shared_jets_are_scaled_alike_and_the_firing_keeps_its_total():
    # +pitch and +yaw share jet 0 (0.9 each): together 1.8 cycles asked of it.
    frac = np.zeros((6, 3))
    frac[2] = [0.9, 1.0, 0.0]
    frac[4] = [0.9, 0.0, 1.0]
    accel = np.array([[0, 0, 0], [0, 0, 0], [0, 1.0, 0], [0, 0, 0], [0, 0, 2.0], [0, 0, 0]])
    cmap = _map(frac)
    total = np.array([[0, 0, 0.2, 0, 0.12, 0]])
    on, delivered, valves = cmap.deliver(total, cmap.initial(1))
    asked = np.minimum(total, CYCLE)
    scale = CYCLE / (asked @ frac).max()
    assert on.max() == pytest.approx(CYCLE, abs=1e-15)  # the shared jet is on the whole cycle
    np.testing.assert_allclose(on, scale * (asked @ frac), rtol=1e-14)
    # The cycle's rate change is along the commanded one (no coupled torque from the cap).
    want, got = asked @ accel, delivered @ accel
    assert np.linalg.norm(np.cross(want, got)) <= 1e-12 * np.linalg.norm(want) ** 2
    # Flown to the end, every jet gets its table time's share.
    rem, jet_total = total - delivered, on.copy()
    for _ in range(30):
        on, delivered, valves = cmap.deliver(rem, valves)
        rem, jet_total = np.where(rem - delivered > 1e-12, rem - delivered, 0.0), jet_total + on
    assert rem.max() == 0
    np.testing.assert_allclose(jet_total, total @ frac, rtol=0, atol=1e-12)


@pytest.mark.parametrize("cycles, fired_ms", [(10, 20.0), (3, 10.0), (2, 0.0)])
def test_short_shares_are_owed_until_the_minimum_on_time(cycles, fired_ms):
    """A trim jet at 5 % of a channel: 2 ms per cycle, under the 10 ms minimum.  Owed, it
    fires 10 ms every 5 cycles; at the firing's end 6 ms owed rounds up to 10 ms (>= half the
    minimum), 4 ms is dropped."""
    frac = np.zeros((6, 2))
    frac[0] = [1.0, 0.05]
    cmap = _map(frac, min_on_s=0.010)
    rem = np.array([[cycles * CYCLE, 0, 0, 0, 0, 0]])
    valves = cmap.initial(1)
    pulses = []
    for _ in range(cycles + 2):
        on, delivered, valves = cmap.deliver(rem, valves)
        rem = rem - delivered
        pulses.append(on[0])
    pulses = np.array(pulses)
    trim = pulses[:, 1]
    assert trim[(trim > 0)].min(initial=0.010) >= 0.010 - 1e-15  # never a pulse the valve drops
    assert trim.sum() * 1e3 == pytest.approx(fired_ms, abs=1e-9)
    assert abs(trim.sum() - cycles * CYCLE * 0.05) <= 0.5 * 0.010 + 1e-15
    np.testing.assert_allclose(pulses[:cycles, 0], CYCLE)  # the main jet is never held back


@pytest.mark.parametrize(("policy", "fired_ms"), [("round-up", 100.0), ("drop", 0.0)])
def test_the_minimum_pulse_policy_rounds_up_or_drops_each_short_share(policy, fired_ms):
    """The same trim jet (5 %: 2 ms a cycle under a 10 ms minimum) for 10 cycles: ``round-up``
    fires the minimum every cycle (10 x 10 ms: five times the 20 ms asked for), ``drop``
    never fires it; the main jet is never held back (profile docstring's rules)."""
    frac = np.zeros((6, 2))
    frac[0] = [1.0, 0.05]
    cmap = _map(frac, min_on_s=0.010, min_pulse=policy)
    rem = np.array([[10 * CYCLE, 0, 0, 0, 0, 0]])
    valves = cmap.initial(1)
    pulses = []
    for _ in range(12):
        on, delivered, valves = cmap.deliver(rem, valves)
        rem = rem - delivered
        pulses.append(on[0])
    pulses = np.array(pulses)
    assert pulses[:, 1].sum() * 1e3 == pytest.approx(fired_ms, abs=1e-9)
    np.testing.assert_allclose(pulses[:10, 0], CYCLE)


def test_an_unknown_minimum_pulse_policy_is_refused():
    with pytest.raises(InputError, match=r"min_pulse must be one of .*'round'"):
        _map(np.eye(6), min_on_s=0.01, min_pulse="round")
