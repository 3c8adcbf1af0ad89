"""The compiled lookup cycle (rcsim/lookup/_step_kernel.c) is the numpy form bit for bit.

Oracle: ``LookupController.step_detail``'s numpy form, the reference the kernel transcribes
(``RCSIM_NUMPY_CONTROLLER=1`` switches the kernel off).  Equality is exact (bytes), not a
tolerance: the kernel claims the same operations in the same order, and campaigns must give
the same ``runs.parquet`` with or without it.
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.lookup import step_kernel
from rcsim.lookup.pattern_recognition import (
    LookupController,
    LookupParams,
    LookupState,
    load_default_table,
)
from rcsim.models.tables import load_lookup_table
from rcsim.spacecraft.navigation import NavState
from rcsim.spacecraft.vehicle import Vehicle

#: The lookup logic's inputs from the paper vehicle's profile (paper.toml [control]).
LOOKUP_PARAMS = LookupParams.from_profile(Vehicle.load().control)

pytestmark = pytest.mark.skipif(
    step_kernel._step_kernel is None, reason="the optional extension was not built"
)

DEG = np.pi / 180.0


def _both(monkeypatch, controller, nav, state, case_scale=None):
    """step_detail with the kernel and with the numpy form."""
    compiled = controller.step_detail(nav, state, case_scale)
    monkeypatch.setenv("RCSIM_NUMPY_CONTROLLER", "1")
    reference = controller.step_detail(nav, state, case_scale)
    monkeypatch.delenv("RCSIM_NUMPY_CONTROLLER")
    return compiled, reference


def _assert_same_bits(compiled, reference):
    on_c, state_c, detail_c = compiled
    on_r, state_r, detail_r = reference
    pairs = [
        ("on_time_s", on_c, on_r),
        ("remaining_s", state_c.remaining_s, state_r.remaining_s),
        ("hold_s", state_c.hold_s, state_r.hold_s),
    ] + [(k, np.asarray(detail_c[k]), np.asarray(detail_r[k])) for k in detail_r]
    for name, a, b in pairs:
        assert a.shape == b.shape, name
        assert a.dtype.kind == b.dtype.kind, name
        assert np.array_equal(a, b), name
        if a.dtype.kind == "f":  # signed zeros too
            assert a.tobytes() == b.tobytes(), name


def _random_state(rng, n, n_jets, params):
    """States that reach every branch: attitude errors around the maneuver limit and inside
    the no-firing band, rate errors around the dead band, remaining on-times around the
    on-time limit, hold timers running and run out, exact zeros."""
    lim = params.maneuver_limit_rad
    theta = rng.choice(
        [0.0, 0.5 * lim, lim, lim + 0.5 * params.no_fire_band_rad, 3 * lim], size=n
    ) * rng.uniform(0.9, 1.1, n)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    att = theta[:, None] * axis
    att[rng.random(n) < 0.1] = 0.0
    rel = params.rate_error_limit_rad_s
    rate = rng.choice([-3, -1.01, -0.99, 0, 0.99, 1.01, 3], size=(n, 3)) * rel
    rate *= rng.uniform(0.5, 1.5, (n, 3))
    rem = rng.choice([0.0, 0.01, params.on_time_limit_s, 0.05, 0.3], size=(n, n_jets))
    rem *= rng.random((n, n_jets)) < 0.3
    hold = rng.choice([0.0, 1e-10, 0.04, params.hold_time_s], size=(n, 3))
    nav = NavState(0.0, np.tile([1.0, 0, 0, 0], (n, 1)), rate, att, rate, np.zeros((n, 3)))
    return nav, LookupState(remaining_s=rem, hold_s=hold)


@pytest.mark.parametrize("table", ["default", "table6", "table7"])
def test_random_states_give_the_numpy_cycle_bit_for_bit(monkeypatch, table):
    tab = load_default_table() if table == "default" else load_lookup_table(table)
    controller = LookupController(tab, LOOKUP_PARAMS)
    rng = np.random.default_rng(20261126)
    for _ in range(20):
        nav, state = _random_state(rng, 500, 16, controller.params)
        _assert_same_bits(*_both(monkeypatch, controller, nav, state))


def test_per_run_tables_and_case_scales_give_the_numpy_cycle(monkeypatch):
    """Refinement's candidate tables (for_runs, (n, 26, 16)) and the adaptive controller's
    per-run, per-case axis factors take the kernel's other two paths."""
    tab = load_default_table()
    rng = np.random.default_rng(7)
    n = 300
    times = np.asarray(tab.firing_time_s)[None] * rng.choice([0.75, 1.0, 1.3], size=(n, 26, 16))
    controller = LookupController.for_runs(tab, times, LOOKUP_PARAMS)
    scale = rng.uniform(0.5, 1.5, (n, 26, 3))
    for _ in range(10):
        nav, state = _random_state(rng, n, 16, controller.params)
        _assert_same_bits(*_both(monkeypatch, controller, nav, state))
        _assert_same_bits(*_both(monkeypatch, controller, nav, state, scale))


@pytest.mark.parametrize("table", ["default", "table6"])
def test_a_campaign_flight_is_the_same_with_and_without_the_kernel(monkeypatch, tmp_path, table):
    """26 rate cases x 2 runs under Table 5 dispersions, 20 s: every recorded array of the
    history equal byte for byte (Table 6 fails and re-fires in some of them)."""
    from rcsim.analysis.engine.campaign.chunk import fly_runs
    from rcsim.analysis.engine.campaign.spec import load_spec

    path = tmp_path / "spec.toml"
    path.write_text(
        f'seed = 11\nruns_per_case = 2\n[scenario]\ncases = "all"\nduration_s = 20\n'
        f'[controller]\nname = "lookup"\ntable = "{table}"\n'
    )
    spec = load_spec(path)
    ids = np.arange(spec.n_runs)
    compiled, _ = fly_runs(spec, ids)
    monkeypatch.setenv("RCSIM_NUMPY_CONTROLLER", "1")
    reference, _ = fly_runs(spec, ids)
    fields = ["q_BN", "omega_B", "att_err_B", "rate_err_B", "on_time_s", "failed"]
    for name in fields:
        a, b = np.asarray(getattr(compiled, name)), np.asarray(getattr(reference, name))
        assert a.tobytes() == b.tobytes(), name
    assert compiled.final.omega_B.tobytes() == reference.final.omega_B.tobytes()
    assert np.asarray(compiled.on_time_s).sum() > 0  # the controller fired


def test_maneuver_hysteresis_gives_the_numpy_cycle(monkeypatch):
    """With a hysteresis band (the profile's maneuver_hysteresis_deg) the maneuver flag is
    carried in the state; runs just below the limit that were maneuvering keep the maneuver
    rate, and both forms agree bit for bit (flags included)."""
    from dataclasses import replace

    params = replace(LOOKUP_PARAMS, maneuver_hysteresis_rad=0.2 * DEG)
    controller = LookupController(load_default_table(), params)
    rng = np.random.default_rng(11)
    for _ in range(10):
        nav, state = _random_state(rng, 500, 16, params)
        state.maneuvering = rng.random(500) < 0.5
        compiled, reference = _both(monkeypatch, controller, nav, state)
        _assert_same_bits(compiled, reference)
        assert np.array_equal(compiled[1].maneuvering, reference[1].maneuvering)
        theta = np.linalg.norm(nav.att_err_B, axis=1)
        held = state.maneuvering & (theta < params.maneuver_limit_rad)
        held &= theta > params.maneuver_limit_rad - params.maneuver_hysteresis_rad
        assert held.any() and compiled[1].maneuvering[held].all()
