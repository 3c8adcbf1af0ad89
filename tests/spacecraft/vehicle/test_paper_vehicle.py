"""The paper's vehicle through the vehicle file format is the hand-written MJCF, bit for bit.

Oracle: ``hand_written_paper.xml`` beside this file (the MJCF written by hand from Gambone Tables
1-2 that every result before vehicle files was flown with; a test fixture now, as
``rcsim/models/vehicle/paper.toml`` is the paper's vehicle) compiled by MuJoCo. Exact equality: the
vehicle file writes each number as the shortest text that reads back as the same double, so nothing
may differ.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

from rcsim.lookup.registry import make_controller
from rcsim.models.tables import load_dispersions, load_rate_cases
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.vehicle import build_model, load_vehicle
from rcsim.spacecraft.vehicle.model import route_mujoco_warnings

#: The hand-written MJCF of the paper's vehicle (a test fixture: module docstring).
HAND_WRITTEN_XML = Path(__file__).with_name("hand_written_paper.xml")


def hand_written_model() -> mujoco.MjModel:
    """The hand-written MJCF, compiled."""
    route_mujoco_warnings()
    return mujoco.MjModel.from_xml_path(str(HAND_WRITTEN_XML))


def test_every_model_array_equals_the_hand_written_one():
    hand, from_file = hand_written_model(), build_model(load_vehicle("paper"))
    differ = [
        name
        for name in dir(hand)
        if not name.startswith("_")
        and isinstance(getattr(hand, name), np.ndarray)
        and not np.array_equal(getattr(hand, name), getattr(from_file, name))
    ]
    assert differ == []
    assert hand.opt.disableflags == from_file.opt.disableflags
    assert hand.opt.timestep == from_file.opt.timestep
    assert hand.opt.integrator == from_file.opt.integrator


def test_dispersion_table_is_table_5():
    paper = load_vehicle("paper")
    table = load_dispersions()
    sig_file = DispersionSigmas.from_table(paper.dispersion_table())
    assert sig_file == DispersionSigmas.from_table(table)


def test_dispersed_lookup_flights_identical(paper, monkeypatch):
    """The paper's vehicle flown on the hand-written MJCF (what every earlier
    result flew) and on the model its file builds: the same flights bit for bit."""
    from rcsim.spacecraft.vehicle import vehicle as vehicle_module

    n = 26
    rate = np.asarray(load_rate_cases().rate_cmd, float)
    sig = DispersionSigmas.from_table(load_dispersions())
    key = paper.model_key
    out = []
    for model in (hand_written_model(), build_model(load_vehicle("paper"))):
        monkeypatch.setitem(vehicle_module._MODELS, key, model)  # the model the vehicle flies
        assert paper.model is model
        runs = draw_runs(paper.nominal(1), sig, 7, np.arange(n))
        out.append(
            simulate_batch(
                runs.params,
                make_controller("lookup", paper),
                Guidance.rate(rate),
                3.0,
                vehicle=paper,
                nthread=1,
            )
        )
    for key_ in ("q_BN", "omega_B", "on_time_s", "rate_err_B"):
        assert np.array_equal(getattr(out[0], key_), getattr(out[1], key_)), key_
    assert np.array_equal(out[0].propulsion.impulse_ns, out[1].propulsion.impulse_ns)


def test_paper_draws_keep_their_layout(paper):
    """The paper vehicle's runs must draw what they always drew (issue 18 sized every draw by
    the vehicle's jet count; results stay bit-identical only if 16 jets give the old layout).
    Oracle: the layout the modules document, rebuilt from the seed streams: dispersions 37
    normals (mass, CG x, Ixx, Iyy, Izz, 16 thrusts, 16 tilts) then 16 azimuth uniforms; valve
    timing 33 normals (command, 16 opening, 16 closing delays); a fault 4 uniforms (whether,
    which of the 16 jets, when, how).  Exact equality.  The moments (principal axes along B) are
    dispersed in place, without a frame; with products dispersed, the tensor diag(moments) plus
    the products of the mass-extras stream (5 normals: CG y, z, Ixy, Ixz, Iyz) is flown as its
    principal moments and frame: inertia in B (issue 18) leaves both as they were."""
    from rcsim.spacecraft.dispersions import mass_extra_stream, run_streams
    from rcsim.spacecraft.effect_draws import (
        FAULT,
        TIMING,
        FaultSpec,
        TimingSpec,
        draw_faults,
        draw_timing,
        effect_stream,
    )
    from rcsim.spacecraft.propellant import principal

    nominal = paper.nominal(1)
    sig = DispersionSigmas.from_table(load_dispersions())
    runs = draw_runs(nominal, sig, 18, [0, 7])
    assert runs.params.iquat is None
    products = replace(sig, products_kg_m2=(10.0, 15.0, 20.0))
    with_products = draw_runs(nominal, products, 18, [0, 7])
    timing = draw_timing(TimingSpec(open_delay_s=0.008, open_delay_sigma_s=0.001), 18, [0, 7], 16)
    spec = FaultSpec(mode="off", probability=0.5, time_s=(0.0, 3.0))
    faults, drawn = draw_faults(spec, 18, [0, 7], nominal.n_jets)
    for k, run in enumerate((0, 7)):
        rng = np.random.default_rng(run_streams(18, run)[0])
        z, u = rng.standard_normal(37), rng.random(16)
        assert runs.params.mass_kg[k] == nominal.mass_kg[0] + sig.mass_kg * z[0]
        moments = nominal.inertia_B[0] + np.asarray(sig.inertia_kg_m2) * z[2:5]
        np.testing.assert_array_equal(runs.params.inertia_B[k], moments)
        x = np.random.default_rng(mass_extra_stream(18, run)).standard_normal(5)
        tensor = np.diag(moments)
        for (a, b), s, xk in zip(((0, 1), (0, 2), (1, 2)), products.products_kg_m2, x[2:]):
            tensor[a, b] = tensor[b, a] = s * xk
        moments_p, frame_p = principal(tensor[None])
        np.testing.assert_array_equal(with_products.params.inertia_B[k], moments_p[0])
        np.testing.assert_array_equal(with_products.params.iquat[k], frame_p[0])
        np.testing.assert_array_equal(
            runs.params.thrust_n[k], nominal.thrust_n[0] + sig.thrust_n * z[5:21]
        )
        np.testing.assert_array_equal(runs.tilt_rad[k], sig.thruster_angle_rad * z[21:37])
        np.testing.assert_array_equal(runs.azimuth_rad[k], 2 * np.pi * u)
        zt = np.random.default_rng(effect_stream(18, run, TIMING)).standard_normal(33)
        np.testing.assert_array_equal(
            timing.open_delay_s[k], np.maximum(0.008 + 0.001 * zt[1:17], 0)
        )
        uf = np.random.default_rng(effect_stream(18, run, FAULT)).random(4)
        jet = int(uf[1] * 16) + 1 if uf[0] < 0.5 else 0
        assert drawn["fault_jet"][k] == jet
        if jet:
            assert faults.off_from_s[k, jet - 1] == 3.0 * uf[2]
