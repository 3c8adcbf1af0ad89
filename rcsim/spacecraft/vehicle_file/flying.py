"""A vehicle file ready to fly: its compiled model, nominal parameters, valve limit and tank.

What the engine needs to fly a user's vehicle instead of the packaged one, in one place:

* :attr:`FlyingVehicle.model` -- the MuJoCo model
  (:func:`~rcsim.spacecraft.vehicle_file.build_model`);
* :meth:`FlyingVehicle.nominal` -- :class:`~rcsim.spacecraft.vehicle.VehicleParams` read back from
  that model, with the file's Isp (as many jets as the file has: :attr:`FlyingVehicle.n_jets`);
* :meth:`FlyingVehicle.propulsion` -- the valve limits (the file's minimum on-time);
* :meth:`FlyingVehicle.tank` -- the tracked propellant, or None when the file gives no
  propellant mass (then the mass properties stay constant, as for the packaged vehicle);
* :meth:`FlyingVehicle.timing` -- the file's nominal valve timing (command, opening and closing
  delays), or None when it has none (then the flight is exactly one without delays);
* :meth:`FlyingVehicle.flight_options` -- all three as the keywords of
  :func:`rcsim.spacecraft.simulation.simulate_batch` /
  :func:`rcsim.analysis.engine.flight.fly_batch`: the one way a flight of the vehicle outside
  a campaign gets them (a campaign combines the timing with its spec's ``[dispersions.timing]``,
  :mod:`rcsim.analysis.engine.campaign.effects`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace

import mujoco

from rcsim.spacecraft.propellant import PropellantTank
from rcsim.spacecraft.propulsion import PropulsionParams
from rcsim.spacecraft.valves import ValveTiming
from rcsim.spacecraft.vehicle import VehicleParams, jet_count
from rcsim.spacecraft.vehicle_file.mjcf import build_model
from rcsim.spacecraft.vehicle_file.schema import VehicleDef, load_vehicle


@dataclass(frozen=True)
class FlyingVehicle:
    """A validated vehicle file and its compiled model."""

    definition: VehicleDef
    model: mujoco.MjModel

    @classmethod
    def load(cls, path: str | os.PathLike) -> FlyingVehicle:
        """Read, validate and compile a vehicle file (or a packaged vehicle's name); any
        number of jets flies.

        Raises
        ------
        InputError
            The file is invalid.
        """
        definition = load_vehicle(path)
        return cls(definition, build_model(definition))

    @property
    def n_jets(self) -> int:
        """The vehicle's jet count, its model's (:func:`rcsim.spacecraft.vehicle.jet_count`)."""
        return jet_count(self.model)

    def nominal(self, n_runs: int = 1) -> VehicleParams:
        """The nominal vehicle ``n_runs`` times, with the file's Isp."""
        return replace(VehicleParams.nominal(n_runs, self.model), isp_s=self.definition.isp_s)

    def propulsion(self) -> PropulsionParams:
        """Valve limits: the file's minimum on-time (a new pulse shorter is not made)."""
        return PropulsionParams(min_pulse_s=self.definition.min_on_s)

    def tank(self, n_runs: int) -> PropellantTank | None:
        """The propellant tracked for ``n_runs`` runs, None when the file gives no mass."""
        d = self.definition
        if d.propellant_kg is None:
            return None
        return PropellantTank.of(n_runs, d.propellant_kg, d.tank_position_m)

    def timing(self, n_runs: int) -> ValveTiming | None:
        """The file's nominal valve timing for ``n_runs`` runs, None when every delay is zero
        (a flight without timing is then exactly the flight it always was)."""
        d = self.definition
        return d.valve_timing(n_runs) if d.has_delays else None

    def flight_options(self, n_runs: int) -> dict:
        """``propulsion``, ``tank`` and ``timing`` of ``n_runs`` flights of the vehicle: the
        keywords of :func:`~rcsim.spacecraft.simulation.simulate_batch` (None where the file gives
        no propellant mass or no delay)."""
        return {
            "propulsion": self.propulsion(),
            "tank": self.tank(n_runs),
            "timing": self.timing(n_runs),
        }
