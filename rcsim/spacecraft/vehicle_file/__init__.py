"""A vehicle a user writes: a TOML vehicle file, validated, and the MuJoCo model built from it.

* :mod:`~rcsim.spacecraft.vehicle_file.schema` -- the file's keys, their checks and the validated
  :class:`~rcsim.spacecraft.vehicle_file.schema.VehicleDef` (mass, CG, full inertia, any number of
  jets with their valve delays, propellant, the Table 5-format dispersion table);
* :mod:`~rcsim.spacecraft.vehicle_file.mjcf` -- the vehicle's MJCF text and compiled model, with the
  packaged vehicle's structure (jets as site actuators named ``jet_01``...);
* :mod:`~rcsim.spacecraft.control_profile` -- the flight-software profile (``[control]``:
  cycle, maneuver rate and limit, deadbands, hold time) as data;
* :mod:`~rcsim.spacecraft.vehicle_file.vehicle` -- :class:`Vehicle`, the vehicle flown, resolved
  once (definition, cached model, jet geometry, Isp, valve limits, profile, tank, timing);
* :mod:`~rcsim.spacecraft.vehicle_file.authority` -- what the jets can do: force/torque matrix,
  authority per axis and direction, unreachable directions, jet-out cases
  (``rcsim vehicle check``).

The paper's vehicle is the packaged example ``paper`` (``rcsim/models/vehicle/paper.toml``: it
builds a model that flies bit-identically to ``rcsim/models/vehicle/vehicle.xml``); ``canted16`` is
a four-quad layout with canted jets and ``canted12`` four canted triads (arithmetic in
``rcsim/models/vehicle/README.md``).  Any jet count flies: every per-jet array of the flight is as
wide as the vehicle's model has jets (:func:`rcsim.spacecraft.vehicle.jet_count`).
"""

from rcsim.spacecraft.control_profile import ControlProfile
from rcsim.spacecraft.vehicle_file.mjcf import build_model, to_mjcf
from rcsim.spacecraft.vehicle_file.schema import (
    PACKAGED_VEHICLES,
    Jet,
    VehicleDef,
    load_vehicle,
    resolve_vehicle,
)
from rcsim.spacecraft.vehicle_file.vehicle import DEFAULT_VEHICLE, Vehicle

__all__ = [
    "DEFAULT_VEHICLE",
    "PACKAGED_VEHICLES",
    "ControlProfile",
    "Vehicle",
    "Jet",
    "VehicleDef",
    "build_model",
    "load_vehicle",
    "resolve_vehicle",
    "to_mjcf",
]
