"""The vehicle file: keys, checks and the validated :class:`VehicleDef`.

Error rule (the campaign specs'): every mistake is one :class:`~rcsim.models.errors.InputError` line
``<file>: <key.path>: <problem> (got <value>)``; unknown keys are refused.

Conventions
-----------
* Body frame B as the packaged vehicle: x roll, y pitch, z yaw; origin at the structural
  reference point; SI units with the unit in the key name (``thrust_n``).
* ``[mass] inertia_kg_m2`` is about the CG in B: ``[ixx, iyy, izz]`` with optional
  ``products_kg_m2 = [ixy, ixz, iyz]``, or a full symmetric 3x3 list.  Products are the tensor
  entries ``I_xy = -sum(m x y)`` (MuJoCo's ``fullinertia`` convention).
* ``[[jet]] direction`` is the force on the vehicle, any non-zero vector (normalised on load).
* ``[propellant] mass_kg`` is the usable propellant, included in ``[mass] mass_kg`` (the wet
  vehicle at t = 0), a point mass at ``tank_position_m`` (default the CG); absent, the
  propellant is accounted but never runs out and the mass properties stay constant.
* ``[dispersions]`` is Table 5 in the campaign specs' ``three_sigma`` keys (3-sigma, normal).
* Valve timing (optional, seconds; the names of :class:`rcsim.spacecraft.valves.ValveTiming`
  and of a campaign's ``[dispersions.timing]``): ``open_delay_s`` and ``close_delay_s`` per jet (in
  ``[jet_defaults]``, overridden per ``[[jet]]``), the valve's latency from a rising (falling)
  command edge to thrust on (off); ``[timing] command_delay_s``, the sensor-to-actuator delay of
  the whole vehicle.  A pulse commanded over ``[t, t + u]`` thrusts over
  ``[t + command + open, t + command + u + close]``.  Absent: zero, and the vehicle flies exactly
  as a file without them.  They are the vehicle's nominal timing, flown by every flight of it.

Layout of the file: ``rcsim/models/vehicle/paper.toml`` (every key, commented).
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.models.errors import InputError
from rcsim.models.tables import CONTROL_CYCLE_S
from rcsim.models.toml_reader import Reader
from rcsim.spacecraft.dispersions import (
    INERTIA_ENTRIES,
    INERTIA_RULE,
    THREE_SIGMA_KEYS,
    inertia_scale_limit,
    largest_inertia_sigma,
    second_moment_slack,
    three_sigma_bounds,
)
from rcsim.spacecraft.valves import ValveTiming
from rcsim.spacecraft.vehicle import G0_M_S2

#: Vehicle files packaged with rcsim, by name (``rcsim/models/vehicle/<name>.toml``).
PACKAGED_VEHICLES = ("paper", "canted16", "canted12")
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
    """

    source: str
    name: str
    mass_kg: float
    cg_m: tuple
    inertia_kg_m2: np.ndarray
    jets: tuple
    min_on_s: float = 0.0
    timestep_s: float = CONTROL_CYCLE_S
    integrator: str = "RK4"
    hull_half_m: tuple | None = None
    hull_center_m: tuple | None = None
    isp_s: float = 280.0
    propellant_kg: float | None = None
    tank_position_m: tuple | None = None
    three_sigma: dict = field(default_factory=dict)
    doc: str = ""
    command_delay_s: float = 0.0
    delay_keys: tuple = ()

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

    def force_torque(self) -> np.ndarray:
        """Force [N] and torque about the CG [N m] of each jet at full thrust, (6, n_jets):
        rows Fx, Fy, Fz, Tx, Ty, Tz in B."""
        force = self.directions() * self.thrusts_n()[:, None]
        torque = np.cross(self.positions_m() - np.asarray(self.cg_m), force)
        return np.vstack([force.T, torque.T])

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


def _inertia(r: Reader) -> np.ndarray:
    value = r.raw("inertia_kg_m2", None)
    if value is None:
        raise r.error("inertia_kg_m2", "is required: [ixx, iyy, izz] or a 3x3 list")
    if isinstance(value, list) and len(value) == 3 and all(isinstance(v, list) for v in value):
        if r.has("products_kg_m2"):
            raise r.error("products_kg_m2", "not allowed with a full 3x3 inertia_kg_m2")
        ok = all(
            len(row) == 3
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row)
            for row in value
        )
        tensor = np.array(value, float) if ok else None
        if tensor is None or not np.isfinite(tensor).all():
            raise r.error("inertia_kg_m2", "must be 3 lists of 3 finite numbers", value)
        if not np.array_equal(tensor, tensor.T):
            raise r.error("inertia_kg_m2", "must be symmetric", value)
    else:
        r.table["inertia_kg_m2"] = value
        d = r.vector("inertia_kg_m2", 3)
        p = r.vector("products_kg_m2", 3, [0.0, 0.0, 0.0])
        tensor = np.array([[d[0], p[0], p[1]], [p[0], d[1], p[2]], [p[1], p[2], d[2]]])
    moments = np.linalg.eigvalsh(tensor)
    if moments.min() <= 0:
        raise r.error(
            "inertia_kg_m2",
            f"must be positive definite (principal moments {np.round(moments, 6).tolist()}): "
            "a singular or negative inertia is no rigid body",
            tensor.tolist(),
        )
    a, b, c = moments
    if a + b < c * (1 - 1e-12):  # every rigid body's principal moments obey it
        raise r.error(
            "inertia_kg_m2",
            f"principal moments violate the triangle inequality ({a:g} + {b:g} < {c:g}): "
            "no rigid body has them",
            tensor.tolist(),
        )
    return tensor


def _reach(r: Reader, name: str, what: str, point, cg: tuple, gyration_m: float) -> None:
    """Refuse a ``point`` farther from the CG than :data:`MAX_REACH_GYRATIONS` radii of
    gyration."""
    reach = MAX_REACH_GYRATIONS * gyration_m
    distance = float(np.linalg.norm(np.subtract(point, cg)))
    if distance > reach:
        raise r.error(
            name,
            f"{what} is {distance:.4g} m from the CG; it must be within {reach:.4g} m "
            f"({MAX_REACH_GYRATIONS:g} radii of gyration, sqrt(Imax/m) = {gyration_m:.4g} m): "
            "farther than any real vehicle's structure reaches: a position in mm? or mass.mass_kg "
            "or mass.inertia_kg_m2 in other units (sqrt(Imax/m) is computed from them: a mass in "
            "grams makes it 32 times small)",
            list(point),
        )


def _delay(r: Reader, name: str, default: float = 0.0) -> float:
    """A delay key [s]: finite, >= 0 and shorter than the control cycle."""
    value = r.number(name, default, minimum=0.0)
    if value >= CONTROL_CYCLE_S:
        raise r.error(
            name,
            f"must be shorter than the {CONTROL_CYCLE_S * 1e3:g} ms control cycle: a valve "
            "command must act within its cycle (a delay in ms?)",
            value,
        )
    return value


_JET_DEFAULT_KEYS = ("thrust_n", "min_on_s", *VALVE_DELAY_KEYS)


def _jets(top: Reader, cg: tuple, src: str, gyration_m: float) -> tuple[list[Jet], float]:
    defaults = top.table_("jet_defaults")
    shared = dict(defaults.table)
    for key in shared:
        if key not in _JET_DEFAULT_KEYS:
            raise InputError(
                f"{src}: unknown key 'jet_defaults.{key}' (jet_defaults takes "
                f"{', '.join(_JET_DEFAULT_KEYS)})"
            )
    for key in VALVE_DELAY_KEYS:  # checked here, so that a message names jet_defaults
        if key in shared:
            _delay(Reader(dict(shared), "jet_defaults", src), key)
    raw_jets = top.raw("jet", None)
    if not isinstance(raw_jets, list) or not raw_jets:
        raise top.error("jet", "at least one [[jet]] block is required", raw_jets)
    jets: list[Jet] = []
    seen: dict[str, int] = {}
    min_on: set[float] = set()
    for k, raw in enumerate(raw_jets):
        if not isinstance(raw, dict):
            raise top.error(f"jet[{k + 1}]", "must be a table", raw)
        r = Reader({**shared, **raw}, f"jet[{k + 1}]", src)
        name = r.raw("name", f"jet_{k + 1:02d}")
        if not isinstance(name, str) or not name.isidentifier():
            raise r.error("name", "must be an identifier (letters, digits, _)", name)
        if name in seen:
            raise r.error("name", f"duplicate (first in jet[{seen[name]}])", name)
        seen[name] = k + 1
        r.note = f" ({name})"  # every later message names the jet too: jet[9].position_m (fwd)
        pos = r.vector("position_m", 3)
        d = r.vector("direction", 3)
        norm = math.sqrt(sum(x * x for x in d))
        if norm < 1e-9:
            raise r.error("direction", "must be a non-zero vector", list(d))
        unit = tuple(x / norm for x in d)
        if not r.has("thrust_n"):
            raise r.error("thrust_n", "is required (here or in [jet_defaults])")
        thrust = r.number("thrust_n", None, minimum=0.0, strict=True)
        if thrust > MAX_THRUST_N:
            raise r.error(
                "thrust_n",
                f"must be at most {MAX_THRUST_N:g} N, over 2.5 times the largest "
                "reaction-control jets flown (Space Shuttle primary RCS, 3,870 N): a thrust "
                "in mN?",
                thrust,
            )
        min_on.add(r.number("min_on_s", 0.0, minimum=0.0))
        open_s, close_s = (_delay(r, key) for key in VALVE_DELAY_KEYS)
        r.done()
        if np.linalg.norm(np.subtract(pos, cg)) < MIN_ARM_M:
            raise r.error(
                "position_m",
                f"is at the CG {list(cg)} (closer than {MIN_ARM_M * 1e3:g} mm): a jet there "
                "has no moment arm",
                list(pos),
            )
        _reach(r, "position_m", "the jet", pos, cg, gyration_m)
        jets.append(Jet(name, pos, unit, d if norm == 1.0 else unit, thrust, open_s, close_s))
    if len(min_on) > 1:
        raise top.error(
            "jet",
            "min_on_s differs between jets; the valve model has one minimum on-time",
            sorted(min_on),
        )
    shortest = min_on.pop()
    if shortest >= CONTROL_CYCLE_S:
        raise top.error(
            "jet_defaults.min_on_s",
            f"must be shorter than the {CONTROL_CYCLE_S * 1e3:g} ms control cycle",
            shortest,
        )
    return jets, shortest


def _timing(t: Reader, jets: list[Jet], raw_jets: list, defaults: dict) -> tuple[float, tuple]:
    """``[timing] command_delay_s`` and the delay keys the file gives (:data:`DELAY_KEYS`,
    from the ``[jet_defaults]`` and ``[[jet]]`` tables as written); with each jet's valve
    latencies the command must still act within the cycle, as the simulator requires
    (``command + open < T``, ``command + close < T``)."""
    given = [key for key in VALVE_DELAY_KEYS if key in defaults or any(key in j for j in raw_jets)]
    for key in VALVE_DELAY_KEYS:
        if t.has(key):
            raise t.error(
                key,
                "valve latencies are per jet: give them in [jet_defaults] (every jet) or in a "
                "[[jet]] block; [timing] takes command_delay_s",
                t.raw(key),
            )
    if t.has("command_delay_s"):
        given.insert(0, "command_delay_s")
    command = _delay(t, "command_delay_s")
    t.done()
    for k, jet in enumerate(jets):
        for key in VALVE_DELAY_KEYS:
            own = key in raw_jets[k]
            total = command + getattr(jet, key)
            if total >= CONTROL_CYCLE_S:
                where = f"jet[{k + 1}].{key}" if own else f"jet_defaults.{key}"
                raise InputError(
                    f"{t.source}: {where}: plus timing.command_delay_s = {command:g} s is "
                    f"{total:.4g} s; it must be shorter than the {CONTROL_CYCLE_S * 1e3:g} ms "
                    f"control cycle: a valve command must act within its cycle "
                    f"(got {getattr(jet, key)!r})"
                )
    return command, tuple(given)


_UNITS = {"kg": "kg", "m": "m", "m2": "kg m^2", "n": "N", "deg": "deg"}


def _dispersions(ds: Reader, mass: float, inertia: np.ndarray, cg: tuple, jets: list) -> dict:
    """``[dispersions]``: dispersion name -> 3-sigma in SI, each below its bound (a 3-sigma
    draw must stay a vehicle: :func:`rcsim.spacecraft.dispersions.three_sigma_bounds`) and the
    inertia values together keeping the tensor a rigid body's
    (:func:`rcsim.spacecraft.dispersions.inertia_scale_limit`)."""
    three_sigma, given = {}, {}
    for key in list(ds.table):
        if key not in THREE_SIGMA_KEYS:
            raise ds.error(key, "unknown dispersion; known: " + ", ".join(THREE_SIGMA_KEYS))
        row, factor = THREE_SIGMA_KEYS[key]
        given[row] = (key, ds.number(key, None, minimum=0.0))
        three_sigma[row] = given[row][1] * factor
    ds.done()
    bounds = three_sigma_bounds(
        mass,
        np.diag(inertia),
        [j.thrust_n for j in jets],
        cg,
        [j.position_m for j in jets],
    )
    for row, (key, value) in given.items():
        if row in bounds and not three_sigma[row] < bounds[row][0]:
            bound, why = bounds[row]
            factor = THREE_SIGMA_KEYS[key][1]
            unit = _UNITS[key.rsplit("_", 1)[-1]]
            raise ds.error(
                key,
                f"must be below {bound / factor:.4g} {unit}, {why}: a 3-sigma draw must stay "
                "physical",
                value,
            )
    inertia_sigma = {n: v for n, v in three_sigma.items() if n in INERTIA_ENTRIES}
    if not inertia_scale_limit(inertia, inertia_sigma) > 1.0:
        # Named: the inertia value that weighs most, with the most it may be given the others.
        row = max(inertia_sigma, key=lambda n: INERTIA_ENTRIES[n] * inertia_sigma[n])
        most = largest_inertia_sigma(inertia, inertia_sigma, row)
        raise ds.error(
            given[row][0],
            INERTIA_RULE.format(slack=second_moment_slack(inertia)).replace(" times scale", "")
            + f"; with the other values it must be below {most:.4g} kg m^2",
            given[row][1],
        )
    return three_sigma


def load_vehicle(path: str | os.PathLike) -> VehicleDef:
    """Read and validate a vehicle file.

    Parameters
    ----------
    path : path or str
        A vehicle TOML file, or the name of a packaged one (:data:`PACKAGED_VEHICLES`).

    Raises
    ------
    InputError
        One line naming the file, the key and the value.
    """
    path = resolve_vehicle(path)
    src = str(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{src}: vehicle file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{src}: cannot read the vehicle file: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{src}: not valid TOML: {exc}") from None
    top = Reader(data, "", src)
    v = top.table_("vehicle")
    name = v.raw("name", path.stem)
    doc = v.raw("source", "")
    if not isinstance(name, str) or not isinstance(doc, str):
        raise v.error("name", "name and source must be strings", name)
    v.done()
    m = top.table_("mass")
    if not m.has("mass_kg"):
        raise m.error("mass_kg", "is required")
    mass = m.number("mass_kg", None, minimum=0.0, strict=True)
    if mass > MAX_MASS_KG:
        raise m.error(
            "mass_kg",
            f"must be at most {MAX_MASS_KG:g} kg, over 20 times the ISS: no spacecraft with "
            "reaction control is that heavy (a mass in grams?)",
            mass,
        )
    cg = m.vector("cg_m", 3)
    inertia = _inertia(m)
    gyration = np.sqrt(np.linalg.eigvalsh(inertia) / mass)
    lo, hi = GYRATION_RANGE_M
    if gyration.min() < lo or gyration.max() > hi:
        raise m.error(
            "inertia_kg_m2",
            f"does not fit mass_kg = {mass:g}: the radii of gyration sqrt(I/m) of its principal "
            f"moments are {np.round(gyration, 4).tolist()} m, outside {lo:g} to {hi:g} m (a 10 cm "
            "cube has 0.041 m, the ISS about 20 m; an inertia in kg mm^2 or g m^2, or a mass "
            "in another unit?)",
            inertia.tolist(),
        )
    m.done()
    ph = top.table_("physics")
    dt = ph.number("timestep_s", CONTROL_CYCLE_S, minimum=0.0, strict=True)
    n_sub = round(CONTROL_CYCLE_S / dt)
    if n_sub < 1 or abs(n_sub * dt - CONTROL_CYCLE_S) > 1e-9 * CONTROL_CYCLE_S:
        raise ph.error(
            "timestep_s", f"must divide the {CONTROL_CYCLE_S * 1e3:g} ms control cycle", dt
        )
    if dt < MIN_TIMESTEP_S:
        raise ph.error(
            "timestep_s",
            f"must be at least {MIN_TIMESTEP_S * 1e3:g} ms, ten times finer than the 1 ms "
            "reference of the convergence study (RK4 at 40 ms is converged): a finer step buys "
            f"nothing and costs {round(CONTROL_CYCLE_S / dt)} steps a cycle",
            dt,
        )
    integrator = ph.choice("integrator", "RK4", INTEGRATORS)
    ph.done()
    hull = top.table_("hull")
    hull_half = hull.vector("half_size_m", 3, required=False)
    hull_center = hull.vector("center_m", 3, list(cg) if hull_half else None, required=False)
    hull.done()
    reach_unit = float(gyration.max())  # the radius of gyration of the largest moment
    # The tables as written (``_jets`` validates them): which delay keys the file gives.
    raw_jets, raw_defaults = top.table.get("jet", []), top.table.get("jet_defaults", {})
    jets, min_on = _jets(top, cg, src, reach_unit)
    command_delay, delay_keys = _timing(top.table_("timing"), jets, raw_jets, raw_defaults)
    pr = top.table_("propellant")
    isp = pr.number("isp_s", 280.0, minimum=0.0, strict=True)
    lo, hi = ISP_RANGE_S
    if not lo <= isp <= hi:
        raise pr.error(
            "isp_s",
            f"must be within {lo:g} to {hi:g} s, cold gas to arcjets (an exhaust velocity in "
            "m/s, 9.81 times the Isp?)",
            isp,
        )
    prop = pr.number("mass_kg", None, minimum=0.0, strict=True) if pr.has("mass_kg") else None
    tank = pr.vector("tank_position_m", 3, list(cg) if prop is not None else None, required=False)
    if tank is not None and prop is None:
        raise pr.error("tank_position_m", "needs propellant.mass_kg", list(tank))
    if tank is not None:
        _reach(pr, "tank_position_m", "the tank", tank, cg, reach_unit)
    pr.done()
    if prop is not None and prop >= mass:
        raise InputError(
            f"{src}: propellant.mass_kg: must be below mass.mass_kg = {mass:g} (got {prop!r})"
        )
    three_sigma = _dispersions(top.table_("dispersions"), mass, inertia, cg, jets)
    top.done()
    return VehicleDef(
        source=src,
        name=name,
        mass_kg=mass,
        cg_m=cg,
        inertia_kg_m2=inertia,
        jets=tuple(jets),
        min_on_s=min_on,
        timestep_s=dt,
        integrator=integrator,
        hull_half_m=hull_half,
        hull_center_m=hull_center,
        isp_s=isp,
        propellant_kg=prop,
        tank_position_m=tank,
        three_sigma=three_sigma,
        doc=doc,
        command_delay_s=command_delay,
        delay_keys=delay_keys,
    )
