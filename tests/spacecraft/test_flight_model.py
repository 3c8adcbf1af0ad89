"""The flight model (rcsim/spacecraft/flight_model.py) against the vehicle MJCF's own jets.

Oracle: MuJoCo stepping the packaged vehicle with its 16 site-transmission jet actuators
(``rcsim/models/vehicle/paper.toml``), with dispersed mass, CG, inertia, thrust and jet pointing
written into both models.  The flight model replaces the jets by a force and a torque computed
with :func:`rcsim.spacecraft.flight_model.jet_wrench_B`; the physics is the same sum in another
order, so the states must agree to rounding.  Tolerance 1e-12 (absolute, on quaternion
components and velocities of order 1e-2): measured differences are ~1e-16 per step and reach
~1e-14 after a 20 s campaign run; a wrong arm, sign or frame gives errors of order 1e-4 or more.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rcsim.models.tables import load_dispersions
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
from rcsim.spacecraft.flight_model import WRENCH_NAMES, flight_model, jet_wrench_B
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle import Vehicle, build_model, load_vehicle
from rcsim.spacecraft.vehicle.model import (
    BODY,
    N_JETS,
    dist_actuator_ids,
    jet_actuator_ids,
)
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: The paper's vehicle (paper.toml), for helpers outside the fixtures.
PAPER = Vehicle.load()

STATE_ATOL = 1e-12


def draw_dispersions(n: int, model: mujoco.MjModel, seed: int) -> RunParameters:
    """``n`` Table 5 vehicles (at three times Table 5's spread, so that pointing errors and CG
    offsets are large enough for a frame or arm mistake to show)."""
    sigmas = DispersionSigmas.from_table(load_dispersions(), scale=3.0)
    return draw_runs(PAPER.nominal(n), sigmas, seed, np.arange(n)).params


def _write_vehicle(model: mujoco.MjModel, params: RunParameters, run: int) -> None:
    body = model.body(BODY).id
    model.body_mass[body] = params.mass_kg[run]
    model.body_ipos[body] = params.cg_B[run]
    model.body_inertia[body] = params.inertia_B[run]


@pytest.mark.parametrize("run", [0, 1, 2])
def test_flight_model_flies_as_the_jets_do(run):
    """Random on-fractions of all 16 jets for 100 steps of 40 ms, a tumble and a disturbance
    torque, on a dispersed vehicle (Table 5 draws): both models give the same state."""
    jets_model = build_model(load_vehicle("paper"))
    params = draw_dispersions(3, jets_model, seed=11 + run)
    _write_vehicle(jets_model, params, run)
    jets = jet_actuator_ids(jets_model)
    jets_model.actuator_gainprm[jets, 0] = params.thrust_n[run]
    jets_model.actuator_gear[jets, 0:3] = params.jet_dir_S[run]
    mujoco.mj_setConst(jets_model, mujoco.MjData(jets_model))
    flight = flight_model(jets_model)
    wrench = jet_wrench_B(params.take([run]), jets_model)[0]  # (6, 16)

    rng = np.random.default_rng(run)
    on = rng.uniform(0.0, 1.0, size=(100, N_JETS)) * (rng.uniform(size=(100, N_JETS)) < 0.3)
    torque = np.array([0.4, -0.2, 0.3])
    states = []
    for model in (jets_model, flight):
        d = mujoco.MjData(model)
        q = np.array([0.9, 0.1, -0.3, 0.2])
        d.qpos[3:7] = q / np.linalg.norm(q)
        d.qvel[3:6] = [0.01, -0.02, 0.015]
        for k in range(len(on)):
            if model is jets_model:
                d.ctrl[jets] = on[k]
                d.ctrl[dist_actuator_ids(model)] = torque
            else:
                d.ctrl[:] = wrench @ on[k]
                d.ctrl[3:6] += torque
            mujoco.mj_step(model, d)
        states.append(np.r_[d.qpos, d.qvel])
    np.testing.assert_allclose(states[1], states[0], rtol=0, atol=STATE_ATOL)
    assert np.abs(states[0][7:10]).max() > 1e-4  # the jets did push the CG


def test_flight_model_keeps_the_vehicle_and_its_options():
    """Same body inertial values, options and disabled stages as the vehicle model; six
    actuators and nothing else that costs a step."""
    model = Vehicle.load("paper").with_physics(timestep_s=0.01, integrator="Euler").model
    flight = flight_model(model)
    body = model.body(BODY).id
    for name in ("body_mass", "body_ipos", "body_iquat", "body_inertia"):
        np.testing.assert_array_equal(getattr(flight, name)[1], getattr(model, name)[body])
    assert flight.opt.timestep == 0.01
    assert flight.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    assert flight.opt.disableflags == model.opt.disableflags
    assert [flight.actuator(i).name for i in range(flight.nu)] == list(WRENCH_NAMES)
    assert flight.ngeom == 0 and flight.nbody == 2


def test_a_vehicle_of_several_bodies_is_refused():
    two = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body name='vehicle'><freejoint/><geom size='1'/></body>"
        "<body name='b'><freejoint/><geom size='1'/></body></worldbody></mujoco>"
    )
    with pytest.raises(ValueError, match="one free body"):
        flight_model(two)


def test_batch_reads_back_what_it_flies(paper):
    """BatchSimulation's read-back: the jets' thrust and pointing it summed, the body values
    MuJoCo holds; bit for bit the dispersed parameters (invalid runs aside)."""
    model = build_model(load_vehicle("paper"))
    params = draw_dispersions(4, model, seed=5)
    sim = BatchSimulation(params, vehicle=paper, nthread=1)
    back = sim.flown_params()
    for name in ("mass_kg", "cg_B", "inertia_B", "thrust_n", "jet_dir_S"):
        np.testing.assert_array_equal(getattr(back, name), getattr(params, name))


def test_a_vehicle_with_its_cg_at_the_origin_flies_dispersed():
    """smallsat8's nominal CG is at the body origin with principal axes along the body's, so
    MuJoCo would compile it as a "simple" body; a run's dispersed CG and inertia move its
    inertial frame.  Every dispersed run must fly (MuJoCo refused each one before: "sameframe
    no longer holds"), and physics must hold: coasting with no jet, the angular momentum
    about the CG, I_N omega_N, is constant (Euler's equations, no torque); RK4 at 40 ms keeps
    it to ~1e-12 relative on these rates (docs/engine_facts.md), 1e-9 leaves room."""
    from pathlib import Path

    from scipy.spatial.transform import Rotation

    from rcsim.analysis.engine.campaign.spec import parse_dict
    from rcsim.analysis.engine.flight import Scenario, fly
    from rcsim.lookup.open_loop import OpenLoopController

    root = Path(__file__).resolve().parents[2]
    spec = parse_dict(  # the vehicle file's own [dispersions], as a campaign of it draws them
        {
            "vehicle": str(root / "docs/examples/smallsat8.toml"),
            "scenario": {"kind": "maneuver", "attitude_deg": [0.0, 0.0, 1.0], "duration_s": 1.0},
            "controller": {"name": "allocator"},
        },
        source="test",
        base_dir=root,
    )
    vehicle = spec.vehicle
    assert np.allclose(vehicle.model.body_ipos[1], 0)  # the case this test is about
    params = draw_runs(vehicle.nominal(1), spec.sigmas, 4, np.arange(6)).params
    assert not np.allclose(params.cg_B, 0)  # the dispersions move the CG off the origin
    coast = OpenLoopController(np.zeros(vehicle.n_jets), vehicle.control.cycle_s)
    spin = Scenario(name="coast", duration_s=20.0, omega0_rad_s=np.radians([2.0, -1.0, 1.5]))
    hist = fly(spin, vehicle=vehicle, params=params, controller_obj=coast)
    assert not np.any(hist.failed), hist.reason
    for i in range(params.n_runs):
        # Principal moments inertia_B along the principal axes iquat (scalar-first) in B.
        iquat = np.array([1.0, 0, 0, 0]) if params.iquat is None else params.iquat[i]
        axes = Rotation.from_quat(iquat[[1, 2, 3, 0]]).as_matrix()
        inertia = axes @ np.diag(params.inertia_B[i]) @ axes.T
        # q_BN is scalar-first and turns body vectors into the inertial frame.
        h = [
            Rotation.from_quat(hist.q_BN[i, k][[1, 2, 3, 0]]).as_matrix()
            @ (inertia @ hist.omega_B[i, k])
            for k in (0, -1)
        ]
        assert np.linalg.norm(h[1] - h[0]) <= 1e-9 * np.linalg.norm(h[0])
