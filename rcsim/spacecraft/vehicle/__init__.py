"""The vehicle: its file, the vehicle flown, each run's parameters, its MuJoCo model, its checks.

The vehicle flown
    * :mod:`~rcsim.spacecraft.vehicle.vehicle` -- :class:`Vehicle`, the vehicle flown, resolved
      once at the public edge (:meth:`Vehicle.load`: a packaged name, a file or None for the
      paper's): definition, cached model, jet geometry, Isp, valve limits, profile, tank,
      timing.  Everything below the edge takes a ``Vehicle``.
Reading the file
    * :mod:`~rcsim.spacecraft.vehicle.file_schema` -- the TOML file's keys, their checks, the
      packaged vehicles by name (``parse_vehicle``, ``load_vehicle``, ``resolve_vehicle``);
    * :mod:`~rcsim.spacecraft.vehicle.file_sections` -- the reader of each section;
    * :mod:`~rcsim.spacecraft.vehicle.definition` -- what a validated file holds:
      :class:`VehicleDef` and :class:`Jet` (mass, CG, full inertia, any number of jets with
      their valve delays, propellant, the Table 5-format dispersion table), the plausible
      ranges; the flight-software profile it carries is
      :class:`~rcsim.spacecraft.control_profile.ControlProfile`.
Each run's parameters
    * :mod:`~rcsim.spacecraft.vehicle.run_parameters` -- :class:`RunParameters`, the physical
      parameters of ``n_runs`` runs (mass, CG, inertia, thrust, jet directions, Isp), nominal
      or dispersed.
The MuJoCo model
    * :mod:`~rcsim.spacecraft.vehicle.mjcf` -- the MJCF text and compiled model of a
      definition (jets as site actuators named ``jet_01``...);
    * :mod:`~rcsim.spacecraft.vehicle.model` -- reading the model back: jet ids and count, jet
      geometry, :func:`~rcsim.spacecraft.vehicle.run_parameters.jet_force_torque_B` (the one
      computation of each jet's force and torque about the CG), MuJoCo's warning route.
The checks
    * :mod:`~rcsim.spacecraft.vehicle.sanity` -- physically odd but legal values, one line each;
    * :mod:`~rcsim.spacecraft.vehicle.axis_authority` -- authority about one axis (the LPs);
    * :mod:`~rcsim.spacecraft.vehicle.authority` -- what the jets can do: force/torque matrix,
      authority per axis and direction, unreachable directions, jet-out cases
      (``rcsim vehicle check``).

The paper's vehicle is the packaged example ``paper`` (``rcsim/models/vehicle/paper.toml``,
Gambone Tables 1-2); ``canted16`` is a four-quad layout with canted jets, ``canted12`` four
canted triads, and ``service_module`` the paper's vehicle with a tank's slosh and two solar
wings (arithmetic in ``rcsim/models/vehicle/README.md``).  Any jet count flies: every
per-jet array of the flight is as wide as the vehicle's model has jets
(:func:`rcsim.spacecraft.vehicle.model.jet_count`).

The names below load on first use: the modules of the flight (propulsion, propellant,
dispersions...) import :mod:`~rcsim.spacecraft.vehicle.model` and
:mod:`~rcsim.spacecraft.vehicle.run_parameters`, which :class:`Vehicle` itself builds on.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle.definition import Jet, VehicleDef
    from rcsim.spacecraft.vehicle.file_schema import (
        PACKAGED_VEHICLES,
        load_vehicle,
        resolve_vehicle,
    )
    from rcsim.spacecraft.vehicle.mjcf import build_model, to_mjcf
    from rcsim.spacecraft.vehicle.run_parameters import RunParameters
    from rcsim.spacecraft.vehicle.vehicle import DEFAULT_VEHICLE, Vehicle

#: Public name -> the module that defines it.
_NAMES = {
    "DEFAULT_VEHICLE": "vehicle",
    "Vehicle": "vehicle",
    "PACKAGED_VEHICLES": "file_schema",
    "load_vehicle": "file_schema",
    "resolve_vehicle": "file_schema",
    "Jet": "definition",
    "VehicleDef": "definition",
    "RunParameters": "run_parameters",
    "build_model": "mjcf",
    "to_mjcf": "mjcf",
}
__all__ = [
    "DEFAULT_VEHICLE",
    "PACKAGED_VEHICLES",
    "Jet",
    "RunParameters",
    "Vehicle",
    "VehicleDef",
    "build_model",
    "load_vehicle",
    "resolve_vehicle",
    "to_mjcf",
]


def __getattr__(name: str):
    if name not in _NAMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
    globals()[name] = value  # later lookups skip __getattr__
    return value
