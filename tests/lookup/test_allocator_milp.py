"""The allocator in ``propellant`` mode against an independent mixed-integer optimum.

Oracle: scipy's ``milp`` (HiGHS branch and bound) on the problem written here from the
vehicle's jet model alone, in SI units and without the allocator's scaling, elastic residual,
tie-break or LP warm start::

    min  mdot . t   s.t.  D t = b,   t_min z <= t <= T z,   z in {0, 1}^n

(``T`` = 10 s: no command below bounds a jet longer; the rate cases need < 1 s; the cost is
solved in seconds of the dearest jet, as HiGHS' absolute gap is 1e-6).  Commands:
the 26 rate cases of Table 3 at the profile's ``rate_case_deg_s`` and the 3 single-axis
maneuver starts at the maneuver rate, on canted12, canted16 (packaged), service16 (15 t) and
smallsat8 (30 kg; docs/examples).  Tolerance 1 % (the issue's acceptance figure); the two
solves differ only by the MILP gap (1e-9 here, HiGHS' default 1e-4 there) and the tie-break
(10^-6 relative), so 1 % is loose -- the measured worst is printed by
``benchmarks/allocator.py --milp``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import Bounds, LinearConstraint, milp

from rcsim.lookup.allocator_controller import allocator_controller, jet_model
from rcsim.spacecraft.vehicle import Vehicle

VEHICLES = ["canted12", "canted16", "docs/examples/service16.toml", "docs/examples/smallsat8.toml"]


def commands(vehicle: Vehicle) -> np.ndarray:
    """(29, 3) rate changes [rad/s]: the 26 rate cases and 3 maneuver starts."""
    signs = np.array([s for s in itertools.product((-1, 0, 1), repeat=3) if any(s)], float)
    cases = signs / np.linalg.norm(signs, axis=1, keepdims=True) * vehicle.control.rate_case_rad_s
    return np.vstack([cases, np.eye(3) * vehicle.control.maneuver_rate_rad_s])


def independent_optimum(D, mdot, t_min, b) -> float:
    """Least propellant [kg] of an exact plan for ``b`` (module docstring)."""
    n = D.shape[1]
    big = 10.0
    link = np.zeros((2 * n, 2 * n))
    link[:n, :n], link[:n, n:] = np.eye(n), -big * np.eye(n)
    link[n:, :n], link[n:, n:] = np.eye(n), -np.diag(t_min)
    # Cost in seconds of the dearest jet: HiGHS' absolute MIP gap (1e-6) on an objective in kg
    # (~1e-5) would stop it 10 % from the optimum.
    res = milp(
        np.r_[mdot / mdot.max(), np.zeros(n)],
        constraints=[
            LinearConstraint(np.hstack([D, np.zeros((3, n))]), b, b),
            LinearConstraint(
                link,
                np.r_[np.full(n, -np.inf), np.zeros(n)],
                np.r_[np.zeros(n), np.full(n, np.inf)],
            ),
        ],
        integrality=np.r_[np.zeros(n), np.ones(n)],
        bounds=Bounds(0, np.r_[np.full(n, np.inf), np.ones(n)]),
        options={"mip_rel_gap": 1e-9},
    )
    assert res.status == 0, res.message
    return float(res.fun) * mdot.max()


@pytest.mark.parametrize("name", VEHICLES)
def test_propellant_mode_is_within_one_percent_of_the_milp_optimum(name):
    vehicle = Vehicle.load(name)
    assert vehicle.control.allocation == "propellant"  # the default mode
    ctrl = allocator_controller(vehicle)
    D, _, mdot, _ = jet_model(vehicle.model, vehicle.isp_s)
    t_min = ctrl.allocator.t_min
    assert vehicle.min_on_s > 0 and (t_min > 0).all()  # the minimum binds on all four
    b = commands(vehicle)
    t, residual = ctrl.allocator.allocate(b)
    fired = t > 0
    assert (t[fired] >= np.broadcast_to(t_min, t.shape)[fired] * (1 - 1e-9)).all()
    assert np.abs(residual).max() <= 1e-6 * np.abs(b).max()
    ours = t @ mdot
    best = np.array([independent_optimum(D, mdot, t_min, row) for row in b])
    assert (ours <= best * 1.01).all(), np.max(ours / best)
    assert (ours >= best * (1 - 1e-6)).all()  # nothing beats the optimum: the oracle is sound


def test_vehicle_check_translation_coupling_figures():
    """``rcsim vehicle check``'s coupling section (rcsim/lookup/translation_coupling.py) on
    smallsat8, whose eight jets all push +x: no mode can cancel the force, so every mode still
    reaches each rate change (translation-first must not leave one undone) and leaves +x
    delta-v; its figures per deg/s equal the allocator's plan for 1 deg/s divided by 1 (G t,
    mdot . t), recomputed here.  On canted16 translation-first cancels the force (to what the
    minimum on-time allows) and costs at least the propellant mode's propellant (the cheapest)."""
    from rcsim.lookup.translation_coupling import DIRECTIONS, coupling_text, translation_coupling

    small = Vehicle.load("docs/examples/smallsat8.toml")
    c = translation_coupling(small)
    D, G, mdot, _ = jet_model(small.model, small.isp_s)
    for mode in c.propellant_kg_per_deg_s:
        assert (c.residual_deg_s[mode] < 1e-9).all(), mode
        assert (c.dv_B_m_s_per_deg_s[mode][:, 0] > 0).all(), mode
    t, _ = allocator_controller(small).allocator.allocate(np.radians([[0.0, 0.0, 1.0]]))
    yaw = DIRECTIONS.index("+yaw")
    np.testing.assert_allclose(
        c.propellant_kg_per_deg_s["propellant"][yaw], t[0] @ mdot, rtol=1e-12
    )
    np.testing.assert_allclose(
        c.dv_B_m_s_per_deg_s["propellant"][yaw, 0], (G @ t[0])[0], rtol=1e-12
    )
    assert "unreachable" not in coupling_text(small, c)
    canted = translation_coupling(Vehicle.load("canted16"))
    # Cancelled up to what the 10 ms minimum on-time allows (a cancelling share below it is
    # a whole minimum pulse or none): measured 7e-5 m/s against 0.015 m/s in propellant mode.
    first = np.linalg.norm(canted.dv_B_m_s_per_deg_s["translation-first"], axis=1).max()
    assert first < 0.01 * np.linalg.norm(canted.dv_B_m_s_per_deg_s["propellant"], axis=1).max()
    assert (
        canted.propellant_kg_per_deg_s["translation-first"]
        >= canted.propellant_kg_per_deg_s["propellant"] * (1 - 1e-9)
    ).all()
    assert np.linalg.norm(canted.dv_B_m_s_per_deg_s["propellant"], axis=1).max() > 1e-3


def test_the_milp_fallback_is_within_one_percent_too(monkeypatch):
    """When the branch and bound runs out of nodes (forced here: one node), HiGHS' MILP gives
    the plan; canted16, the same commands and oracle, the same 1 %."""
    import rcsim.lookup.allocator as allocator_module

    monkeypatch.setattr(allocator_module, "MAX_NODES", 1)
    vehicle = Vehicle.load("canted16")
    alloc = allocator_controller(vehicle).allocator
    D, _, mdot, _ = jet_model(vehicle.model, vehicle.isp_s)
    b = commands(vehicle)
    t, _ = alloc.allocate(b)
    assert alloc.n_milp > 0  # the fallback ran
    best = np.array([independent_optimum(D, mdot, alloc.t_min, row) for row in b])
    assert ((t @ mdot) <= best * 1.01).all()
