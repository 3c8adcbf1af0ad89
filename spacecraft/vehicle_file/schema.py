"""The vehicle file: keys, checks and the validated :class:`VehicleDef`.

Error rule (the campaign specs'): every mistake is one :class:`~models.errors.InputError` line
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

Layout of the file: ``models/vehicle/paper.toml`` (every key, commented).
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

from models.errors import InputError
from models.tables import CONTROL_CYCLE_S
from models.toml_reader import Reader
from spacecraft.dispersions import THREE_SIGMA_KEYS
from spacecraft.vehicle import G0_M_S2, N_JETS

#: Vehicle files packaged with rcsim, by name (``models/vehicle/<name>.toml``).
PACKAGED_VEHICLES = ("paper", "canted16")
INTEGRATORS = ("RK4", "Euler", "implicit", "implicitfast")
#: A jet closer to the CG than this [m] has no moment arm worth the name (a jet "inside the CG").
MIN_ARM_M = 1e-3


@dataclass(frozen=True)
class Jet:
    """One jet (B frame, SI).

    ``direction`` is the unit force on the vehicle; ``direction_text`` is what the MJCF gets
    (the file's vector when it is already unit, so the packaged vehicle compiles to the same
    site frames bit for bit).
    """

    name: str
    position_m: tuple
    direction: tuple
    direction_text: tuple
    thrust_n: float


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

    @property
    def n_jets(self) -> int:
        return len(self.jets)

    @property
    def jet_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.jets)

    def require_flyable(self) -> None:
        """Raise InputError unless the closed loop can fly this vehicle today: its jet
        arrays are 16 wide (:data:`spacecraft.vehicle.N_JETS`), so a vehicle file with another
        jet count is checked (``rcsim vehicle check``) but not flown."""
        if self.n_jets != N_JETS:
            raise InputError(
                f"{self.source}: jet: the simulation flies {N_JETS} jets; this vehicle has "
                f"{self.n_jets} (rcsim vehicle check analyses any count)"
            )

    def positions_m(self) -> np.ndarray:
        """Jet positions in B [m], (n_jets, 3)."""
        return np.array([j.position_m for j in self.jets], float)

    def directions(self) -> np.ndarray:
        """Unit force directions in B, (n_jets, 3)."""
        return np.array([j.direction for j in self.jets], float)

    def thrusts_n(self) -> np.ndarray:
        """Thrust of each jet [N], (n_jets,)."""
        return np.array([j.thrust_n for j in self.jets], float)

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
        """The ``[dispersions]`` as a :func:`models.tables.load_dispersions` frame (columns
        ``name``, ``three_sigma``, SI), for
        :meth:`spacecraft.dispersions.DispersionSigmas.from_table`."""
        return pd.DataFrame(
            {"name": list(self.three_sigma), "three_sigma": list(self.three_sigma.values())}
        )


def packaged_vehicle(name: str) -> Path:
    """Path of a packaged vehicle file (``models/vehicle/<name>.toml``)."""
    if name not in PACKAGED_VEHICLES:
        raise InputError(
            f"unknown packaged vehicle {name!r}; choose one of {', '.join(PACKAGED_VEHICLES)} "
            "or give a file path",
            parameter="vehicle",
            value=name,
        )
    return Path(str(files("models") / "vehicle" / f"{name}.toml"))


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


def _jets(top: Reader, cg: tuple, src: str) -> tuple[list[Jet], float]:
    defaults = top.table_("jet_defaults")
    shared = dict(defaults.table)
    for key in shared:
        if key not in ("thrust_n", "min_on_s"):
            raise InputError(
                f"{src}: unknown key 'jet_defaults.{key}' (jet_defaults takes thrust_n, min_on_s)"
            )
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
        pos = r.vector("position_m", 3)
        d = r.vector("direction", 3)
        norm = math.sqrt(sum(x * x for x in d))
        if norm < 1e-9:
            raise r.error("direction", "must be a non-zero vector", list(d))
        unit = tuple(x / norm for x in d)
        if not r.has("thrust_n"):
            raise r.error("thrust_n", "is required (here or in [jet_defaults])")
        thrust = r.number("thrust_n", None, minimum=0.0, strict=True)
        min_on.add(r.number("min_on_s", 0.0, minimum=0.0))
        r.done()
        if np.linalg.norm(np.subtract(pos, cg)) < MIN_ARM_M:
            raise r.error(
                "position_m",
                f"is at the CG {list(cg)} (closer than {MIN_ARM_M * 1e3:g} mm): a jet there "
                "has no moment arm",
                list(pos),
            )
        jets.append(Jet(name, pos, unit, d if norm == 1.0 else unit, thrust))
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
    cg = m.vector("cg_m", 3)
    inertia = _inertia(m)
    m.done()
    ph = top.table_("physics")
    dt = ph.number("timestep_s", CONTROL_CYCLE_S, minimum=0.0, strict=True)
    n_sub = round(CONTROL_CYCLE_S / dt)
    if n_sub < 1 or abs(n_sub * dt - CONTROL_CYCLE_S) > 1e-9 * CONTROL_CYCLE_S:
        raise ph.error(
            "timestep_s", f"must divide the {CONTROL_CYCLE_S * 1e3:g} ms control cycle", dt
        )
    integrator = ph.choice("integrator", "RK4", INTEGRATORS)
    ph.done()
    hull = top.table_("hull")
    hull_half = hull.vector("half_size_m", 3, required=False)
    hull_center = hull.vector("center_m", 3, list(cg) if hull_half else None, required=False)
    hull.done()
    jets, min_on = _jets(top, cg, src)
    pr = top.table_("propellant")
    isp = pr.number("isp_s", 280.0, minimum=0.0, strict=True)
    prop = pr.number("mass_kg", None, minimum=0.0, strict=True) if pr.has("mass_kg") else None
    tank = pr.vector("tank_position_m", 3, list(cg) if prop is not None else None, required=False)
    if tank is not None and prop is None:
        raise pr.error("tank_position_m", "needs propellant.mass_kg", list(tank))
    pr.done()
    if prop is not None and prop >= mass:
        raise InputError(
            f"{src}: propellant.mass_kg: must be below mass.mass_kg = {mass:g} (got {prop!r})"
        )
    ds = top.table_("dispersions")
    three_sigma = {}
    for key in list(ds.table):
        if key not in THREE_SIGMA_KEYS:
            raise ds.error(key, "unknown dispersion; known: " + ", ".join(THREE_SIGMA_KEYS))
        row, factor = THREE_SIGMA_KEYS[key]
        three_sigma[row] = ds.number(key, None, minimum=0.0) * factor
    ds.done()
    top.done()
    for row, nominal in (
        ("mass", mass),
        ("ixx", inertia[0, 0]),
        ("iyy", inertia[1, 1]),
        ("izz", inertia[2, 2]),
    ):
        if three_sigma.get(row, 0.0) >= nominal:
            raise InputError(
                f"{src}: dispersions: the 3-sigma of {row} ({three_sigma[row]:g}) must be below "
                f"its nominal {nominal:g}"
            )
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
    )
