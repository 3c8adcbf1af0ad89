"""The readers of a vehicle file's sections: mass properties (``[mass]``), jets
(``[jet_defaults]``, ``[[jet]]``), valve timing (``[timing]``), dispersions (``[dispersions]``)
and the flight-software profile (``[control]``), each value checked against its range and the
control cycle (:mod:`rcsim.spacecraft.vehicle.file_schema` puts them together).
"""

from __future__ import annotations

import functools
import math
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np

from rcsim.models.errors import InputError
from rcsim.models.toml_reader import Reader
from rcsim.spacecraft.control_profile import (
    CONTROL_FIELDS,
    CONTROL_KEYS,
    ControlProfile,
    bound_problems,
    control_key,
    flatten_control,
    rate_problems,
    read_control,
    shown_value,
)
from rcsim.spacecraft.dispersions import (
    INERTIA_ENTRIES,
    INERTIA_RULE,
    THREE_SIGMA_KEYS,
    inertia_scale_limit,
    largest_inertia_sigma,
    second_moment_slack,
    three_sigma_bounds,
)
from rcsim.spacecraft.vehicle.definition import (
    MAX_REACH_GYRATIONS,
    MAX_THRUST_N,
    MIN_ARM_M,
    VALVE_DELAY_KEYS,
    Jet,
    packaged_vehicle,
)


def read_inertia(r: Reader) -> np.ndarray:
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


def check_reach(r: Reader, name: str, what: str, point, cg: tuple, gyration_m: float) -> None:
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


def _check_cg_against_jets(top: Reader, cg: tuple, jets: list[Jet], gyration_m: float) -> None:
    """Refuse a CG beyond every jet's reach (:func:`check_reach`) and far from their centroid:
    then the CG is the odd one out (a CG in mm), and the message blames ``mass.cg_m``, not the
    first jet."""
    if len(jets) < 2:
        return
    reach = MAX_REACH_GYRATIONS * gyration_m
    positions = np.array([j.position_m for j in jets], float)
    if np.linalg.norm(positions - np.asarray(cg), axis=1).min() <= reach:
        return
    centroid = positions.mean(axis=0)
    distance = float(np.linalg.norm(centroid - np.asarray(cg)))
    raise top.error(
        "mass.cg_m",
        f"is {distance:.4g} m from the centroid of the jets {np.round(centroid, 4).tolist()} "
        f"m, and every jet is farther than {reach:.4g} m from it ({MAX_REACH_GYRATIONS:g} "
        f"radii of gyration, sqrt(Imax/m) = {gyration_m:.4g} m): a CG in mm? (or every "
        "position in another unit)",
        list(cg),
    )


def _delay(r: Reader, name: str, cycle_s: float, default: float = 0.0) -> float:
    """A delay key [s]: finite, >= 0 and shorter than the control cycle ``cycle_s``."""
    value = r.number(name, default, minimum=0.0)
    if value >= cycle_s:
        raise r.error(
            name,
            f"must be shorter than the {cycle_s * 1e3:g} ms control cycle: a valve "
            "command must act within its cycle (a delay in ms?)",
            value,
        )
    return value


_JET_DEFAULT_KEYS = ("thrust_n", "min_on_s", *VALVE_DELAY_KEYS)


def read_jets(
    top: Reader, cg: tuple, src: str, gyration_m: float, cycle_s: float
) -> tuple[list[Jet], float]:
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
            _delay(Reader(dict(shared), "jet_defaults", src), key, cycle_s)
    raw_jets = top.raw("jet", None)
    if not isinstance(raw_jets, list) or not raw_jets:
        raise top.error("jet", "at least one [[jet]] block is required", raw_jets)
    jets: list[Jet] = []
    readers: list[Reader] = []  # each jet's, for a message naming it after the loop
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
        open_s, close_s = (_delay(r, key, cycle_s) for key in VALVE_DELAY_KEYS)
        r.done()
        if np.linalg.norm(np.subtract(pos, cg)) < MIN_ARM_M:
            raise r.error(
                "position_m",
                f"is at the CG {list(cg)} (closer than {MIN_ARM_M * 1e3:g} mm): a jet there "
                "has no moment arm",
                list(pos),
            )
        readers.append(r)
        jets.append(Jet(name, pos, unit, d if norm == 1.0 else unit, thrust, open_s, close_s))
    _check_cg_against_jets(top, cg, jets, gyration_m)
    for r, jet in zip(readers, jets):
        check_reach(r, "position_m", "the jet", jet.position_m, cg, gyration_m)
    if len(min_on) > 1:
        raise top.error(
            "jet",
            "min_on_s differs between jets; the valve model has one minimum on-time",
            sorted(min_on),
        )
    shortest = min_on.pop()
    if shortest >= cycle_s:
        raise top.error(
            "jet_defaults.min_on_s",
            f"must be shorter than the {cycle_s * 1e3:g} ms control cycle",
            shortest,
        )
    return jets, shortest


def read_timing(
    t: Reader, jets: list[Jet], raw_jets: list, defaults: dict, cycle_s: float
) -> tuple[float, tuple]:
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
    command = _delay(t, "command_delay_s", cycle_s)
    t.done()
    for k, jet in enumerate(jets):
        for key in VALVE_DELAY_KEYS:
            own = key in raw_jets[k]
            total = command + getattr(jet, key)
            if total >= cycle_s:
                where = f"jet[{k + 1}].{key}" if own else f"jet_defaults.{key}"
                raise InputError(
                    f"{t.source}: {where}: plus timing.command_delay_s = {command:g} s is "
                    f"{total:.4g} s; it must be shorter than the {cycle_s * 1e3:g} ms "
                    f"control cycle: a valve command must act within its cycle "
                    f"(got {getattr(jet, key)!r})"
                )
    return command, tuple(given)


_UNITS = {"kg": "kg", "m": "m", "m2": "kg m^2", "n": "N", "deg": "deg"}


def read_dispersions(ds: Reader, mass: float, inertia: np.ndarray, cg: tuple, jets: list) -> dict:
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


def read_file_control(
    top: Reader, path: Path, overrides: dict, overrides_from: str
) -> ControlProfile:
    """``[control]``: the file's profile (keys it leaves out: the paper's), then
    ``overrides``; the source names the file, the keys taken from the paper's profile and the
    overridden keys."""
    raw = top.raw("control", {})
    paper = paper_control()
    own = read_control(raw, paper, where=str(path), bounds=False)
    given = sorted(set(_given_keys(raw)))
    if path.resolve() == packaged_vehicle("paper").resolve():
        source = "the paper's profile (paper.toml [control]: Gambone sec. II, Table 4)"
    elif not given:
        source = f"the paper's profile (paper.toml [control]; {path.name} has no [control])"
    elif len(given) == len(CONTROL_KEYS):
        source = f"{path.name} [control]"
    else:
        rest = [k for k in CONTROL_KEYS if k not in given]
        source = f"{path.name} [control]; the paper's profile for {', '.join(rest)}"
    own = replace(own, source=source)
    if overrides:
        own = read_control(overrides, own, where=overrides_from or "overrides", bounds=False)
    return own


def check_profile(
    control: ControlProfile,
    timestep_s: float,
    path: Path,
    raw: dict,
    overrides: dict,
    overrides_from: str,
) -> None:
    """The profile's bounds once every override is applied, named where the key at fault came
    from: its rates against the vehicle's physics step first
    (:func:`rcsim.spacecraft.control_profile.rate_problems`), then the bounds between its keys
    (:func:`rcsim.spacecraft.control_profile.bound_problems`), a rule between keys blaming an
    overridden key before one the file set.

    Parameters
    ----------
    raw : dict
        The file's ``[control]`` table as written (the keys it sets).
    overrides : dict
        The ``[control]`` overrides applied on top (a spec's, ``--control``'s), from
        ``overrides_from``.
    """
    by_key = {control_key(name): name for name in CONTROL_FIELDS}
    over = {by_key[k] for k in flatten_control(overrides) if k in by_key}
    own = {by_key[k] for k in _given_keys(raw) if k in by_key}
    problems = rate_problems(control, timestep_s) or bound_problems(control, (over, own))
    if not problems:
        return
    name, text = problems[0]
    where = (overrides_from or "overrides") if name in over else str(path)
    raise InputError(
        f"{where}: control.{control_key(name)}: {text} (got {shown_value(control, name)})"
    )


def read_failure(f: Reader, control: ControlProfile) -> dict:
    """``[failure]``: the vehicle's own failure criterion, the keys it gives (deg/s, deg).

    * ``rate_error_deg_s`` (a run fails when its final rate error on any axis is at or above
      it): > 0 and below the profile's maneuver rate, or a run still turning at the maneuver
      rate at its end would pass;
    * ``attitude_error_deg`` (a run fails when its final attitude error is above it): > 0 and
      below 180 deg (no attitude error is larger, so it could never fail a run).
    """
    out: dict = {}
    if f.has("rate_error_deg_s"):
        rate = f.number("rate_error_deg_s", None, minimum=0.0, strict=True)
        most = math.degrees(control.maneuver_rate_rad_s)
        if rate >= most:
            raise f.error(
                "rate_error_deg_s",
                f"must be below the maneuver rate control.maneuver_rate_deg_s = {most:g}: a run "
                "still turning at the maneuver rate at its end would pass",
                rate,
            )
        out["rate_error_deg_s"] = rate
    if f.has("attitude_error_deg"):
        att = f.number("attitude_error_deg", None, minimum=0.0, strict=True)
        if att >= 180.0:
            raise f.error(
                "attitude_error_deg",
                "must be below 180 deg: no attitude error is larger, so it would fail no run",
                att,
            )
        out["attitude_error_deg"] = att
    f.done()
    return out


def _given_keys(raw) -> list[str]:
    if not isinstance(raw, dict):
        return []
    out = []
    for key, value in raw.items():
        if isinstance(value, dict):
            out += [f"{key}.{sub}" for sub in value]
        else:
            out.append(key)
    return out


@functools.cache
def paper_control() -> ControlProfile:
    """The paper's profile: ``paper.toml``'s ``[control]``, every key required (the values a
    vehicle file's missing keys take)."""
    path = packaged_vehicle("paper")
    raw = tomllib.loads(path.read_text(encoding="utf-8")).get("control")
    if raw is None:  # pragma: no cover - a packaging mistake, caught by the tests
        raise InputError(f"{path}: [control] is missing: the paper's profile must be complete")
    return read_control(raw, None, where=str(path))


@functools.cache
def paper_isp_s() -> float:
    """The paper vehicle's specific impulse [s] (``paper.toml``'s ``[propellant] isp_s``):
    what a vehicle file without one takes."""
    path = packaged_vehicle("paper")
    return float(tomllib.loads(path.read_text(encoding="utf-8"))["propellant"]["isp_s"])
