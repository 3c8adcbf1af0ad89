"""A validated vehicle file's contents: :class:`VehicleDef` and :class:`Jet`, the packaged
vehicles by name, and the plausible ranges the reader checks values against (why each bound is
what it is, beside it).  The reader is :mod:`rcsim.spacecraft.vehicle.file_schema`; the readers
of each section, :mod:`rcsim.spacecraft.vehicle.file_sections`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.models.errors import InputError
from rcsim.spacecraft.control_profile import ControlProfile
from rcsim.spacecraft.modes.reader import Modes
from rcsim.spacecraft.pulse_file import BlowdownSpec, PulseSpec
from rcsim.spacecraft.valves import ValveTiming
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2

#: Vehicle files packaged with rcsim, by name (``rcsim/models/vehicle/<name>.toml``).
PACKAGED_VEHICLES = ("paper", "canted16", "canted12", "service_module")
INTEGRATORS = ("RK4", "Euler", "implicit", "implicitfast")
#: A jet closer to the CG than this [m] has no moment arm worth the name (a jet "inside the CG").
MIN_ARM_M = 1e-3

# Plausible ranges (docs/vehicles.md, "Ranges"): values that parse but no real vehicle has,
# chosen so that a program's vehicle never meets them while a unit or decimal slip does.
#: Largest wet mass [kg]: over 20 times the ISS (about 4.2e5 kg); no spacecraft with reaction
#: control comes near it (a mass in grams of a vehicle above 10 t does).
MAX_MASS_KG = 1e7
#: Range of the radii of gyration ``sqrt(I/m)`` of the principal moments [m].  A 10 cm cube
#: has 4.1 cm, the paper's vehicle 0.84-1.01 m, the ISS about 20 m; an inertia in kg mm^2 (or
#: a mass in mg) moves it 1000x, out of the range.
GYRATION_RANGE_M = (5e-3, 200.0)
#: Farthest a jet or the tank may be from the CG, in radii of gyration (the largest principal
#: moment's).  A body's mass lies within its extent, so its radius of gyration is a fair share
#: of it (a solid sphere's is 0.63 of its radius, a rod's 0.58 of its half length); a point 20
#: times further out needs a light boom 20 times the body's size, or a position in mm.
MAX_REACH_GYRATIONS = 20.0
#: Largest thrust of one jet [N]: about 2.6 times the Space Shuttle's primary RCS jets (3,870 N),
#: the largest reaction-control jets flown; a thrust in mN (1000x) of a jet above 10 N is over.
MAX_THRUST_N = 1e4
#: Range of the specific impulse [s]: cold gas (xenon about 30 s, nitrogen about 70 s) to arcjets
#: (500-600 s), every chemical jet in between (hydrazine 220-235 s, bipropellant 280-320 s); an
#: exhaust velocity in m/s of a chemical jet (9.81x: 2,746 for 280 s) is over.
ISP_RANGE_S = (20.0, 1000.0)
#: Finest physics step [s]: 0.1 ms, ten times finer than the 1 ms reference of the convergence
#: study (docs/convergence.md: RK4 at 40 ms is converged); 400 steps a cycle already.
MIN_TIMESTEP_S = 1e-4
#: The valve-timing keys (seconds), named as :class:`rcsim.spacecraft.valves.ValveTiming` names
#: them: the per-jet valve latencies (``[jet_defaults]``, ``[[jet]]``) and the vehicle's
#: sensor-to-actuator delay (``[timing]``).
VALVE_DELAY_KEYS = ("open_delay_s", "close_delay_s")
DELAY_KEYS = ("command_delay_s", *VALVE_DELAY_KEYS)


@dataclass(frozen=True)
class Jet:
    """One jet (B frame, SI).

    ``direction`` is the unit force on the vehicle; ``direction_text`` is what the MJCF gets
    (the file's vector when it is already unit, so the packaged vehicle compiles to the same
    site frames bit for bit).  ``open_delay_s``, ``close_delay_s``: the valve's latency from
    a rising (falling) command edge to thrust on (off) [s] (0: none).
    """

    name: str
    position_m: tuple
    direction: tuple
    direction_text: tuple
    thrust_n: float
    open_delay_s: float = 0.0
    close_delay_s: float = 0.0


#: The keys of a vehicle file's ``[failure]``: a campaign's failure criterion for this vehicle
#: (final rate error [deg/s], final attitude error [deg]), as a campaign spec's ``[failure]``.
FAILURE_KEYS = ("rate_error_deg_s", "attitude_error_deg")
#: The failure threshold of a campaign whose spec and vehicle file give none [deg/s]: the
#: paper's (Gambone sec. III; the campaign's example spec says why), set for its vehicle.
PAPER_RATE_ERROR_DEG_S = 0.04


@dataclass(frozen=True)
class VehicleDef:
    """A validated vehicle file.

    Attributes
    ----------
    source : str
        The file (for messages and traceability).
    name : str
    mass_kg : float
        Wet mass at t = 0 [kg].
    cg_m : tuple of 3 floats
        CG in B [m].
    inertia_kg_m2 : ndarray, (3, 3)
        Full inertia tensor about the CG in B [kg m^2].
    jets : tuple of Jet
    control : ControlProfile
        The flight-software profile (``[control]``, the paper's values for keys it leaves out).
    min_on_s : float
        Shortest new pulse a valve makes [s] (0: none); the same for every jet.
    timestep_s, integrator
        MuJoCo physics step and integrator.
    isp_s : float
        Specific impulse [s].
    propellant_kg : float or None
        Usable propellant [kg] (None: accounted, never runs out).
    tank_position_m : tuple of 3 floats or None
        Where the propellant is (point mass) [m].
    three_sigma : dict
        Table 5 name -> 3-sigma in SI.
    command_delay_s : float
        Sensor-to-actuator delay [s] (``[timing]``; 0: none).
    delay_keys : tuple of str
        The valve-timing keys (:data:`DELAY_KEYS`) the file gives, anywhere (even as 0): the
        delays it states as its own, which a campaign spec may disperse but not restate
        (:mod:`rcsim.analysis.engine.campaign.effects`).
    failure : dict
        The vehicle's own failure criterion (``[failure]``): :data:`FAILURE_KEYS` it gives ->
        value (deg/s, deg), the defaults of a campaign of it (a spec's ``[failure]`` wins);
        empty: the paper's apply.
    modes : Modes or None
        ``[[slosh]]`` and ``[[appendage]]`` (:mod:`rcsim.spacecraft.modes`) and the hub they
        leave; None: a rigid vehicle.
    pulse : rcsim.spacecraft.pulse_file.PulseSpec or None
        ``[pulse]``: thrust rise and tail-off or an impulse-bit table (None: square pulses).
    blowdown : rcsim.spacecraft.pulse_file.BlowdownSpec or None
        ``[propellant.blowdown]`` (None: constant thrust and Isp).
    pulse_three_sigma : dict
        ``[dispersions]`` of the pulse and the tank pressure, key -> 3-sigma (SI;
        :mod:`rcsim.spacecraft.pulse_draws`); empty: not dispersed.
    """

    source: str
    name: str
    mass_kg: float
    cg_m: tuple
    inertia_kg_m2: np.ndarray
    jets: tuple
    control: ControlProfile
    timestep_s: float
    isp_s: float
    min_on_s: float = 0.0
    integrator: str = "RK4"
    hull_half_m: tuple | None = None
    hull_center_m: tuple | None = None
    propellant_kg: float | None = None
    tank_position_m: tuple | None = None
    three_sigma: dict = field(default_factory=dict)
    doc: str = ""
    command_delay_s: float = 0.0
    delay_keys: tuple = ()
    failure: dict = field(default_factory=dict)
    modes: Modes | None = None
    pulse: PulseSpec | None = None
    blowdown: BlowdownSpec | None = None
    pulse_three_sigma: dict = field(default_factory=dict)

    @property
    def n_jets(self) -> int:
        return len(self.jets)

    @property
    def jet_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.jets)

    def positions_m(self) -> np.ndarray:
        """Jet positions in B [m], (n_jets, 3)."""
        return np.array([j.position_m for j in self.jets], float)

    def directions(self) -> np.ndarray:
        """Unit force directions in B, (n_jets, 3)."""
        return np.array([j.direction for j in self.jets], float)

    def thrusts_n(self) -> np.ndarray:
        """Thrust of each jet [N], (n_jets,)."""
        return np.array([j.thrust_n for j in self.jets], float)

    def open_delays_s(self) -> np.ndarray:
        """Valve opening latency of each jet [s], (n_jets,)."""
        return np.array([j.open_delay_s for j in self.jets], float)

    def close_delays_s(self) -> np.ndarray:
        """Valve closing latency of each jet [s], (n_jets,)."""
        return np.array([j.close_delay_s for j in self.jets], float)

    @property
    def has_delays(self) -> bool:
        """Whether any delay is non-zero (else the vehicle flies as one without delays)."""
        return bool(
            self.command_delay_s or self.open_delays_s().any() or self.close_delays_s().any()
        )

    def delay_record(self) -> dict:
        """The nominal delays as JSON-able values [s]: ``command_delay_s`` and the per-jet
        ``open_delay_s``, ``close_delay_s`` lists (what manifests and metadata record)."""
        return {
            "command_delay_s": self.command_delay_s,
            "open_delay_s": self.open_delays_s().tolist(),
            "close_delay_s": self.close_delays_s().tolist(),
        }

    def valve_timing(self, n_runs: int = 1) -> ValveTiming:
        """The vehicle's nominal delays for ``n_runs`` runs, ``(n_runs, n_jets)`` per jet
        (zeros when the file gives none)."""
        return ValveTiming.of(
            n_runs,
            n_jets=self.n_jets,
            command_delay_s=self.command_delay_s,
            open_delay_s=self.open_delays_s(),
            close_delay_s=self.close_delays_s(),
        )

    def mass_flow_kg_s(self) -> np.ndarray:
        """Propellant mass flow of each jet firing [kg/s]: F / (Isp g0), (n_jets,)."""
        return self.thrusts_n() / (self.isp_s * G0_M_S2)

    def dispersion_table(self) -> pd.DataFrame:
        """The ``[dispersions]`` as a :func:`rcsim.models.tables.load_dispersions` frame (columns
        ``name``, ``three_sigma``, SI), for
        :meth:`rcsim.spacecraft.dispersions.DispersionSigmas.from_table`."""
        return pd.DataFrame(
            {"name": list(self.three_sigma), "three_sigma": list(self.three_sigma.values())}
        )


def packaged_vehicle(name: str) -> Path:
    """Path of a packaged vehicle file (``rcsim/models/vehicle/<name>.toml``)."""
    if name not in PACKAGED_VEHICLES:
        raise InputError(
            f"unknown packaged vehicle {name!r}; choose one of {', '.join(PACKAGED_VEHICLES)} "
            "or give a file path",
            parameter="vehicle",
            value=name,
        )
    return Path(str(files("rcsim.models") / "vehicle" / f"{name}.toml"))


def resolve_vehicle(value: str | os.PathLike) -> Path:
    """A packaged vehicle's name or a vehicle file's path, as a path.  A name that is also a
    file in the working directory is refused as ambiguous (write ``./name``)."""
    text = str(value)
    if text in PACKAGED_VEHICLES:
        if Path(text).exists():
            raise InputError(
                f"ambiguous: both the packaged vehicle {text!r} and the file {text}; write "
                f'"./{text}" for the file',
                parameter="vehicle",
                value=text,
            )
        return packaged_vehicle(text)
    return Path(text).expanduser()
