"""Propellant use on a vehicle with modes: the stated rule (docs/vehicles.md, "Slosh and
appendages") is that the propellant used comes off the hub's point mass at the tank while the
slosh masses and panels stay as they are."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.propellant import PropellantTank
from rcsim.spacecraft.simulation import BatchSimulation
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2

EXAMPLE = Path("docs/examples/canted16_modes.toml")


class _Constant:
    """Fire the jets of ``on`` (n_runs, n_jets) bool for whole cycles, every cycle."""

    cycle_s = 0.04

    def __init__(self, on):
        self.on = np.asarray(on, bool)

    def initial_state(self, n_runs):
        return None

    def step(self, nav, state):
        return np.where(self.on, self.cycle_s, 0.0), None


def test_propellant_comes_off_the_hub_only():
    """jet_03 alone for 8 s: the hub loses F t / (Isp g0) (the rocket mass flow; 1e-9
    relative, per-cycle sums of 200 doubles), the modes' bodies keep their masses bit for
    bit, and the whole vehicle's mass is the file's less the propellant used."""
    vehicle = Vehicle.load(EXAMPLE)
    d = vehicle.definition
    on = np.zeros((1, vehicle.n_jets), bool)
    on[0, 2] = True
    params = vehicle.nominal(1)
    tank = PropellantTank.of(1, d.propellant_kg, d.tank_position_m)
    sim = BatchSimulation(params, vehicle=vehicle, nthread=1, tank=tank)
    history = sim.run(_Constant(on), Guidance.rate(np.zeros((1, 3))), 8.0)
    used = d.jets[2].thrust_n * 8.0 / (d.isp_s * G0_M_S2)
    assert history.propulsion.propellant_kg(d.isp_s)[0] == pytest.approx(used, rel=1e-9)
    masses = np.asarray(sim.physics.batch.expanded("body_mass"))[0]
    model = vehicle.model
    assert masses[1] == pytest.approx(model.body_mass[1] - used, rel=1e-9)
    np.testing.assert_array_equal(masses[2:], model.body_mass[2:])
    assert masses[1:].sum() == pytest.approx(d.mass_kg - used, rel=1e-12)
    assert not history.failed.any()
