"""The DAI papers' spacecraft, gains, timelines, disturbances and CMGs as data (SI).

Owns ``rcsim/models/dai/``: ``parameters.csv`` (one value per row: group, name, value, unit,
source), ``dispersions.csv`` (the Monte Carlo uncertainties), ``paper_figures_of_merit.csv`` (001
Tables 6-9, the reference results), ``dai_spacecraft.xml`` (rigid body + three
body-frame torque motors) and ``SOURCES.md`` (which table or equation each value came from and
every reading chosen where a paper is garbled or contradicts itself).  The loaders validate
every cell and convert to SI; a bad cell raises :class:`rcsim.models.errors.InputError` naming
the file, the row, the field and the value.  Like the rest of ``models`` this package
must not import ``spacecraft``, ``lookup`` or ``analysis``.

Papers: 001 = Wilt & Sands, "Microsatellite Uncertainty Control Using Deterministic Artificial
Intelligence", Sensors 22 (2022) 8723 (group ``wilt2022``); 002 = Smeresky & Rizzo, "Modern
Control System Learning", in *Deterministic Artificial Intelligence*, IntechOpen (2020)
(group ``smeresky2020``).

Only imported by: rcsim.spacecraft.continuous, rcsim.lookup.continuous,
rcsim.analysis.apps.studies.
"""

from __future__ import annotations

import atexit
import csv
import functools
import math
import os
from contextlib import ExitStack
from dataclasses import dataclass
from importlib.resources import as_file, files
from pathlib import Path

import numpy as np

from rcsim.models.errors import InputError

PAPERS = ("wilt2022", "smeresky2020")

# unit -> factor to SI.  Units are checked per row so a user file in other units converts
# instead of being misread.
_UNITS = {
    "1": 1.0,
    "kg": 1.0,
    "kg*m^2": 1.0,
    "s": 1.0,
    "m": 1.0,
    "km": 1e3,
    "K": 1.0,
    "Pa": 1.0,
    "K/km": 1e-3,
    "km^3/s^2": 1e9,
    "kg/mol": 1.0,
    "J/(mol*K)": 1.0,
    "deg": math.pi / 180.0,
    "rad": 1.0,
    "N*m/rad": 1.0,
    "N*m*s/rad": 1.0,
    "N*m/(rad*s)": 1.0,
    "N*m*s": 1.0,
    "s^3": 1.0,
}
_COLUMNS = ("group", "name", "value", "unit", "source")
_DISPERSION_COLUMNS = ("name", "distribution", "nominal", "bound", "unit", "source")


def _resource(name: str) -> Path:
    """Real path of a packaged file of this folder, kept alive until exit (MuJoCo needs a
    real file; from a zip install ``as_file`` extracts one)."""
    resource = files("rcsim.models.dai") / name
    if isinstance(resource, Path):
        return resource
    keep = ExitStack()
    atexit.register(keep.close)
    return Path(keep.enter_context(as_file(resource)))


@functools.cache
def dai_xml() -> Path:
    """Path of the DAI spacecraft MJCF (``rcsim/models/dai/dai_spacecraft.xml``)."""
    return _resource("dai_spacecraft.xml")


def _read_rows(path: Path, columns: tuple[str, ...]) -> list[dict[str, str]]:
    try:
        with open(path, newline="") as fh:
            reader = csv.DictReader(fh)
            header = tuple(reader.fieldnames or ())
            rows = list(reader)
    except OSError as exc:
        raise InputError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    missing = [c for c in columns if c not in header]
    if missing:
        raise InputError(
            f"{path}: missing column(s) {', '.join(missing)} (header: {', '.join(header)})"
        )
    return rows


def _number(path: Path, row: int, field: str, text: str | None) -> float:
    try:
        value = float(text)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{path}: row {row}, {field}: not a number: {text!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{path}: row {row}, {field}: not finite: {text!r}")
    return value


@functools.cache
def _parameters_cached(path: str) -> dict[str, dict[str, float]]:
    p = Path(path)
    table: dict[str, dict[str, float]] = {}
    for i, row in enumerate(_read_rows(p, _COLUMNS), start=1):
        group, name, unit = row["group"].strip(), row["name"].strip(), row["unit"].strip()
        if unit not in _UNITS:
            raise InputError(
                f"{p}: row {i} ({group}.{name}), unit: unknown unit {unit!r} "
                f"(known: {', '.join(sorted(_UNITS))})"
            )
        if name in table.get(group, {}):
            raise InputError(f"{p}: row {i}, name: {group}.{name} appears twice")
        table.setdefault(group, {})[name] = (
            _number(p, i, f"value of {group}.{name}", row["value"]) * _UNITS[unit]
        )
    return table


def load_parameters(path: str | os.PathLike | None = None) -> dict[str, dict[str, float]]:
    """Every row of ``parameters.csv`` in SI: ``{group: {name: value}}``.

    Parameters
    ----------
    path : path, optional
        A user file with the same columns; default the packaged table.
    """
    return _parameters_cached(str(Path(path) if path else _resource("parameters.csv")))


def _get(params: dict, group: str, name: str, path: str | os.PathLike | None) -> float:
    try:
        return params[group][name]
    except KeyError:
        where = path or "parameters.csv"
        raise InputError(f"{where}: no row {group}.{name}") from None


def _check_positive(value: float, group: str, name: str, path) -> float:
    if not value > 0:
        raise InputError(f"{path or 'parameters.csv'}: {group}.{name} must be > 0, got {value}")
    return value


def _check_paper(paper: str) -> None:
    if paper not in PAPERS:
        raise InputError(
            f"must be one of {', '.join(PAPERS)}, got {paper!r}", parameter="paper", value=paper
        )


@dataclass(frozen=True)
class PaperSetup:
    """One paper's spacecraft, gains and timeline (SI).

    Attributes
    ----------
    inertia_B : ndarray, (3, 3)
        Inertia about the CG in body axes [kg m^2], symmetric positive definite.
    mass_kg : float
    pdi_gains, observer_gains : ndarray, (3,)
        ``(kp, kd, ki)`` [N m/rad, N m s/rad, N m/(rad s)] of the PDI controller and of the
        Luenberger observer.
    quiescent_s, maneuver_s, observation_s : float
        The three periods of the sinusoidal trajectory [s].
    timestep_s : float
        The paper's fixed step [s].
    dai_memory_s : float
        Forgetting time constant of the DAI regression [s] (chosen; SOURCES.md).
    dai_gain_s3 : float
        Learning gain ``g`` of the integral reading [s^3] (SOURCES.md).
    """

    paper: str
    inertia_B: np.ndarray
    mass_kg: float
    pdi_gains: np.ndarray
    observer_gains: np.ndarray
    quiescent_s: float
    maneuver_s: float
    observation_s: float
    timestep_s: float
    dai_memory_s: float
    dai_gain_s3: float

    @property
    def duration_s(self) -> float:
        return self.quiescent_s + self.maneuver_s + self.observation_s


def load_setup(paper: str, path: str | os.PathLike | None = None) -> PaperSetup:
    """The spacecraft, gains and timeline of ``paper`` (``"wilt2022"`` or ``"smeresky2020"``).

    Raises
    ------
    InputError
        Unknown paper; a missing row; an inertia that is not positive definite or violates
        the triangle inequality; a non-positive gain or period.
    """
    _check_paper(paper)
    p = load_parameters(path)
    g = lambda name: _get(p, paper, name, path)  # noqa: E731
    j = np.array(
        [
            [g("jxx"), g("jxy"), g("jxz")],
            [g("jxy"), g("jyy"), g("jyz")],
            [g("jxz"), g("jyz"), g("jzz")],
        ]
    )
    moments = np.linalg.eigvalsh(j)
    if moments.min() <= 0 or 2 * moments.max() > moments.sum() * (1 + 1e-12):
        raise InputError(
            f"{path or 'parameters.csv'}: {paper} inertia {j.tolist()} is not "
            "a rigid body's (principal moments must be > 0 and obey the "
            "triangle inequality)"
        )
    names = ("kp", "kd", "ki")
    pdi = np.array([_check_positive(g(f"pdi_{n}"), paper, f"pdi_{n}", path) for n in names])
    obs = np.array(
        [_check_positive(g(f"observer_{n}"), paper, f"observer_{n}", path) for n in names]
    )
    periods = {
        n: _check_positive(g(n), paper, n, path)
        for n in ("quiescent", "maneuver", "observation", "timestep")
    }
    return PaperSetup(
        paper=paper,
        inertia_B=j,
        mass_kg=_check_positive(g("mass"), paper, "mass", path),
        pdi_gains=pdi,
        observer_gains=obs,
        quiescent_s=periods["quiescent"],
        maneuver_s=periods["maneuver"],
        observation_s=periods["observation"],
        timestep_s=periods["timestep"],
        dai_memory_s=_check_positive(_get(p, "dai", "memory", path), "dai", "memory", path),
        dai_gain_s3=_check_positive(
            _get(p, "dai", "learning_gain", path), "dai", "learning_gain", path
        ),
    )


@dataclass(frozen=True)
class Damage:
    """001 App. A.2: at ``time_s`` the principal moments are multiplied by ``factors``."""

    time_s: float
    factors: np.ndarray  # (3,): xx, yy, zz


def load_damage(path: str | os.PathLike | None = None) -> Damage:
    """The simulated damage of 001 App. A.2."""
    p = load_parameters(path)
    g = lambda name: _get(p, "wilt2022", name, path)  # noqa: E731
    factors = np.array(
        [
            _check_positive(g(f"damage_factor_{a}"), "wilt2022", f"damage_factor_{a}", path)
            for a in ("xx", "yy", "zz")
        ]
    )
    return Damage(
        time_s=_check_positive(g("damage_time"), "wilt2022", "damage_time", path), factors=factors
    )


@dataclass(frozen=True)
class Environment:
    """Orbit, atmosphere and drag geometry of 001 App. C (SI).

    Attributes
    ----------
    earth_radius_m, mu_m3_s2, altitude_m : float
    t_inf_k, t_10_k, lapse_k10_k_m, z_10_m : float
        Thermosphere temperature profile (001 App. C, "From 1977 NASA").
    pressure_pa, molar_mass_kg_mol, gas_constant : float
        Pressure and mean molar mass at ``altitude_m`` and the universal gas constant.
    cd : float
    size_m : ndarray, (3,)
        Box edges a, b, c [m].
    cp_cg_B : ndarray, (3,)
        Centre of pressure minus centre of mass, body axes [m].
    """

    earth_radius_m: float
    mu_m3_s2: float
    altitude_m: float
    t_inf_k: float
    t_10_k: float
    lapse_k10_k_m: float
    z_10_m: float
    pressure_pa: float
    molar_mass_kg_mol: float
    gas_constant: float
    cd: float
    size_m: np.ndarray
    cp_cg_B: np.ndarray

    @property
    def radius_m(self) -> float:
        return self.earth_radius_m + self.altitude_m

    @property
    def mean_motion_rad_s(self) -> float:
        """Circular-orbit rate w0 = sqrt(mu / R^3) (001 App. C)."""
        return math.sqrt(self.mu_m3_s2 / self.radius_m**3)

    @property
    def speed_m_s(self) -> float:
        """Orbital speed V = w0 R (001 App. C, V_orbit)."""
        return self.mean_motion_rad_s * self.radius_m

    @property
    def area_B_m2(self) -> np.ndarray:
        """Projected areas along body x, y, z (001 App. C's ``Area``, read as m^2)."""
        a, b, c = self.size_m
        return np.array([a * b, (a + c + a) * a, b * a + c * a + b * a])


def load_environment(path: str | os.PathLike | None = None) -> Environment:
    """Orbit, atmosphere and drag parameters (001 App. C) in SI."""
    p = load_parameters(path)

    def g(group, name):
        return _check_positive(_get(p, group, name, path), group, name, path)

    return Environment(
        earth_radius_m=g("orbit", "earth_radius"),
        mu_m3_s2=g("orbit", "mu"),
        altitude_m=g("orbit", "altitude"),
        t_inf_k=g("atmosphere", "t_inf"),
        t_10_k=g("atmosphere", "t_10"),
        lapse_k10_k_m=g("atmosphere", "lapse_k10"),
        z_10_m=g("atmosphere", "z_10"),
        pressure_pa=g("atmosphere", "pressure_150km"),
        molar_mass_kg_mol=g("atmosphere", "molar_mass_150km"),
        gas_constant=g("atmosphere", "gas_constant"),
        cd=g("drag", "cd"),
        size_m=np.array([g("drag", f"size_{k}") for k in "abc"]),
        cp_cg_B=np.array([_get(p, "drag", f"cp_cg_{k}", path) for k in "xyz"]),
    )


@dataclass(frozen=True)
class CmgSetup:
    """Three single-gimbal CMGs (002 Sec. 2.1, 001 App. C).

    Attributes
    ----------
    skew_rad : ndarray, (3,)
        Skew angles beta_i [rad].
    gimbal0_rad : ndarray, (3,)
        Initial gimbal angles theta_i [rad].
    wheel_momentum_nms : float
        Rotor momentum of each CMG [N m s] (not in the papers; SOURCES.md).
    singular_det : float
        |det A| of the unit-momentum Jacobian below which a gimbal set is flagged singular.
    """

    skew_rad: np.ndarray
    gimbal0_rad: np.ndarray
    wheel_momentum_nms: float
    singular_det: float


def load_cmg(path: str | os.PathLike | None = None) -> CmgSetup:
    """The CMG array parameters in SI."""
    p = load_parameters(path)
    g = lambda name: _get(p, "cmg", name, path)  # noqa: E731
    return CmgSetup(
        skew_rad=np.full(3, g("skew_angle")),
        gimbal0_rad=np.full(3, g("initial_gimbal_angle")),
        wheel_momentum_nms=_check_positive(g("wheel_momentum"), "cmg", "wheel_momentum", path),
        singular_det=_check_positive(g("singular_det"), "cmg", "singular_det", path),
    )


@dataclass(frozen=True)
class Dispersion:
    """One Monte Carlo uncertainty: ``uniform`` (nominal +- bound) or ``normal`` (sigma)."""

    name: str
    distribution: str
    nominal: float
    bound: float


def load_dispersions(path: str | os.PathLike | None = None) -> dict[str, Dispersion]:
    """``dispersions.csv`` in SI, by name."""
    p = Path(path) if path else _resource("dispersions.csv")
    out = {}
    for i, row in enumerate(_read_rows(p, _DISPERSION_COLUMNS), start=1):
        name, dist, unit = row["name"].strip(), row["distribution"].strip(), row["unit"].strip()
        if dist not in ("uniform", "normal"):
            raise InputError(
                f"{p}: row {i} ({name}), distribution: must be uniform or normal, got {dist!r}"
            )
        if unit not in _UNITS:
            raise InputError(f"{p}: row {i} ({name}), unit: unknown unit {unit!r}")
        bound = _number(p, i, "bound", row["bound"]) * _UNITS[unit]
        if bound < 0:
            raise InputError(f"{p}: row {i} ({name}), bound: must be >= 0, got {row['bound']}")
        out[name] = Dispersion(
            name, dist, _number(p, i, "nominal", row["nominal"]) * _UNITS[unit], bound
        )
    return out


@dataclass(frozen=True)
class PaperFigure:
    """One row of 001 Tables 6-9 (``paper_figures_of_merit.csv``).

    Attributes
    ----------
    table : int
        The paper's table number (6, 7, 8; 9 for the percent improvements).
    scenario, method : str
        The study's scenario name and method (``"improvement"`` for Table 9).
    mean, std, effort : float
        Mean tracking error and its standard deviation [deg], and the "control effort"
        column (run time [s], SOURCES.md reading 11); percentages for Table 9.
    """

    table: int
    scenario: str
    method: str
    mean: float
    std: float
    effort: float


def load_paper_figures(path: str | os.PathLike | None = None) -> list[PaperFigure]:
    """001 Tables 6-9 as transcribed in ``paper_figures_of_merit.csv`` (comment lines ``#``)."""
    p = Path(path) if path else _resource("paper_figures_of_merit.csv")
    try:
        lines = [line for line in p.read_text().splitlines() if not line.startswith("#")]
    except OSError as exc:
        raise InputError(f"{p}: cannot read it ({exc.strerror or exc})") from None
    reader = csv.DictReader(lines)
    missing = [
        c
        for c in ("table", "scenario", "method", "mean", "std", "effort")
        if c not in (reader.fieldnames or ())
    ]
    if missing:
        raise InputError(f"{p}: missing column(s) {', '.join(missing)}")
    return [
        PaperFigure(
            int(_number(p, i, "table", row["table"])),
            row["scenario"].strip(),
            row["method"].strip(),
            *(_number(p, i, k, row[k]) for k in ("mean", "std", "effort")),
        )
        for i, row in enumerate(reader, start=1)
    ]
