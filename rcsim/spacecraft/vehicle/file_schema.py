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
* ``[control]`` is the flight-software profile (:mod:`rcsim.spacecraft.control_profile`):
  the control cycle, maneuver rate and limit, deadbands, hold time; a key left out is the
  paper's (``paper.toml``'s ``[control]``).  Every limit below that depends on the cycle (valve
  delays, minimum on-time, physics step) is checked against the profile's cycle.
* ``[failure]`` is the vehicle's own failure criterion (``rate_error_deg_s``,
  ``attitude_error_deg``, as a campaign spec's ``[failure]``): the defaults of a campaign of
  it, which a spec's ``[failure]`` overrides; without it a campaign judges the vehicle by the
  paper's (0.04 deg/s, Gambone sec. III) and says so.
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

import os
import tomllib
from pathlib import Path

import numpy as np

from rcsim.models.errors import InputError
from rcsim.models.toml_reader import Reader
from rcsim.spacecraft.modes.reader import read_modes
from rcsim.spacecraft.pulse_file import read_blowdown, read_pulse, read_pulse_dispersions
from rcsim.spacecraft.vehicle.definition import (
    DELAY_KEYS,
    GYRATION_RANGE_M,
    INTEGRATORS,
    ISP_RANGE_S,
    MAX_MASS_KG,
    MIN_TIMESTEP_S,
    PACKAGED_VEHICLES,
    VALVE_DELAY_KEYS,
    Jet,
    VehicleDef,
    packaged_vehicle,
    resolve_vehicle,
)
from rcsim.spacecraft.vehicle.file_sections import (
    check_profile,
    check_reach,
    paper_control,
    paper_isp_s,
    read_dispersions,
    read_failure,
    read_file_control,
    read_inertia,
    read_jets,
    read_timing,
)

__all__ = [
    "DELAY_KEYS",
    "INTEGRATORS",
    "PACKAGED_VEHICLES",
    "VALVE_DELAY_KEYS",
    "Jet",
    "VehicleDef",
    "load_vehicle",
    "packaged_vehicle",
    "paper_control",
    "paper_isp_s",
    "parse_vehicle",
    "read_vehicle_bytes",
    "resolve_vehicle",
]


def load_vehicle(
    path: str | os.PathLike, control: dict | None = None, *, control_from: str = ""
) -> VehicleDef:
    """Read and validate a vehicle file.

    Parameters
    ----------
    path : path or str
        A vehicle TOML file, or the name of a packaged one (:data:`PACKAGED_VEHICLES`).
    control : dict, optional
        Overrides of the file's ``[control]`` keys (a campaign spec's ``[control]``, the
        command line's ``--control``), applied before every check that depends on the cycle.
    control_from : str
        Where ``control`` came from, for messages and the profile's source.

    Raises
    ------
    InputError
        One line naming the file, the key and the value (and the overrides' origin when a
        check fails under them).
    """
    path = resolve_vehicle(path)
    text = read_vehicle_bytes(path).decode("utf-8")
    return parse_vehicle(text, path, control, control_from=control_from)


def read_vehicle_bytes(path: Path) -> bytes:
    """A vehicle file's bytes (``path`` resolved by :func:`resolve_vehicle`), checked to be
    UTF-8 text.

    Raises
    ------
    InputError
        The file is missing, unreadable or not UTF-8, naming it.
    """
    try:
        raw = path.read_bytes()
        raw.decode("utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: vehicle file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the vehicle file: {exc}") from None
    return raw


def parse_vehicle(
    text: str, path: Path, control: dict | None = None, *, control_from: str = ""
) -> VehicleDef:
    """Validate a vehicle file's ``text`` (read from ``path``, named in messages); ``control``
    as :func:`load_vehicle`'s."""
    try:
        return _parse_vehicle(text, path, control or {}, control_from)
    except InputError as exc:
        if control:
            keys = ", ".join(
                f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v!r}"
                for k, v in control.items()
            )
            raise InputError(f"{exc} (with control {keys} from {control_from})") from None
        raise


def _parse_vehicle(text: str, path: Path, overrides: dict, overrides_from: str) -> VehicleDef:
    src = str(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{src}: not valid TOML: {exc}") from None
    top = Reader(data, "", src)
    control = read_file_control(top, path, overrides, overrides_from)
    cycle = control.cycle_s
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
    inertia = read_inertia(m)
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
    dt = ph.number("timestep_s", cycle, minimum=0.0, strict=True)
    n_sub = round(cycle / dt)
    if n_sub < 1 or abs(n_sub * dt - cycle) > 1e-9 * cycle:
        raise ph.error("timestep_s", f"must divide the {cycle * 1e3:g} ms control cycle", dt)
    if dt < MIN_TIMESTEP_S:
        raise ph.error(
            "timestep_s",
            f"must be at least {MIN_TIMESTEP_S * 1e3:g} ms, ten times finer than the 1 ms "
            "reference of the convergence study (RK4 at 40 ms is converged): a finer step buys "
            f"nothing and costs {round(cycle / dt)} steps a cycle",
            dt,
        )
    integrator = ph.choice("integrator", "RK4", INTEGRATORS)
    ph.done()
    check_profile(control, dt, path, data.get("control", {}), overrides, overrides_from)
    hull = top.table_("hull")
    hull_half = hull.vector("half_size_m", 3, required=False)
    hull_center = hull.vector("center_m", 3, list(cg) if hull_half else None, required=False)
    hull.done()
    reach_unit = float(gyration.max())  # the radius of gyration of the largest moment
    # The tables as written (``_jets`` validates them): which delay keys the file gives.
    raw_jets, raw_defaults = top.table.get("jet", []), top.table.get("jet_defaults", {})
    pulse = read_pulse(top, raw_jets, raw_defaults, cycle, ISP_RANGE_S)
    jets, min_on = read_jets(top, cg, src, reach_unit, cycle)
    command_delay, delay_keys = read_timing(
        top.table_("timing"), jets, raw_jets, raw_defaults, cycle
    )
    pr = top.table_("propellant")
    # A file without an Isp takes the paper vehicle's (paper.toml: an assumption, the paper
    # gives none); `rcsim vehicle check` says which.
    isp = pr.number("isp_s", paper_isp_s(), minimum=0.0, strict=True)
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
        check_reach(pr, "tank_position_m", "the tank", tank, cg, reach_unit)
    blowdown = read_blowdown(pr, prop)
    pr.done()
    if prop is not None and prop >= mass:
        raise InputError(
            f"{src}: propellant.mass_kg: must be below mass.mass_kg = {mass:g} (got {prop!r})"
        )
    modes = read_modes(
        top,
        mass_kg=mass,
        cg_m=cg,
        inertia_kg_m2=inertia,
        gyration_m=reach_unit,
        timestep_s=dt,
        propellant_kg=prop,
    )
    dispersions = top.table_("dispersions")
    pulse_three_sigma = read_pulse_dispersions(dispersions, pulse, blowdown, cycle)
    three_sigma = read_dispersions(dispersions, mass, inertia, cg, jets)
    failure = read_failure(top.table_("failure"), control)
    top.done()
    return VehicleDef(
        source=src,
        name=name,
        mass_kg=mass,
        cg_m=cg,
        inertia_kg_m2=inertia,
        jets=tuple(jets),
        control=control,
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
        failure=failure,
        modes=modes,
        pulse=pulse,
        blowdown=blowdown,
        pulse_three_sigma=pulse_three_sigma,
    )
