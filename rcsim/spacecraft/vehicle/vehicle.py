"""The vehicle flown: one immutable :class:`Vehicle`, resolved once at the edge.

A :class:`Vehicle` is a validated vehicle file (a packaged name or a path) with everything the
rest of rcsim asks of a vehicle, in one place -- the equivalent of dm_control's ``Physics``,
built once and handed to the task:

* its definition (:class:`~rcsim.spacecraft.vehicle.file_schema.VehicleDef`): mass properties,
  jets, valve timing, propellant, dispersions, and the flight-software profile
  (:attr:`Vehicle.control`, the file's ``[control]``);
* its compiled MuJoCo model (:attr:`Vehicle.model`), cached per process by its MJCF's SHA-256,
  so a vehicle pickles small (a campaign spec goes to Dask workers as
  text and numbers) and a process compiles it once however many chunks it flies;
* what the jets do, from geometry, for every vehicle the paper's included: the force/torque
  matrix and each jet's torque signs about roll, pitch, yaw (:attr:`Vehicle.axis_signs`,
  equal to Table 2 for the paper's vehicle: ``tests/spacecraft/vehicle/test_vehicle.py``);
* Isp, minimum on-time, valve limits on the profile's cycle (:meth:`Vehicle.propulsion`), the
  nominal parameters of ``n`` runs, the tank and the valve timing of a flight.

Callers take ``Vehicle | str | PathLike | None`` at the public edge and resolve it once with
:meth:`Vehicle.load` (None is the paper's vehicle, ``paper``); everything below takes a
``Vehicle``.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

from rcsim.models.errors import InputError
from rcsim.spacecraft.blowdown import Blowdown
from rcsim.spacecraft.control_profile import ControlProfile
from rcsim.spacecraft.propellant import PropellantTank
from rcsim.spacecraft.propulsion import PropulsionParams
from rcsim.spacecraft.pulse_draws import PulseSigmas
from rcsim.spacecraft.pulse_shape import PulseShape
from rcsim.spacecraft.valves import ValveTiming
from rcsim.spacecraft.vehicle.file_schema import (
    INTEGRATORS,
    PACKAGED_VEHICLES,
    VehicleDef,
    parse_vehicle,
    read_vehicle_bytes,
    resolve_vehicle,
)
from rcsim.spacecraft.vehicle.mjcf import build_model, to_mjcf
from rcsim.spacecraft.vehicle.model import jet_count
from rcsim.spacecraft.vehicle.run_parameters import RunParameters, jet_force_torque_B

#: The vehicle flown when none is named: the paper's (``rcsim/models/vehicle/paper.toml``).
DEFAULT_VEHICLE = "paper"

#: Compiled models of this process by the SHA-256 of their MJCF (:attr:`Vehicle.model_key`;
#: ``KEY/flight`` for the wrench model built from it).
_MODELS: dict[str, mujoco.MjModel] = {}
#: How many models this process compiled, vehicle and flight (wrench) models alike (what the
#: per-chunk "vehicle loads" count reads).
MODEL_BUILDS = {"count": 0}


@dataclass(frozen=True, eq=False)
class Vehicle:
    """A resolved vehicle (module docstring).  Build it with :meth:`load`.

    Attributes
    ----------
    definition : VehicleDef
        The validated file (and the ``[control]`` overrides it was loaded with).
    ref : str
        How a spec or manifest names it: a packaged vehicle's name, or the file's absolute path.
    sha256 : str
        SHA-256 of the file's bytes (a resume or replay refuses a changed file).
    text : str
        The file's text as read (re-validated, never re-read, under new ``[control]`` values).
    overrides : tuple of (str, float)
        ``[control]`` overrides applied on top of the file's, and where they came from
        (:attr:`overrides_from`).
    model_key : str
        SHA-256 of the MJCF the definition compiles to: the model cache's key (a definition
        edited in code, :meth:`edited`, compiles to its own model).
    """

    definition: VehicleDef
    ref: str
    sha256: str
    text: str = field(repr=False)
    overrides: tuple = ()
    overrides_from: str = ""
    model_key: str = ""

    def __post_init__(self) -> None:
        if not self.model_key:
            mjcf = to_mjcf(self.definition).encode("utf-8")
            object.__setattr__(self, "model_key", hashlib.sha256(mjcf).hexdigest())

    # ------------------------------------------------------------------------ resolving --
    @classmethod
    def load(
        cls,
        value: Vehicle | str | os.PathLike | None = None,
        *,
        control: dict | None = None,
        control_from: str = "",
    ) -> Vehicle:
        """Resolve ``value`` once: a :class:`Vehicle` (returned as is), a packaged vehicle's
        name, a vehicle file's path, or None (:data:`DEFAULT_VEHICLE`); ``control``
        overrides its ``[control]`` keys (``control_from`` says where they came from).

        Raises
        ------
        InputError
            The file is missing or invalid, or an override breaks a check: one line naming the
            file (or the overrides' origin), the key and the value.
        """
        if isinstance(value, Vehicle):
            return value.with_control(control, control_from) if control else value
        text_value = DEFAULT_VEHICLE if value is None else str(value)
        path = resolve_vehicle(text_value)
        raw = read_vehicle_bytes(path)
        text = raw.decode("utf-8")  # read_vehicle_bytes checked it decodes
        definition = parse_vehicle(text, path, control, control_from=control_from)
        ref = text_value if text_value in PACKAGED_VEHICLES else str(path.resolve())
        return cls(
            definition=definition,
            ref=ref,
            sha256=hashlib.sha256(raw).hexdigest(),
            text=text,
            overrides=tuple(sorted((control or {}).items())),
            overrides_from=control_from,
        )

    def with_control(self, control: dict | None, control_from: str) -> Vehicle:
        """The same vehicle with ``[control]`` keys overridden (on top of earlier overrides),
        every check that depends on the cycle made again."""
        if not control:
            return self
        merged = {**dict(self.overrides), **control}
        where = control_from if not self.overrides else f"{self.overrides_from}; {control_from}"
        path = Path(self.definition.source)
        definition = parse_vehicle(self.text, path, merged, control_from=where)
        return replace(
            self,
            definition=definition,
            overrides=tuple(sorted(merged.items())),
            overrides_from=where,
            model_key="",
        )

    def edited(self, definition: VehicleDef, what: str) -> Vehicle:
        """The vehicle with its definition edited in code (a study: jets with valve delays,
        dispersions removed), no longer its file: named ``<ref> (what)``, its model compiled
        from the new definition."""
        digest = hashlib.sha256(f"{self.sha256}:{what}:{definition!r}".encode()).hexdigest()
        return replace(
            self, definition=definition, ref=f"{self.ref} ({what})", sha256=digest, model_key=""
        )

    def with_physics(self, *, timestep_s: float | None = None, integrator: str | None = None):
        """The same vehicle integrated with another physics step or integrator (convergence
        studies); the step must still divide the control cycle."""
        dt = self.definition.timestep_s if timestep_s is None else float(timestep_s)
        cycle = self.control.cycle_s
        n_sub = round(cycle / dt) if dt > 0 else 0
        if n_sub < 1 or abs(n_sub * dt - cycle) > 1e-9 * cycle:
            raise InputError(
                f"physics step {dt} s does not divide the {cycle * 1e3:g} ms control cycle",
                parameter="timestep_s",
                value=dt,
            )
        if integrator is not None and integrator not in INTEGRATORS:
            raise InputError(
                f"unknown integrator {integrator!r}; choose one of {', '.join(INTEGRATORS)}",
                parameter="integrator",
                value=integrator,
            )
        new = replace(
            self.definition,
            timestep_s=dt,
            integrator=self.definition.integrator if integrator is None else integrator,
        )
        return replace(self, definition=new, model_key="")

    # ----------------------------------------------------------------------- the model --
    @property
    def model(self) -> mujoco.MjModel:
        """The compiled MuJoCo model, compiled once per process (cached by its MJCF's SHA-256,
        :attr:`model_key`).  Callers must not change it: copy it to modify."""
        model = _MODELS.get(self.model_key)
        if model is None:
            model = build_model(self.definition)
            MODEL_BUILDS["count"] += 1
            _MODELS[self.model_key] = model
        return model

    @property
    def flight_model(self) -> mujoco.MjModel:
        """The wrench model the batched flight integrates
        (:func:`rcsim.spacecraft.flight_model.flight_model` of :attr:`model`), built once per
        process beside it: a flight's :class:`mujoco.batch.Batch` simulates copies of it, so
        every chunk of a campaign shares it.  Callers must not change it."""
        key = f"{self.model_key}/flight"
        flight = _MODELS.get(key)
        if flight is None:
            from rcsim.spacecraft.flight_model import flight_model

            flight = flight_model(self.model)
            MODEL_BUILDS["count"] += 1
            _MODELS[key] = flight
        return flight

    # ------------------------------------------------------------------- what it is --
    @property
    def control(self) -> ControlProfile:
        """The flight-software profile flown (the file's ``[control]`` and any overrides)."""
        return self.definition.control

    @property
    def name(self) -> str:
        """The vehicle's own name (``[vehicle] name``)."""
        return self.definition.name

    @property
    def source(self) -> str:
        """The file it was read from."""
        return self.definition.source

    @property
    def label(self) -> str:
        """How a message names it, as the user named it: a packaged vehicle's name, or the
        file's path as given."""
        return self.ref if self.ref in PACKAGED_VEHICLES else self.source

    def warnings(self) -> list[str]:
        """Physically odd but legal values of the file, one line each
        (:func:`rcsim.spacecraft.vehicle.sanity.sanity_warnings`; six small LPs, solved
        once per vehicle)."""
        if "_warnings" not in self.__dict__:  # frozen: cached beside the fields, as the model
            from rcsim.spacecraft.vehicle.sanity import sanity_warnings

            self.__dict__["_warnings"] = sanity_warnings(self.definition)
        return list(self.__dict__["_warnings"])

    def axis_torque_n_m(self) -> np.ndarray:
        """Largest torque the jets give about each body axis, (3,) [N m]: all jets of one
        sign on the axis firing at nominal thrust, the smaller of the two senses.  What a
        disturbance torque is checked against (a hold's beyond it cannot be held)."""
        torque = self.force_torque()[3:].T  # (n_jets, 3)
        return np.minimum(
            np.where(torque > 0, torque, 0).sum(axis=0),
            -np.where(torque < 0, torque, 0).sum(axis=0),
        )

    def disturbance_problem(self, disturbance_n_m) -> str:
        """Why a constant disturbance torque ``disturbance_n_m`` (3,) [N m, body axes] cannot
        be flown on this vehicle, or '' when it can: a component beyond the jets' largest
        torque about its axis (:meth:`axis_torque_n_m`), against which no controller can hold
        attitude.  The one rule a campaign spec, ``rcsim scenario run`` and :func:`rcsim.fly`
        apply."""
        dist = np.asarray(disturbance_n_m, float)
        torque = self.axis_torque_n_m()
        if not (np.abs(dist) > torque).any():
            return ""
        return (
            "each component must be within the jets' largest torque about that axis, +-["
            f"{', '.join(f'{t:.4g}' for t in torque)}] N m ({self.label}'s nominal vehicle, all "
            "jets of one sign firing): beyond it no controller can hold attitude"
        )

    @property
    def n_jets(self) -> int:
        """The vehicle's jet count (its model's,
        :func:`rcsim.spacecraft.vehicle.model.jet_count`)."""
        return jet_count(self.model)

    @property
    def jet_names(self) -> tuple[str, ...]:
        return self.definition.jet_names

    @property
    def isp_s(self) -> float:
        """Specific impulse [s] (the file's ``[propellant] isp_s``)."""
        return self.definition.isp_s

    @property
    def min_on_s(self) -> float:
        """Shortest new pulse the valves make [s] (0: none)."""
        return self.definition.min_on_s

    def force_torque(self) -> np.ndarray:
        """Force [N] and torque about the nominal CG [N m] of each jet at full thrust,
        (6, n_jets): rows Fx, Fy, Fz, Tx, Ty, Tz in B (:func:`jet_force_torque_B` of the
        nominal run on :attr:`model`: the numbers the controllers are designed with)."""
        force, torque = jet_force_torque_B(self.nominal(1), self.model)
        return np.vstack([force[0].T, torque[0].T])

    @property
    def axis_signs(self) -> np.ndarray:
        """Sign of each jet's torque about roll, pitch, yaw, (n_jets, 3) in {-1, 0, 1}, from
        geometry (a component below 1e-9 of the largest is zero): the vehicle's own Table 2."""
        torque = self.force_torque()[3:].T
        big = np.abs(torque) > 1e-9 * np.abs(torque).max()
        return np.where(big, np.sign(torque), 0).astype(int)

    # ---------------------------------------------------------------- what a flight needs --
    def propulsion(self) -> PropulsionParams:
        """Valve limits: the profile's control cycle and the file's minimum on-time."""
        return PropulsionParams(cycle_s=self.control.cycle_s, min_pulse_s=self.min_on_s)

    def nominal(self, n_runs: int = 1) -> RunParameters:
        """The nominal vehicle ``n_runs`` times, with the file's Isp."""
        return RunParameters.nominal(n_runs, self.model, isp_s=self.isp_s)

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

    def pulse_shape(self, n_runs: int) -> PulseShape | None:
        """The file's ``[pulse]`` for ``n_runs`` runs (:mod:`rcsim.spacecraft.pulse_shape`),
        None without one (square pulses, the flight exactly as before)."""
        spec = self.definition.pulse
        return None if spec is None else spec.shape(n_runs, self.isp_s)

    def blowdown(self, n_runs: int) -> Blowdown | None:
        """The file's ``[propellant.blowdown]`` for ``n_runs`` runs
        (:mod:`rcsim.spacecraft.blowdown`), None without one."""
        spec = self.definition.blowdown
        return None if spec is None else spec.blowdown(n_runs)

    def pulse_sigmas(self) -> PulseSigmas:
        """The file's ``[dispersions]`` of the pulse and the tank pressure (one-sigma)."""
        return PulseSigmas.from_three_sigma(self.definition.pulse_three_sigma)

    # ---------------------------------------------------------------------- traceability --
    def record(self) -> dict:
        """What a manifest or report says of the vehicle: its reference, name, SHA-256 and
        the profile that flew."""
        return {
            "vehicle": self.ref,
            "vehicle_name": self.name,
            "vehicle_sha256": self.sha256,
            "control": self.control.record(),
        }
