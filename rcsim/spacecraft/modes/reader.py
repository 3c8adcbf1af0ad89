"""Reading a vehicle file's ``[[slosh]]`` and ``[[appendage]]`` blocks, every value checked
(one-line errors naming the file, the key and the value; ranges in ``docs/vehicles.md``, "Slosh
and appendages").  The vehicle file's reader calls :func:`read_modes` with its own checked
``[mass]`` and ``[physics]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcsim.models.errors import InputError
from rcsim.models.toml_reader import Reader
from rcsim.spacecraft.modes.definition import (
    SLOSH_MODELS,
    Appendage,
    ModeSigmas,
    SloshMode,
    hub_mass_properties,
    hub_problem,
)

#: Lowest mode frequency [Hz]: a period of 1,000 s, longer than any maneuver or hold rcsim
#: flies; below it the "mode" is a free drift (a frequency of 0, or one in mHz written as Hz?).
MIN_FREQUENCY_HZ = 1e-3
#: Fewest physics steps in one clamped period.  RK4 is unstable beyond omega dt = 2.83 (0.45
#: periods a step) and loses phase well before; 10 steps a period keeps omega dt at 0.63.  The
#: coupled frequency is higher than the clamped one (the hub moves against the mode), which
#: the check of the coupled frequency (``rcsim vehicle check``) shows.
MIN_STEPS_PER_PERIOD = 10
#: Fewest steps a period before a warning (20: the phase error of RK4 per period stays below
#: 1e-4 rad).
WARN_STEPS_PER_PERIOD = 20
#: Farthest a mode may be from the CG, in radii of gyration of the whole vehicle's largest
#: principal moment (as a jet or the tank: ``docs/vehicles.md``, "Ranges").
MAX_REACH_GYRATIONS = 20.0
#: Two slide directions of one tank must be normal to each other to this |cos| (two lateral
#: modes; a pair at an angle would couple through the mass matrix of one point).
ORTHOGONAL_COS = 1e-6


@dataclass(frozen=True)
class Modes:
    """A file's modes and what they make of the hub.

    Attributes
    ----------
    slosh : tuple of SloshMode
    appendages : tuple of Appendage
    hub_mass_kg : float
    hub_cg_m : ndarray (3,)
    hub_inertia_kg_m2 : ndarray (3, 3)
        About the hub's CG, B axes.
    sigmas : tuple of ModeSigmas
        Each mode's dispersions, in the order of :attr:`all` (empty: none dispersed).
    """

    slosh: tuple
    appendages: tuple
    hub_mass_kg: float
    hub_cg_m: np.ndarray
    hub_inertia_kg_m2: np.ndarray
    sigmas: tuple = ()

    @property
    def all(self) -> tuple:
        return (*self.slosh, *self.appendages)

    @property
    def dispersed(self) -> bool:
        """Some mode has a dispersion: its runs fly drawn values
        (:mod:`rcsim.spacecraft.modes.draws`)."""
        return any(s.disperses() for s in self.sigmas)


def _unit(r: Reader, name: str, value: tuple) -> tuple:
    norm = math.sqrt(sum(x * x for x in value))
    if norm < 1e-9:
        raise r.error(name, "must be a non-zero vector", list(value))
    return tuple(x / norm for x in value)


def _frequency(r: Reader, timestep_s: float) -> float:
    f = r.number("frequency_hz", None, minimum=0.0, strict=True)
    if f < MIN_FREQUENCY_HZ:
        raise r.error(
            "frequency_hz",
            f"must be at least {MIN_FREQUENCY_HZ:g} Hz (a period of {1 / MIN_FREQUENCY_HZ:g} s, "
            "longer than any flight): a frequency in mHz?",
            f,
        )
    top = 1.0 / (MIN_STEPS_PER_PERIOD * timestep_s)
    if f > top:
        raise r.error(
            "frequency_hz",
            f"must be at most {top:.4g} Hz, {MIN_STEPS_PER_PERIOD} physics steps of "
            f"{timestep_s * 1e3:g} ms a period (RK4 loses the mode beyond it; a smaller "
            "physics.timestep_s flies it, or a frequency in rad/s written as Hz?)",
            f,
        )
    return f


def _damping_ratio(r: Reader) -> float:
    z = r.number("damping_ratio", None, minimum=0.0)
    if z >= 1.0:
        raise r.error(
            "damping_ratio",
            "must be below 1: critically damped or more is no oscillating mode (a ratio in "
            "percent? 0.5 % is 0.005)",
            z,
        )
    return z


def _three_sigma(
    r: Reader, key: str, nominal: float, floor: float, ceiling: float | None, unit: str
) -> float:
    """``<key>_3sigma`` of a block (0 when absent): at least 0, and ``nominal -+ 3-sigma``
    within ``[floor, ceiling]`` (a 3-sigma draw stays a mode rcsim flies; module ranges)."""
    name = f"{key}_3sigma"
    s = r.number(name, 0.0, minimum=0.0)
    if s and nominal - s < floor:
        raise r.error(
            name,
            f"takes {key} from {nominal:g}{unit} to {nominal - s:g}{unit} at -3 sigma, below "
            f"{floor:g}{unit}: a 3-sigma draw must stay a mode (the 3-sigma must be less than "
            f"{nominal - floor:.4g}{unit})",
            s,
        )
    if s and ceiling is not None and nominal + s > ceiling:
        raise r.error(
            name,
            f"takes {key} from {nominal:g}{unit} to {nominal + s:g}{unit} at +3 sigma, above "
            f"{ceiling:.4g}{unit}, the limit of {key} itself",
            s,
        )
    return s


def _sigmas(
    r: Reader, *, mass: float | None, f: float | None, zeta: float | None, timestep_s: float
) -> ModeSigmas:
    """A block's dispersions (``docs/vehicles.md``, "Dispersions of the modes"): 3-sigma,
    absolute; the mass must stay above 0, the frequency between :data:`MIN_FREQUENCY_HZ` and
    the step limit, the damping ratio in [0, 1) at 3 sigma."""
    m_s = f_s = z_s = 0.0
    if mass is not None:
        m_s = _three_sigma(r, "mass_kg", mass, 0.0, None, " kg")
        if m_s >= mass:
            raise r.error("mass_kg_3sigma", f"must be less than the mass {mass:g} kg", m_s)
    if f is not None:
        top = 1.0 / (MIN_STEPS_PER_PERIOD * timestep_s)
        f_s = _three_sigma(r, "frequency_hz", f, MIN_FREQUENCY_HZ, top, " Hz")
    if zeta is not None:
        z_s = _three_sigma(r, "damping_ratio", zeta, 0.0, None, "")
        if zeta + z_s >= 1.0:
            raise r.error(
                "damping_ratio_3sigma",
                f"takes damping_ratio from {zeta:g} to {zeta + z_s:g} at +3 sigma: it must stay "
                "below 1 (an oscillating mode)",
                z_s,
            )
    return ModeSigmas(m_s / 3.0, f_s / 3.0, z_s / 3.0)


def _reach(r: Reader, name: str, point, cg, gyration_m: float, *, value=None) -> None:
    """Refuse a ``point`` beyond the vehicle's reach from the CG (``value``: what the key
    holds, when ``point`` is derived from it)."""
    reach = MAX_REACH_GYRATIONS * gyration_m
    distance = float(np.linalg.norm(np.subtract(point, cg)))
    if distance > reach:
        what = "is" if value is None else f"puts the point {list(point)}"
        raise r.error(
            name,
            f"{what} {distance:.4g} m from the CG; it must be within {reach:.4g} m "
            f"({MAX_REACH_GYRATIONS:g} radii of gyration, as jets and the tank): a position in mm?",
            list(point if value is None else value),
        )


def _name(r: Reader, default: str, seen: dict, where: str) -> str:
    name = r.raw("name", default)
    if not isinstance(name, str) or not name.isidentifier():
        raise r.error("name", "must be an identifier (letters, digits, _)", name)
    if name in seen:
        raise r.error("name", f"duplicate (first in {seen[name]})", name)
    seen[name] = where
    r.note = f" ({name})"
    return name


def _read_slosh(
    r: Reader, name: str, cg, gyration_m: float, timestep_s: float
) -> tuple[SloshMode, ModeSigmas]:
    model = r.choice("model", None, SLOSH_MODELS)
    mass = r.number("mass_kg", None, minimum=0.0, strict=True)
    if model == "spring":
        pos = r.vector("position_m", 3)
        _reach(r, "position_m", pos, cg, gyration_m)
        if r.has("direction") == r.has("directions"):
            raise r.error(
                "direction",
                "give one of direction (one lateral mode) or directions (two, normal to each "
                "other)",
            )
        if r.has("direction"):
            dirs: tuple = (_unit(r, "direction", r.vector("direction", 3)),)
        else:
            raw = r.raw("directions")
            if not isinstance(raw, list) or len(raw) != 2:
                raise r.error("directions", "must be a list of two 3-vectors", raw)
            sub = Reader({"a": raw[0], "b": raw[1]}, r.key("directions"), r.source, r.note)
            dirs = (
                _unit(r, "directions", sub.vector("a", 3)),
                _unit(r, "directions", sub.vector("b", 3)),
            )
            if abs(float(np.dot(*dirs))) > ORTHOGONAL_COS:
                raise r.error("directions", "must be normal to each other (two lateral modes)", raw)
        f = _frequency(r, timestep_s)
        zeta = _damping_ratio(r)
        sigmas = _sigmas(r, mass=mass, f=f, zeta=zeta, timestep_s=timestep_s)
        r.done()
        return (
            SloshMode(name, model, mass, pos, dirs, frequency_hz=f, damping_ratio=zeta),
            sigmas,
        )
    pivot = r.vector("pivot_m", 3)
    _reach(r, "pivot_m", pivot, cg, gyration_m)
    rod = _unit(r, "direction", r.vector("direction", 3))
    length = r.number("length_m", None, minimum=0.0, strict=True)
    if length > MAX_REACH_GYRATIONS * gyration_m:
        raise r.error("length_m", "is longer than the vehicle's reach (a length in mm?)", length)
    damping = r.number("damping_n_m_s", 0.0, minimum=0.0)
    sigmas = _sigmas(r, mass=mass, f=None, zeta=None, timestep_s=timestep_s)
    r.done()
    pos = tuple(np.add(pivot, length * np.asarray(rod)).tolist())
    mode = SloshMode(
        name, model, mass, pos, (rod,), pivot_m=pivot, length_m=length, damping_n_m_s=damping
    )
    return mode, sigmas


def _read_panel_inertia(r: Reader) -> tuple:
    d = r.vector("inertia_kg_m2", 3)
    p = r.vector("products_kg_m2", 3, [0.0, 0.0, 0.0])
    tensor = np.array([[d[0], p[0], p[1]], [p[0], d[1], p[2]], [p[1], p[2], d[2]]])
    moments = np.linalg.eigvalsh(tensor)
    a, b, c = moments
    if moments.min() <= 0 or a + b < c * (1 - 1e-12):
        raise r.error(
            "inertia_kg_m2",
            f"is no rigid body's (principal moments {np.round(moments, 6).tolist()}: each must "
            "be positive, the two smaller adding up to the largest at least)",
            list(d),
        )
    return tuple(map(tuple, tensor.tolist()))


def _read_appendage(
    r: Reader, name: str, cg, gyration_m: float, timestep_s: float
) -> tuple[Appendage, ModeSigmas]:
    mass = r.number("mass_kg", None, minimum=0.0, strict=True)
    inertia = _read_panel_inertia(r)
    hinge = r.vector("hinge_m", 3)
    _reach(r, "hinge_m", hinge, cg, gyration_m)
    axis = _unit(r, "axis", r.vector("axis", 3))
    offset = r.vector("cg_offset_m", 3)
    _reach(r, "cg_offset_m", np.add(hinge, offset).tolist(), cg, gyration_m, value=offset)
    f = _frequency(r, timestep_s)
    zeta = _damping_ratio(r)
    sigmas = _sigmas(r, mass=None, f=f, zeta=zeta, timestep_s=timestep_s)
    r.done()
    return Appendage(name, mass, inertia, hinge, axis, offset, f, zeta), sigmas


def read_modes(
    top: Reader,
    *,
    mass_kg: float,
    cg_m,
    inertia_kg_m2: np.ndarray,
    gyration_m: float,
    timestep_s: float,
    propellant_kg: float | None,
) -> Modes | None:
    """The file's ``[[slosh]]`` and ``[[appendage]]`` blocks (None when it has neither).

    Parameters
    ----------
    top : Reader
        The file's top level (the blocks are popped from it).
    mass_kg, cg_m, inertia_kg_m2
        The whole vehicle's ``[mass]`` (checked).
    gyration_m : float
        Radius of gyration of its largest principal moment [m] (the reach of every point).
    timestep_s : float
        The physics step (a mode needs :data:`MIN_STEPS_PER_PERIOD` of them a period).
    propellant_kg : float or None
        ``[propellant] mass_kg``: the slosh masses are part of it, so their sum must not exceed
        it.

    Raises
    ------
    InputError
        One line naming the file, the block and key, and the value.
    """
    src = top.source
    raw_slosh = top.raw("slosh", [])
    raw_panels = top.raw("appendage", [])
    if not raw_slosh and not raw_panels:
        return None
    seen: dict[str, str] = {}
    slosh: list = []
    panels: list = []
    sigmas: dict[str, list] = {"slosh": [], "appendage": []}
    for key, raw_list, out in (("slosh", raw_slosh, slosh), ("appendage", raw_panels, panels)):
        if not isinstance(raw_list, list):
            raise top.error(key, f"must be [[{key}]] blocks", raw_list)
        for k, raw in enumerate(raw_list):
            where = f"{key}[{k + 1}]"
            if not isinstance(raw, dict):
                raise top.error(where, "must be a table", raw)
            r = Reader(raw, where, src)
            name = _name(r, f"{key}_{k + 1}", seen, where)
            read = _read_slosh if key == "slosh" else _read_appendage
            mode, sigma = read(r, name, cg_m, gyration_m, timestep_s)
            out.append(mode)
            sigmas[key].append(sigma)
    total_slosh = sum(s.mass_kg for s in slosh)
    if propellant_kg is not None and total_slosh > propellant_kg:
        raise InputError(
            f"{src}: slosh.mass_kg: the slosh masses add up to {total_slosh:g} kg, more than the "
            f"propellant.mass_kg = {propellant_kg:g} kg they are part of (got "
            f"{[s.mass_kg for s in slosh]!r})"
        )
    modes = (*slosh, *panels)
    m_h, c_h, i_h = hub_mass_properties(mass_kg, cg_m, inertia_kg_m2, modes)
    problem = hub_problem(m_h, i_h)
    if problem:
        raise InputError(
            f"{src}: mass.mass_kg: is the whole vehicle's with its slosh and appendages; "
            f"{problem} (got mass {mass_kg:g} kg, modes {sum(m.mass_kg for m in modes):g} kg)"
        )
    all_sigmas = (*sigmas["slosh"], *sigmas["appendage"])
    dispersed = any(s.disperses() for s in all_sigmas)
    return Modes(tuple(slosh), tuple(panels), m_h, c_h, i_h, all_sigmas if dispersed else ())


def mode_warnings(modes: Modes | None, timestep_s: float) -> list[str]:
    """Odd but legal modes, one line each: a clamped frequency with fewer than
    :data:`WARN_STEPS_PER_PERIOD` physics steps a period; an undamped mode (it never settles)."""
    if modes is None:
        return []
    out = []
    for mode in modes.all:
        f = mode.frequency_hz
        if f and f * timestep_s * WARN_STEPS_PER_PERIOD > 1:
            out.append(
                f"{mode.name}: clamped frequency {f:g} Hz has {1 / (f * timestep_s):.3g} physics "
                f"steps a period, fewer than {WARN_STEPS_PER_PERIOD} (its coupled frequency is "
                "higher still): a smaller physics.timestep_s integrates it better"
            )
        undamped = mode.damping == 0
        if undamped:
            out.append(f"{mode.name}: no damping: the mode never settles once excited")
    return out
