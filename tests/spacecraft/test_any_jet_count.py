"""A vehicle flies whatever its jet count: every per-jet array is as wide as its model has jets.

Vehicle: five jets on a 200 kg body with principal inertia (40, 50, 60) kg m^2 about its CG at
the body origin, each jet a 10 N force 1 m from the CG, perpendicular to its arm, so each
torques one principal axis only: jet 1 +roll, 2 +pitch, 3 +yaw, 4 -yaw, 5 -roll (torque
``r x F``, 10 N m; worked out beside ``VEHICLE``).

Oracles
-------
* Euler's equations: a jet fired alone from rest for ``t`` torques one principal axis, so the
  body rate grows linearly with no gyroscopic term and ends at ``tau t / I`` about that axis,
  zero about the others.  Tolerance 1e-9 relative (the RK4 step of a constant torque about a
  principal axis is exact to rounding; the paper vehicle's jets are held to the same in
  ``tests/lookup/test_response_database.py``).
* A jet delivering a fraction ``f`` of its thrust (``JetFaults.thrust_factor``) gives ``f``
  times that rate change (same tolerance).
* The dispersion and timing draws of an ``n``-jet vehicle follow the layout the modules
  document (:mod:`rcsim.spacecraft.dispersions`: ``5 + 2 n`` normals -- mass, CG x, three inertias,
  a thrust and a tilt per jet -- then ``n`` azimuth uniforms; :mod:`rcsim.spacecraft.effect_draws`:
  ``1 + 2 n`` timing normals), rebuilt here from the same seed streams: exact equality.
"""

from __future__ import annotations

import numpy as np
import pytest

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.errors import InputError
from rcsim.models.tables import PAPER_CYCLE_S
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs, run_streams
from rcsim.spacecraft.effect_draws import (
    TIMING,
    FaultSpec,
    TimingSpec,
    draw_faults,
    draw_timing,
    effect_stream,
)
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.valves import JetFaults, ValveTiming
from rcsim.spacecraft.vehicle import Vehicle, build_model, load_vehicle
from rcsim.spacecraft.vehicle.model import jet_count

VEHICLE = """
[mass]
mass_kg = 200.0
cg_m = [0.0, 0.0, 0.0]
inertia_kg_m2 = [40.0, 50.0, 60.0]
[jet_defaults]
thrust_n = 10.0
[[jet]]                      # (0, 1, 0) x (0, 0, 10) = (10, 0, 0): +roll
position_m = [0.0, 1.0, 0.0]
direction = [0, 0, 1]
[[jet]]                      # (0, 0, 1) x (10, 0, 0) = (0, 10, 0): +pitch
position_m = [0.0, 0.0, 1.0]
direction = [1, 0, 0]
[[jet]]                      # (1, 0, 0) x (0, 10, 0) = (0, 0, 10): +yaw
position_m = [1.0, 0.0, 0.0]
direction = [0, 1, 0]
[[jet]]                      # (-1, 0, 0) x (0, 10, 0) = (0, 0, -10): -yaw
position_m = [-1.0, 0.0, 0.0]
direction = [0, 1, 0]
[[jet]]                      # (0, -1, 0) x (0, 0, 10) = (-10, 0, 0): -roll
position_m = [0.0, -1.0, 0.0]
direction = [0, 0, 1]
"""
TORQUE_N_M = np.array(
    [[10, 0, 0], [0, 10, 0], [0, 0, 10], [0, 0, -10], [-10, 0, 0]], float
)  # per jet, from the comments above
INERTIA = np.array([40.0, 50.0, 60.0])
ON_S = 0.2  # five whole 40 ms cycles


@pytest.fixture(scope="module")
def five(tmp_path_factory) -> Vehicle:
    path = tmp_path_factory.mktemp("vehicle") / "five.toml"
    path.write_text(VEHICLE)
    return Vehicle.load(path)


def _fly_each_jet(five, **kw):
    """Run j fires jet j alone for ON_S from rest."""
    n = five.n_jets
    on = np.diag(np.full(n, ON_S))
    return simulate_batch(
        five.nominal(n), OpenLoopController(on, five.control.cycle_s),
        Guidance.attitude(np.zeros((n, 3))), 2 * ON_S, vehicle=five, nthread=1, **kw,
    )  # fmt: skip


def test_jet_count_is_the_models():
    assert jet_count(build_model(load_vehicle("paper"))) == 16  # Table 2's jets
    vehicle = Vehicle.load("canted12")
    assert vehicle.n_jets == jet_count(vehicle.model) == vehicle.definition.n_jets == 12
    assert vehicle.nominal(3).thrust_n.shape == (3, 12)


def test_each_jet_alone_is_euler(five):
    assert five.n_jets == 5
    history = _fly_each_jet(five)
    assert history.on_time_s.shape[2] == history.propulsion.on_time_s.shape[1] == 5
    expect = TORQUE_N_M * ON_S / INERTIA  # (run = jet, axis) [rad/s]
    np.testing.assert_allclose(history.final.omega_B, expect, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(history.propulsion.on_time_s, np.diag(np.full(5, ON_S)), atol=1e-15)


def test_faults_per_jet_or_for_every_jet(five):
    every = _fly_each_jet(five, faults=JetFaults.of(5, thrust_factor=0.5))  # one column
    np.testing.assert_allclose(
        every.final.omega_B, 0.5 * TORQUE_N_M * ON_S / INERTIA, rtol=1e-9, atol=1e-15
    )
    factor = np.array([1.0, 0.25, 1.0, 1.0, 0.75])
    per_jet = _fly_each_jet(five, faults=JetFaults.of(5, thrust_factor=factor))
    expect = factor[:, None] * TORQUE_N_M * ON_S / INERTIA
    np.testing.assert_allclose(per_jet.final.omega_B, expect, rtol=1e-9, atol=1e-15)


def test_arrays_of_another_jet_count_are_refused(paper, five):
    n = 5
    with pytest.raises(InputError, match="per-jet values for 16 jets; the vehicle has 5"):
        _fly_each_jet(five, faults=JetFaults.of(n, thrust_factor=np.ones(16)))
    with pytest.raises(InputError, match="per-jet values for 16 jets; the vehicle has 5"):
        _fly_each_jet(five, timing=ValveTiming.of(n, open_delay_s=np.full(16, 0.005)))
    with pytest.raises(InputError, match="16 jets per run; the vehicle model has 5"):
        simulate_batch(
            paper.nominal(n), OpenLoopController(np.zeros(5), PAPER_CYCLE_S),
            Guidance.attitude(np.zeros((n, 3))), 0.04, vehicle=five,
        )  # fmt: skip
    with pytest.raises(InputError, match=r"shape \(5, 16\); the vehicle flies 5 run\(s\) of 5"):
        simulate_batch(
            five.nominal(n), OpenLoopController(np.zeros(16), PAPER_CYCLE_S),
            Guidance.attitude(np.zeros((n, 3))), 0.04, vehicle=five,
        )  # fmt: skip


def test_draws_follow_the_documented_layout(five):
    sig = DispersionSigmas(
        mass_kg=5.0, cg_x_m=0.01, inertia_kg_m2=(1.0, 2.0, 3.0), thrust_n=0.3,
        thruster_angle_rad=0.02,
    )  # fmt: skip
    nominal = five.nominal(1)
    runs = draw_runs(nominal, sig, 11, [4])
    rng = np.random.default_rng(run_streams(11, 4)[0])
    z, u = rng.standard_normal(5 + 2 * 5), rng.random(5)
    p = runs.params
    assert p.mass_kg[0] == nominal.mass_kg[0] + 5.0 * z[0]
    assert p.cg_B[0, 0] == nominal.cg_B[0, 0] + 0.01 * z[1]
    np.testing.assert_array_equal(p.inertia_B[0], nominal.inertia_B[0] + [1.0, 2.0, 3.0] * z[2:5])
    np.testing.assert_array_equal(p.thrust_n[0], nominal.thrust_n[0] + 0.3 * z[5:10])
    np.testing.assert_array_equal(runs.tilt_rad[0], 0.02 * z[10:15])
    np.testing.assert_array_equal(runs.azimuth_rad[0], 2 * np.pi * u)

    timing = draw_timing(TimingSpec(open_delay_s=0.01, open_delay_sigma_s=0.001), 11, [4], 5)
    zt = np.random.default_rng(effect_stream(11, 4, TIMING)).standard_normal(1 + 2 * 5)
    assert timing.open_delay_s.shape == timing.close_delay_s.shape == (1, 5)
    np.testing.assert_array_equal(timing.open_delay_s[0], np.maximum(0.01 + 0.001 * zt[1:6], 0))


def test_fault_jets_are_the_vehicles(five):
    faults, drawn = draw_faults(FaultSpec(mode="off", probability=1.0), 3, np.arange(100), 5)
    assert faults.off_from_s.shape == (100, 5)
    assert set(drawn["fault_jet"]) == {1, 2, 3, 4, 5}  # the default: every jet of the vehicle
    with pytest.raises(InputError, match="no jet 6: the vehicle has jets 1..5"):
        draw_faults(FaultSpec(mode="off", jets=(2, 6)), 3, np.arange(4), 5)
