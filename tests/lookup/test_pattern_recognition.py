"""The pattern-recognition lookup controller (Gambone sec. II-III, Table 4, Figs 5-8, 17-18).

Oracles: the paper's Table 2 (restated below) for what the controller must *learn*; Table 4
(0.6 deg, 0.2 deg/s, 0.06 deg/s, 0.03 s, 0.16 s); the text of sec. II for the gates; sec. III
("two equal and opposite thruster firings", Figs 5-6) and Figs 17-18 for closed-loop behaviour.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rcsim.models.tables as model_tables
import rcsim.spacecraft.vehicle.run_parameters as run_parameters_mod
from rcsim.analysis.engine.scenarios import PaperScenario, fly_scenario, get_scenario
from rcsim.lookup.pattern_recognition import (
    LookupController,
    LookupParams,
    LookupState,
    learn_jets,
    load_default_table,
)
from rcsim.lookup.registry import make_controller
from rcsim.models.errors import InputError
from rcsim.models.tables import LookupTable, load_lookup_table
from rcsim.spacecraft.navigation import NavState
from rcsim.spacecraft.vehicle import Vehicle

#: The paper's vehicle (paper.toml).
PAPER = Vehicle.load()

#: The lookup logic's inputs from the paper vehicle's profile (paper.toml [control]).
LOOKUP_PARAMS = LookupParams.from_profile(Vehicle.load().control)

DEG = np.pi / 180.0
CYCLE_S = 0.04
PAPER_JETS = {
    1: (0, -1),
    3: (0, -1),
    2: (0, +1),
    4: (0, +1),
    9: (1, -1),
    11: (1, -1),
    10: (1, +1),
    12: (1, +1),
    13: (2, -1),
    15: (2, -1),
    14: (2, +1),
    16: (2, +1),
}
OPPOSING = [
    (j, k)
    for j, (a, s) in PAPER_JETS.items()
    for k, (b, t) in PAPER_JETS.items()
    if a == b and s == -t
]


def nav(att_err_deg=(0, 0, 0), rate_err_deg_s=(0, 0, 0), omega_cmd_deg_s=(0, 0, 0)):
    """A NavState for one or more runs from degree inputs, shape (n, 3) or (3,)."""
    e = np.atleast_2d(np.asarray(att_err_deg, float)) * DEG
    r = np.atleast_2d(np.asarray(rate_err_deg_s, float)) * DEG
    c = np.atleast_2d(np.asarray(omega_cmd_deg_s, float)) * DEG * np.ones_like(r)
    q = np.tile([1.0, 0, 0, 0], (r.shape[0], 1))
    return NavState(0.0, q, r + c, e * np.ones_like(r), r, c)


@pytest.fixture(scope="module")
def ctl():
    return LookupController(load_default_table(), LOOKUP_PARAMS)


@pytest.mark.parametrize("which", ["table6", "table7", "generated"])
def test_learns_table2_from_the_table_alone(which):
    table = load_default_table() if which == "generated" else load_lookup_table(which=which)
    axis, sign, opposing = learn_jets(table)
    for j in range(1, 17):
        expected = PAPER_JETS.get(j, (-1, 0))
        assert (axis[j - 1], sign[j - 1]) == expected, f"jet {j}"
    assert {(j + 1, k + 1) for j, k in np.argwhere(opposing)} == set(OPPOSING)


def test_jet_on_two_axes_is_rejected():
    t = load_default_table()
    ft = np.array(t.firing_time_s)
    ft[21, 0] = 0.52  # jet 1 (roll -) also fires in case 22 (+,0,0)
    bad = LookupTable(case=t.case, rate_cmd=t.rate_cmd, firing_time_s=ft, source="bad.csv")
    with pytest.raises(InputError, match="bad.csv.*jet_01"):
        LookupController(bad, LOOKUP_PARAMS)


def test_params_default_to_table4():
    p = LOOKUP_PARAMS
    np.testing.assert_allclose(
        [
            p.maneuver_limit_rad / DEG,
            p.maneuver_rate_rad_s / DEG,
            p.rate_error_limit_rad_s / DEG,
            p.on_time_limit_s,
            p.hold_time_s,
            p.no_fire_band_rad / DEG,
            p.cycle_s,
        ],
        [0.6, 0.2, 0.06, 0.03, 0.16, 0.1, 0.04],
        rtol=1e-12,
    )
    with pytest.raises(InputError, match="rate_error_limit_rad_s"):
        replace(p, rate_error_limit_rad_s=-1.0)


def test_rate_error_logic(ctl):
    """Sec. II: maneuver rate split along the attitude error above the limit; commanded rate
    below; dead band per axis."""
    w = 0.2 * DEG
    # 3-4-0 deg error (5 deg total) at rest: target rate -0.2 deg/s along (0.6, 0.8, 0).
    err = ctl.rate_error(nav(att_err_deg=(3, 4, 0)))
    np.testing.assert_allclose(err[0], [0.6 * w, 0.8 * w, 0.0], rtol=1e-12)
    # Below the limit: against the commanded rate; 0.05 deg/s < 0.06 is dead-banded.
    err = ctl.rate_error(nav(att_err_deg=(0.3, 0, 0), rate_err_deg_s=(0.05, -0.1, 0.07)))
    np.testing.assert_allclose(err[0], [0.0, -0.1 * DEG, 0.07 * DEG], rtol=1e-12)


def test_first_firing_scaled_from_table(ctl):
    """A +0.2 deg/s yaw rate error selects case (0,0,-) and fires the -yaw jets (13, 15) for the
    table time times 0.2/0.3 (the scale factor of our reading); 0.4 s in the generated table."""
    on, state = ctl.step(nav(rate_err_deg_s=(0, 0, 0.2)), ctl.initial_state(1))
    assert set(np.flatnonzero(on[0]) + 1) == {13, 15}
    np.testing.assert_allclose(on[0, [12, 14]], CYCLE_S)
    np.testing.assert_allclose(state.remaining_s[0, [12, 14]], 0.4 * 2 / 3 - CYCLE_S, rtol=1e-12)


def test_no_fire_band(ctl):
    """Figs 17-18: no new firing within +-0.1 deg of the 0.6 deg maneuver limit."""
    n = nav(att_err_deg=(0, 0, 0.65))  # in the band, maneuver rate error 0.2 deg/s
    on, _ = ctl.step(n, ctl.initial_state(1))
    assert not on.any()
    off = LookupController(ctl.table, replace(ctl.params, no_fire_band_rad=0.0))
    on, _ = off.step(n, off.initial_state(1))
    assert set(np.flatnonzero(on[0]) + 1) == {13, 15}


def test_gates_block_new_firings(ctl):
    """Sec. II: no new firing while an opposing jet's remaining on-time >= 0.03 s, or during
    the hold time after the axis's firing."""
    n = nav(rate_err_deg_s=(0, 0, 0.2))  # wants -yaw (13, 15)
    busy = ctl.initial_state(1)
    busy.remaining_s[0, [13, 15]] = 0.05  # +yaw pair still firing
    on, state = ctl.step(n, busy)
    assert set(np.flatnonzero(on[0]) + 1) == {14, 16}  # the old firing goes on
    held = ctl.initial_state(1)
    held.hold_s[0, 2] = 0.08
    on, state = ctl.step(n, held)
    assert not on.any()
    np.testing.assert_allclose(state.hold_s[0, 2], 0.04)


# ---------------------------------------------------------------- property tests (Hypothesis)
_vec = st.lists(st.floats(-1.5, 1.5, allow_nan=False), min_size=3, max_size=3)
_navs = st.lists(st.tuples(_vec, _vec), min_size=1, max_size=25)


def _run(ctl, seq, signs=np.ones(3)):
    """Step a batch of one through ``seq`` of (att_err_deg, rate_err_deg_s); yield
    (nav, prev_state, on, state)."""
    state = ctl.initial_state(1)
    for att, rate in seq:
        n = nav(att_err_deg=np.asarray(att) * signs, rate_err_deg_s=np.asarray(rate) * 0.3 * signs)
        on, new = ctl.step(n, state)
        yield n, state, on, new
        state = new


@settings(max_examples=60, deadline=None)
@given(seq=_navs)
def test_commands_within_limits(ctl, seq):
    """On-times in [0, cycle]; conserved (on + remaining = previous remaining) unless the axis
    was re-planned, which only happens with every jet of the axis below the on-time limit, the
    hold over and outside the no-firing region; opposing jets never fire together."""
    p = ctl.params
    axis = ctl.jet_axis_
    for n, prev, on, new in _run(ctl, seq):
        assert np.all(on >= 0) and np.all(on <= CYCLE_S + 1e-15)
        for j, k in OPPOSING:
            assert not (on[0, j - 1] > 0 and on[0, k - 1] > 0)
        changed = ~np.isclose(on[0] + new.remaining_s[0], prev.remaining_s[0], atol=1e-12)
        assert not changed[axis < 0].any()
        theta = np.linalg.norm(n.att_err_B[0])
        for a in np.unique(axis[changed]):
            jets = axis == a
            assert np.all(prev.remaining_s[0, jets] < p.on_time_limit_s)
            assert prev.hold_s[0, a] <= 1e-9
            assert abs(theta - p.maneuver_limit_rad) >= p.no_fire_band_rad
        assert np.all(new.remaining_s >= 0) and np.all(new.hold_s >= 0)


@settings(max_examples=40, deadline=None)
@given(seq=_navs, signs=st.sampled_from([(-1, 1, 1), (1, -1, 1), (1, 1, -1), (-1, -1, -1)]))
def test_sign_symmetry(ctl, seq, signs):
    """Mirroring the errors on some axes mirrors the commands: each jet's role is taken by the
    opposing jet of its pair (2<->1, 4<->3, ...).  Needs a mirror-symmetric table, which the
    generated one is (the vehicle's jet arms are symmetric)."""
    t = np.asarray(ctl.table.firing_time_s)
    perm = np.arange(16)
    for a, s in enumerate(signs):
        if s < 0:
            plus = sorted(j - 1 for j, (b, u) in PAPER_JETS.items() if b == a and u > 0)
            minus = sorted(j - 1 for j, (b, u) in PAPER_JETS.items() if b == a and u < 0)
            perm[plus], perm[minus] = minus, plus
    pattern = np.sign(ctl.table.rate_cmd) * np.asarray(signs)
    mirror_case = [
        int(np.flatnonzero((np.sign(ctl.table.rate_cmd) == row).all(1))[0]) for row in pattern
    ]
    np.testing.assert_allclose(t[mirror_case][:, perm], t, atol=1e-12)  # symmetric table
    for (_, _, on, _), (_, _, on_m, _) in zip(_run(ctl, seq), _run(ctl, seq, np.array(signs))):
        np.testing.assert_allclose(on_m[0, perm], on[0], atol=1e-12)


# ---------------------------------------------------------------- closed loop (simulation)
@pytest.fixture(scope="module")
def single_axis():
    runs = tuple(get_scenario(f"single-axis-{a}").runs[0] for a in ("roll", "pitch", "yaw"))
    scn = PaperScenario("single-axis-all", "", "", runs)
    return fly_scenario(scn, "lookup")


def test_single_axis_two_equal_opposite_firings(single_axis):
    """Sec. III / Figs 5-6: one firing builds the maneuver rate, one equal and opposite firing
    stops it.  "Equal" to within the table's quantization: the stop firing scales with the
    rate actually reached, which differs from 0.2 deg/s by the table's rounding of the
    pure-axis time (|0.52-0.5194|/0.5194, |0.48-0.4794|/0.4794, |0.40-0.3995|/0.3995 <= 0.13 %),
    so 0.5 % relative."""
    h = single_axis
    for run, a in enumerate(range(3)):
        plus = [j - 1 for j, (b, s) in PAPER_JETS.items() if b == a and s > 0]
        minus = [j - 1 for j, (b, s) in PAPER_JETS.items() if b == a and s < 0]
        firings = h.propulsion.firings[run]
        assert firings.sum() == 4 and np.all(firings[plus + minus] == 1)
        on = h.on_time_s[run]
        first_plus = np.flatnonzero(on[:, plus].sum(1))[0]
        first_minus = np.flatnonzero(on[:, minus].sum(1))[0]
        assert first_plus < first_minus  # +5 deg command: + jets start, - jets stop
        t_plus, t_minus = on[:, plus].sum(0), on[:, minus].sum(0)
        np.testing.assert_allclose(t_minus, t_plus, rtol=5e-3)


def test_single_axis_ends_in_deadbands(single_axis):
    """Ends below the 0.6 deg maneuver limit with every rate error below 0.06 deg/s (Table 4)."""
    final = single_axis.final
    assert np.all(np.linalg.norm(final.att_err_B, axis=1) < 0.6 * DEG)
    assert np.all(np.abs(final.rate_err_B) < 0.06 * DEG)


def test_controller_needs_no_vehicle_knowledge(paper, monkeypatch):
    """The controller never reads mass properties or the jet map: it is built from a table with
    those loaders disabled, and flies a 5 deg three-axis maneuver to the hold region on
    vehicles with -25 %/+30 % inertia and -30 %/+20 % thrust, using the nominal table."""
    table = load_default_table()

    def forbidden(*a, **k):
        raise AssertionError("controller read vehicle knowledge")

    for mod, name in (
        (model_tables, "load_jet_map"),
        (model_tables, "load_mass_properties"),
        (run_parameters_mod, "torque_per_jet_B"),
    ):
        monkeypatch.setattr(mod, name, forbidden)
    ctl = LookupController(table, LOOKUP_PARAMS)
    monkeypatch.undo()  # the simulator itself may use the model
    # 90 s: the weakest vehicle (1.3 x inertia) flies at 0.2/1.3 deg/s, 8.66 deg in ~56 s.
    base = replace(get_scenario("three-axis-5deg").runs[0], duration_s=90.0)
    scn = PaperScenario("offnominal", "", "", (base,) * 4)
    p = paper.nominal(4)
    p = replace(
        p,
        inertia_B=p.inertia_B * np.array([[0.75], [1.3], [1.0], [1.3]]),
        thrust_n=p.thrust_n * np.array([[1.0], [1.0], [0.7], [1.2]]),
    )
    h = fly_scenario(scn, controller_obj=ctl, params=p)
    # Converged = held in the hold region for the last 15 s: total error below 0.75 deg (the
    # 0.7 deg edge of the no-firing region + 0.05 deg while a correction builds, as in the
    # hold test) and rates below the maneuver rate + dead band (0.26 deg/s).  Not "final rate
    # error < 0.06 deg/s": a residual rate just under the dead band drifts the attitude to
    # 0.7 deg, where the logic corrects it (measured: run 4 is mid-correction at 60 s).
    last = h.t_s >= h.t_s[-1] - 15.0
    assert not h.failed.any()
    assert np.linalg.norm(h.att_err_B[:, last], axis=2).max() < 0.75 * DEG
    assert np.abs(h.rate_err_B[:, last]).max() < 0.26 * DEG


def test_hold_band_fires_less():
    """Figs 17-18: under a large disturbance the no-firing region cuts the firings."""
    with_band = fly_scenario(get_scenario("attitude-hold-disturbed"), "lookup")
    without = fly_scenario(get_scenario("attitude-hold-disturbed-no-band"), "lookup")
    n_with = with_band.propulsion.firings.sum()
    n_without = without.propulsion.firings.sum()
    assert n_with < n_without
    # Both hold the attitude near the limit: the band lets it reach 0.7 deg, not more
    # (+0.05 deg for the overshoot while the maneuver rate builds, measured ~0.02 deg).
    for h, limit in ((with_band, 0.75), (without, 0.65)):
        assert np.linalg.norm(h.att_err_B[0], axis=1).max() < limit * DEG


def test_registry_and_missing_table(tmp_path):
    assert isinstance(make_controller("lookup", PAPER), LookupController)
    with pytest.raises(InputError, match="nope.csv"):
        make_controller("lookup", PAPER, table=tmp_path / "nope.csv")


def test_state_shapes(ctl):
    s = ctl.initial_state(5)
    assert isinstance(s, LookupState)
    assert s.remaining_s.shape == (5, 16) and s.hold_s.shape == (5, 3)
    on, s2 = ctl.step(nav(rate_err_deg_s=np.zeros((5, 3))), s)
    assert on.shape == (5, 16) and not on.any()


@pytest.mark.parametrize("hysteresis_deg", [0.0, 0.2])
def test_maneuver_hysteresis(ctl, hysteresis_deg):
    """Step 1 with the profile's maneuver_hysteresis_deg: a run that flew the maneuver at 0.8
    deg keeps asking for the maneuver rate (0.2 deg/s along the error) at 0.5 deg when the
    hysteresis is 0.2 deg (0.5 > 0.6 - 0.2), and asks for none at 0 (the paper's rule); at
    0.3 deg both have left the maneuver.  Exact: the rate error is the 0.2 deg/s itself."""
    from dataclasses import replace as _replace

    c = LookupController(
        ctl.table, _replace(ctl.params, maneuver_hysteresis_rad=hysteresis_deg * DEG)
    )
    state = c.initial_state(1)
    _, state = c.step(nav(att_err_deg=(0, 0, 0.8)), state)
    assert state.maneuvering is not None and state.maneuvering[0]
    _, state = c.step(nav(att_err_deg=(0, 0, 0.5)), state)
    assert bool(state.maneuvering[0]) is (hysteresis_deg > 0)
    err = c.rate_error(nav(att_err_deg=(0, 0, 0.5)), maneuver=state.maneuvering)
    expect = 0.2 * DEG if hysteresis_deg > 0 else 0.0
    np.testing.assert_allclose(err[0], [0.0, 0.0, expect], rtol=1e-12)
    _, state = c.step(nav(att_err_deg=(0, 0, 0.3)), state)
    assert not state.maneuvering[0]
