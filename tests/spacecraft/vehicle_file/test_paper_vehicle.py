"""The paper's vehicle through the vehicle file format is the packaged vehicle, bit for bit.

Oracle: ``models/vehicle/vehicle.xml`` compiled by MuJoCo (the model every earlier result
was flown with).  Exact equality: the vehicle file writes each number as the shortest text
that reads back as the same double, so nothing may differ.
"""

from __future__ import annotations

import numpy as np

from lookup.registry import make_controller
from models.tables import load_dispersions, load_rate_cases
from spacecraft.dispersions import DispersionSigmas, draw_runs
from spacecraft.navigation import Guidance
from spacecraft.simulation import simulate_batch
from spacecraft.vehicle import VehicleParams, load_model
from spacecraft.vehicle_file import build_model, load_vehicle


def test_every_model_array_equals_the_packaged_one():
    packaged, from_file = load_model(), build_model(load_vehicle("paper"))
    differ = [
        name
        for name in dir(packaged)
        if not name.startswith("_")
        and isinstance(getattr(packaged, name), np.ndarray)
        and not np.array_equal(getattr(packaged, name), getattr(from_file, name))
    ]
    assert differ == []
    assert packaged.opt.disableflags == from_file.opt.disableflags
    assert packaged.opt.timestep == from_file.opt.timestep
    assert packaged.opt.integrator == from_file.opt.integrator


def test_dispersion_table_is_table_5():
    paper = load_vehicle("paper")
    table = load_dispersions()
    sig_file = DispersionSigmas.from_table(paper.dispersion_table())
    assert sig_file == DispersionSigmas.from_table(table)


def test_dispersed_lookup_flights_identical():
    n = 26
    rate = np.asarray(load_rate_cases().rate_cmd, float)
    sig = DispersionSigmas.from_table(load_dispersions())
    out = []
    for model in (load_model(), build_model(load_vehicle("paper"))):
        runs = draw_runs(VehicleParams.nominal(1, model), sig, 7, np.arange(n))
        out.append(
            simulate_batch(
                runs.params,
                make_controller("lookup"),
                Guidance.rate(rate),
                3.0,
                model=model,
                nthread=1,
            )
        )
    for key in ("q_BN", "omega_B", "on_time_s", "rate_err_B"):
        assert np.array_equal(getattr(out[0], key), getattr(out[1], key)), key
    assert np.array_equal(out[0].propulsion.impulse_ns, out[1].propulsion.impulse_ns)
