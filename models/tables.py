"""The paper's reference tables as validated data (Gambone, *Pattern Recognition Control Design*).

Tables 1-7 of the paper live as CSV files in ``models/data`` (see ``models/data/SOURCES.md``
for provenance and every correction).  The loaders here read them -- or a user file in the same
format -- check their *structure*, and return SI quantities:

========================  =======================================  =========================
loader                    file                                     returns
========================  =======================================  =========================
load_mass_properties      table1_mass_properties.csv               MassProperties
load_jet_map              table2_jet_map.csv                       int array (16, 3)
load_rate_cases           table3_rate_cases.csv                    RateCases
load_lookup_inputs        table4_lookup_inputs.csv                 LookupInputs
load_dispersions          table5_dispersions.csv                   pandas.DataFrame
load_lookup_table         table6_lookup_original.csv / table7_...  LookupTable
paper_corrections         corrections.csv                          list[Correction]
========================  =======================================  =========================

Design rules
------------
* No table value appears in this module's logic.  The checks are structural: the set of rate
  cases is every sign pattern of (roll, pitch, yaw) except all-zero, in roll-major order; every
  case has the same total rate; the jets that fire are exactly those the jet map points along
  the commanded rate; paired jets fire equally long; firing times are whole control cycles.
  The only numbers below are constants the paper states in its *text* (16 thrusters, 40 ms
  control cycle, 0.3 deg/s total rate command), each cited where it is defined.
* Every failure is a :class:`models.errors.InputError` whose one-line message names the file,
  the row (1-based data row, plus the case or jet number when known), the column and the bad
  value, so an analyst can go straight to the cell.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import os
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Sequence, Union

import numpy as np
import pandas as pd

from rcsim.models.atomic import atomic_write
from rcsim.models.errors import InputError

__all__ = [
    "AXES",
    "CONTROL_CYCLE_S",
    "N_CASES",
    "N_JETS",
    "PAPER_TOTAL_RATE_DEG_S",
    "RATE_RTOL",
    "Correction",
    "LookupInputs",
    "LookupTable",
    "MassProperties",
    "RateCases",
    "check_consistency",
    "load_dispersions",
    "load_jet_map",
    "load_lookup_inputs",
    "load_lookup_table",
    "load_mass_properties",
    "load_rate_cases",
    "paper_corrections",
    "sign_patterns",
]

PathLike = Union[str, os.PathLike]

# --------------------------------------------------------------------------------------------
# Constants the paper states in its text (not table values).
# --------------------------------------------------------------------------------------------
AXES = ("roll", "pitch", "yaw")
#: Paper section II: "The spacecraft has 16 thrusters that can be used for rotational control."
N_JETS = 16
#: Paper section II: the 26 rate commands are "combinations of positive, negative and zero rate
#: commands in roll, pitch, and yaw" -- every pattern in {-,0,+}^3 except the all-zero one.
N_CASES = 3 ** len(AXES) - 1
#: Paper section II: "The control rate for the spacecraft model is set to 40 milliseconds."
CONTROL_CYCLE_S = 0.040
#: Paper section II: "... for a 0.3 degrees per second total rate command for each run."
PAPER_TOTAL_RATE_DEG_S = 0.3

#: Relative tolerance on rate magnitudes.  The paper prints rates to 4 decimals (0.2121 for
#: 0.3/sqrt(2) = 0.212132, 0.1732 for 0.3/sqrt(3) = 0.173205).  A rounding error of at most
#: 5e-5 deg/s per component moves the norm of a 0.3 deg/s command by at most
#: 5e-5 * sqrt(3) / 0.3 = 2.9e-4 relative, so 1e-3 accepts every correctly rounded entry while
#: any real typo (a wrong digit in the first three places, or a 1-axis magnitude on a 2-axis
#: case, which is 29 % off) is far outside it.
RATE_RTOL = 1e-3
#: Absolute tolerance (s) for "firing time is a whole number of control cycles" and for "paired
#: jets fire equally long": far below one cycle, far above float error of a decimal like 0.28.
TIME_ATOL_S = 1e-9

RATE_COLUMNS = tuple(f"{axis}_deg_s" for axis in AXES)
SIGN_COLUMNS = tuple(f"{axis}_sign" for axis in AXES)
JET_COLUMNS = tuple(f"jet_{j:02d}" for j in range(1, N_JETS + 1))

_PACKAGED_LOOKUP = {"table6": "table6_lookup_original.csv", "table7": "table7_lookup_updated.csv"}

# Unit string -> (physical dimension, factor to SI).  Long tables carry their unit per row, so
# a user file in other units (lbf, ms, rad) converts instead of silently being misread.
_UNITS: dict[str, tuple[str, float]] = {
    "kg": ("mass", 1.0),
    "m": ("length", 1.0),
    "kg*m^2": ("inertia", 1.0),
    "kg-m^2": ("inertia", 1.0),
    "kg m^2": ("inertia", 1.0),
    "N": ("force", 1.0),
    "lbf": ("force", 4.4482216152605),  # exact by definition of the pound-force
    "deg": ("angle", math.pi / 180.0),
    "rad": ("angle", 1.0),
    "deg/s": ("angular_rate", math.pi / 180.0),
    "deg/sec": ("angular_rate", math.pi / 180.0),  # the paper's own spelling in Table 4
    "rad/s": ("angular_rate", 1.0),
    "s": ("time", 1.0),
    "sec": ("time", 1.0),
    "ms": ("time", 1e-3),
}
_SI_UNIT = {
    "mass": "kg",
    "length": "m",
    "inertia": "kg*m^2",
    "force": "N",
    "angle": "rad",
    "angular_rate": "rad/s",
    "time": "s",
}
# parameter -> (dimension, must be strictly positive)
_MASS_PARAMETERS = {
    "mass": ("mass", True),
    "cg_x": ("length", False),  # a position: either sign is physical
    "ixx": ("inertia", True),
    "iyy": ("inertia", True),
    "izz": ("inertia", True),
    "thrust": ("force", True),
}
_LOOKUP_PARAMETERS = {
    "maneuver_limit": ("angle", True),
    "maneuver_rate": ("angular_rate", True),
    "rate_error_limit": ("angular_rate", True),
    "on_time_limit": ("time", True),
    "hold_time": ("time", True),
}
# Dispersions the vehicle model knows; other names are allowed (a campaign may add its own) but
# these must carry a unit of the right dimension.
_DISPERSION_DIMENSIONS = {
    "mass": "mass",
    "cg_x": "length",
    "ixx": "inertia",
    "iyy": "inertia",
    "izz": "inertia",
    "thrust": "force",
    "thruster_angle": "angle",
}
# Paper section III: "The three-sigma values used to generate normal Monte Carlo inputs".
_DISTRIBUTIONS = ("normal",)


# --------------------------------------------------------------------------------------------
# Result types
# --------------------------------------------------------------------------------------------
def _frozen_array(values, dtype, shape: tuple[int, ...], what: str) -> np.ndarray:
    arr = np.array(values, dtype=dtype)  # a copy: callers cannot mutate our state through it
    if arr.shape != shape:
        raise InputError(f"{what}: expected shape {shape}, got {arr.shape}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class MassProperties:
    """Vehicle mass properties (paper Table 1), SI.

    Attributes
    ----------
    mass_kg : float
        Vehicle mass, kg.
    cg_x_m : float
        Centre-of-gravity x position, m.
    inertia_kgm2 : numpy.ndarray, shape (3,)
        Principal moments of inertia [Ixx, Iyy, Izz], kg*m^2 (read-only).
    thrust_n : float
        Thrust of one jet, N.
    """

    mass_kg: float
    cg_x_m: float
    inertia_kgm2: np.ndarray
    thrust_n: float

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "inertia_kgm2", _frozen_array(self.inertia_kgm2, float, (3,), "inertia_kgm2")
        )


@dataclass(frozen=True, eq=False)
class RateCases:
    """The rate-command cases of the lookup table (paper Table 3), SI.

    Attributes
    ----------
    case : numpy.ndarray of int, shape (26,)
        Case numbers 1..26, ascending.
    rate_cmd : numpy.ndarray of float, shape (26, 3)
        Commanded body rate [roll, pitch, yaw] per case, rad/s.
    """

    case: np.ndarray
    rate_cmd: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "case", _frozen_array(self.case, int, (N_CASES,), "case"))
        object.__setattr__(
            self, "rate_cmd", _frozen_array(self.rate_cmd, float, (N_CASES, 3), "rate_cmd")
        )


@dataclass(frozen=True)
class LookupInputs:
    """Pattern-recognition control-logic inputs (paper Table 4), SI.

    Attributes
    ----------
    maneuver_limit_rad : float
        Total angle error above which the logic commands the maneuver rate, rad.
    maneuver_rate_rad_s : float
        Total maneuver rate, rad/s.
    rate_error_limit_rad_s : float
        Dead band: rate errors below this are treated as zero, rad/s.
    on_time_limit_s : float
        A new firing is computed only when the remaining on time of a jet and its opposing jet
        is below this, s.
    hold_time_s : float
        Settling time after a firing before another is commanded, s.
    """

    maneuver_limit_rad: float
    maneuver_rate_rad_s: float
    rate_error_limit_rad_s: float
    on_time_limit_s: float
    hold_time_s: float


@dataclass(frozen=True)
class Correction:
    """One cell where the packaged data differs from the paper as printed.

    Attributes
    ----------
    file : str
        Data file name, e.g. ``"table3_rate_cases.csv"``.
    case : int
        Case (or 1-based data row) of the corrected cell.
    column : str
        Column of the corrected cell, e.g. ``"roll_deg_s"``.
    paper_value : float
        Value printed in the paper, in the column's unit.
    corrected_value : float
        Value stored in the packaged file, in the column's unit.
    reason : str
        Why the printed value is wrong.
    """

    file: str
    case: int
    column: str
    paper_value: float
    corrected_value: float
    reason: str


@dataclass(frozen=True, eq=False)
class LookupTable:
    """A jet firing-time lookup table (paper Tables 6 and 7), SI, all 16 jets.

    Attributes
    ----------
    case : numpy.ndarray of int, shape (26,)
        Case numbers 1..26, ascending.
    rate_cmd : numpy.ndarray of float, shape (26, 3)
        Rate command [roll, pitch, yaw] each row was designed for, rad/s.
    firing_time_s : numpy.ndarray of float, shape (26, 16)
        Firing time of jets 1..16 per case, s; jets that do not fire (including the unused
        translation jets 5-8) are 0.
    source : str
        Where the table was read from (for messages); ``""`` if built in memory.

    Notes
    -----
    Construction checks shapes only; :func:`load_lookup_table` and :func:`check_consistency`
    check the content.
    """

    case: np.ndarray
    rate_cmd: np.ndarray
    firing_time_s: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        case = _frozen_array(self.case, int, (N_CASES,), "case")
        object.__setattr__(self, "case", case)
        object.__setattr__(
            self, "rate_cmd", _frozen_array(self.rate_cmd, float, (N_CASES, 3), "rate_cmd")
        )
        object.__setattr__(
            self,
            "firing_time_s",
            _frozen_array(self.firing_time_s, float, (N_CASES, N_JETS), "firing_time_s"),
        )

    def to_csv(self, path: PathLike) -> Path:
        """Write the table in the rcsim layout, atomically.

        Columns: ``case, roll_deg_s, pitch_deg_s, yaw_deg_s, jet_01 ... jet_16`` (rates in
        deg/s, firing times in s).  Floats are written with ``repr`` so that reading the file
        back gives the same doubles (rates up to the rad<->deg conversion, a few ulp).

        The file is written to a temporary file in the target directory and moved into place
        with :func:`os.replace`, so a crash never leaves a half-written table that a later
        campaign could load.

        Parameters
        ----------
        path : str or os.PathLike
            Destination file.

        Returns
        -------
        pathlib.Path
            The written path.
        """
        target = Path(path)
        rates_deg = np.rad2deg(self.rate_cmd)
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["case", *RATE_COLUMNS, *JET_COLUMNS])
        for i, case in enumerate(self.case):
            writer.writerow(
                [int(case)]
                + [repr(float(v)) for v in rates_deg[i]]
                + [repr(float(v)) for v in self.firing_time_s[i]]
            )
        def write(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8", newline="") as fh:
                fh.write(buf.getvalue())
                fh.flush()
                os.fsync(fh.fileno())

        return atomic_write(target, write)


# --------------------------------------------------------------------------------------------
# CSV reading with cell-precise errors
# --------------------------------------------------------------------------------------------
_NO_VALUE = object()


def _where(file: str, row=None, column=None, case=None, jet=None) -> str:
    parts = [str(file)]
    if row == "header":
        parts.append("header row")
    elif row is not None:
        loc = f"row {row}"
        if case is not None:
            loc += f" (case {case})"
        elif jet is not None:
            loc += f" (jet {jet})"
        parts.append(loc)
    elif case is not None:
        parts.append(f"case {case}")
    if column is not None:
        parts.append(f"column '{column}'")
    return ", ".join(parts)


def _error(file, problem, *, row=None, column=None, case=None, jet=None, value=_NO_VALUE):
    msg = f"{_where(file, row, column, case, jet)}: {problem}"
    if value is not _NO_VALUE:
        msg += f" (got {value!r})"
    return InputError(msg.replace("\n", " "))


@dataclass
class _Raw:
    """A CSV file as stripped strings; ``rows[i]`` is 1-based data row ``i + 1``."""

    file: str
    header: list[str]
    rows: list[list[str]]

    def cell(self, i: int, column: str) -> str:
        return self.rows[i][self.header.index(column)]


def _source(path: PathLike | None, default_name: str):
    if path is None:
        return files("rcsim.models") / "data" / default_name
    return Path(path)


def _read_raw(path: PathLike | None, default_name: str) -> _Raw:
    src = _source(path, default_name)
    label = str(src)
    try:
        # utf-8-sig: tolerate the byte-order mark spreadsheet programs put on exported CSV.
        with src.open("r", encoding="utf-8-sig", newline="") as fh:
            text = fh.read()
    except FileNotFoundError:
        raise InputError(f"{label}: file not found") from None
    except IsADirectoryError:
        raise InputError(f"{label}: is a directory, not a CSV file") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{label}: not UTF-8 text ({exc.reason})") from None
    records = [r for r in csv.reader(io.StringIO(text)) if any(c.strip() for c in r)]
    if not records:
        raise InputError(f"{label}: empty file (no header row)")
    header = [c.strip() for c in records[0]]
    rows = []
    for i, rec in enumerate(records[1:], start=1):
        cells = [c.strip() for c in rec]
        if len(cells) > len(header):
            raise _error(
                label,
                f"{len(cells)} fields but the header has {len(header)}",
                row=i,
                column=f"<extra field {len(header) + 1}>",
                value=cells[len(header)],
            )
        # A short row means trailing cells are missing: pad with "" so the empty-cell check
        # reports the first missing column by name.
        rows.append(cells + [""] * (len(header) - len(cells)))
    if not rows:
        raise InputError(f"{label}: no data rows")
    return _Raw(label, header, rows)


def _check_columns(raw: _Raw, required: Sequence[str], hint: str = "") -> None:
    seen = set()
    for name in raw.header:
        if name == "":
            raise _error(raw.file, "empty column name", row="header", column=name)
        if name in seen:
            raise _error(raw.file, "duplicate column", row="header", column=name)
        seen.add(name)
    for name in required:
        if name not in seen:
            raise _error(
                raw.file,
                f"missing column; expected columns {', '.join(required)}{hint}",
                row="header",
                column=name,
            )
    for name in raw.header:
        if name not in required:
            raise _error(
                raw.file,
                f"unknown column; expected columns {', '.join(required)}{hint}",
                row="header",
                column=name,
            )


def _number(raw: _Raw, i: int, column: str, *, case=None, jet=None, minimum=None, strict=False):
    """Parse cell (row ``i`` 0-based, ``column``) as a finite float, optionally bounded below."""
    text = raw.cell(i, column)
    where = dict(row=i + 1, column=column, case=case, jet=jet)
    if text == "":
        raise _error(raw.file, "empty cell", **where)
    try:
        value = float(text)
    except ValueError:
        raise _error(raw.file, "not a number", value=text, **where) from None
    if not math.isfinite(value):
        raise _error(raw.file, "NaN/infinite value", value=text, **where)
    if minimum is not None and (value <= minimum if strict else value < minimum):
        bound = f"> {minimum:g}" if strict else f">= {minimum:g}"
        raise _error(raw.file, f"wrong sign: must be {bound}", value=text, **where)
    return value


def _integer(raw: _Raw, i: int, column: str, *, case=None) -> int:
    value = _number(raw, i, column, case=case)
    if value != int(value):
        raise _error(raw.file, "not an integer", row=i + 1, column=column, value=raw.cell(i, column))
    return int(value)


def _index_column(raw: _Raw, column: str, count: int, what: str) -> np.ndarray:
    """Parse a 1..count numbering column; every number exactly once.  Returns the numbers."""
    numbers = []
    first_row: dict[int, int] = {}
    for i in range(len(raw.rows)):
        n = _integer(raw, i, column)
        if not 1 <= n <= count:
            raise _error(
                raw.file,
                f"{what} number outside 1..{count} (the table has exactly {count} {what}s)",
                row=i + 1,
                column=column,
                value=raw.cell(i, column),
            )
        if n in first_row:
            raise _error(
                raw.file,
                f"duplicate {what} {n} (first on row {first_row[n]})",
                row=i + 1,
                column=column,
                value=raw.cell(i, column),
            )
        first_row[n] = i + 1
        numbers.append(n)
    missing = sorted(set(range(1, count + 1)) - set(first_row))
    if missing:
        raise _error(
            raw.file,
            f"wrong shape: {what} {missing[0]} missing (need {what}s 1..{count}, got "
            f"{len(raw.rows)} rows)",
            case=missing[0] if what == "case" else None,
            column=column,
        )
    return np.array(numbers, dtype=int)


def _long_table(path, default_name, value_column, spec) -> tuple[_Raw, dict[str, float]]:
    """Read a ``parameter, unit, <value_column>`` table; return SI values keyed by parameter."""
    raw = _read_raw(path, default_name)
    _check_columns(raw, ("parameter", "unit", value_column))
    out: dict[str, float] = {}
    first_row: dict[str, int] = {}
    for i in range(len(raw.rows)):
        name = raw.cell(i, "parameter")
        if name not in spec:
            raise _error(
                raw.file,
                f"unknown parameter; expected {', '.join(spec)}",
                row=i + 1,
                column="parameter",
                value=name,
            )
        if name in first_row:
            raise _error(
                raw.file,
                f"duplicate parameter (first on row {first_row[name]})",
                row=i + 1,
                column="parameter",
                value=name,
            )
        first_row[name] = i + 1
        dimension, positive = spec[name]
        factor = _unit_factor(raw, i, "unit", dimension)
        value = _number(raw, i, value_column, minimum=0.0 if positive else None, strict=positive)
        out[name] = value * factor
    for name in spec:
        if name not in out:
            raise _error(raw.file, f"parameter '{name}' missing", column="parameter")
    return raw, out


def _unit_factor(raw: _Raw, i: int, column: str, dimension: str | None) -> float:
    unit = raw.cell(i, column)
    if unit not in _UNITS:
        raise _error(
            raw.file, f"unknown unit; known: {', '.join(_UNITS)}", row=i + 1, column=column,
            value=unit,
        )
    unit_dim, factor = _UNITS[unit]
    if dimension is not None and unit_dim != dimension:
        raise _error(
            raw.file,
            f"unit of {unit_dim} where a {dimension} unit (e.g. {_SI_UNIT[dimension]}) is needed",
            row=i + 1,
            column=column,
            value=unit,
        )
    return factor


# --------------------------------------------------------------------------------------------
# Structural checks
# --------------------------------------------------------------------------------------------
def sign_patterns() -> np.ndarray:
    """Every sign pattern of (roll, pitch, yaw) in {-1, 0, +1}^3 except all-zero, roll-major.

    This is the case numbering of the lookup tables: case ``k`` has pattern ``k - 1`` of this
    array (case 1 = (-,-,-), case 2 = (-,-,0), ..., case 26 = (+,+,+)).

    Returns
    -------
    numpy.ndarray of int, shape (26, 3)
        Signs per case, columns roll, pitch, yaw.
    """
    pats = [p for p in itertools.product((-1, 0, 1), repeat=len(AXES)) if any(p)]
    return np.array(pats, dtype=int)


def _fmt_pattern(p) -> str:
    return "(" + ",".join({-1: "-", 0: "0", 1: "+"}[int(s)] for s in p) + ")"


def _check_rate_rows(
    file: str,
    rows: np.ndarray,
    case: np.ndarray,
    rate_deg_s: np.ndarray,
    *,
    total_rate_deg_s: float | None,
    roll_major: bool,
    equal_split: bool,
) -> None:
    """Check rate-command rows (deg/s, sorted by case; ``rows`` = 1-based file rows).

    Raises InputError on: an all-zero command; a sign pattern used twice; (``roll_major``) a
    sign pattern other than the case number's roll-major pattern; (``equal_split``) unequal
    magnitudes on the nonzero axes; a total rate off ``total_rate_deg_s`` (or, if None, off
    the common total of all rows) by more than RATE_RTOL relative.
    """
    signs = np.sign(rate_deg_s).astype(int)
    expected = sign_patterns()
    owner: dict[tuple, list[int]] = {}
    for k, p in enumerate(signs):
        owner.setdefault(tuple(p), []).append(int(case[k]))
    for k in range(len(case)):
        c, r, p = int(case[k]), int(rows[k]), signs[k]
        if not p.any():
            raise _error(
                file, "rate command is zero on every axis", row=r, case=c,
                column=RATE_COLUMNS[0], value=float(rate_deg_s[k, 0]),
            )
        others = [o for o in owner[tuple(p)] if o != c]
        dup = f"; it duplicates case {others[0]}" if others else ""
        # Blame the later of two duplicate rows: the first one is where the pattern belongs.
        earlier = [o for o in others if o < c]
        if roll_major and not np.array_equal(p, expected[c - 1]):
            axis = int(np.flatnonzero(p != expected[c - 1])[0])
            raise _error(
                file,
                f"sign pattern {_fmt_pattern(p)} breaks the roll-major case order, which "
                f"gives case {c} the pattern {_fmt_pattern(expected[c - 1])}{dup}",
                row=r, case=c, column=RATE_COLUMNS[axis], value=float(rate_deg_s[k, axis]),
            )
        if earlier:
            axis = int(np.flatnonzero(p)[0])
            raise _error(
                file,
                f"sign pattern {_fmt_pattern(p)} used twice (cases {owner[tuple(p)]}); each "
                f"pattern of {{-,0,+}}^3 except all-zero must appear once",
                row=r, case=c, column=RATE_COLUMNS[axis], value=float(rate_deg_s[k, axis]),
            )
    norms = np.linalg.norm(rate_deg_s, axis=1)
    reference = float(np.median(norms)) if total_rate_deg_s is None else float(total_rate_deg_s)
    what = (
        f"the common total rate {reference:g} deg/s of this table"
        if total_rate_deg_s is None
        else f"the total rate command {reference:g} deg/s"
    )
    for k in range(len(case)):
        c, r = int(case[k]), int(rows[k])
        nz = np.flatnonzero(rate_deg_s[k])
        mags = np.abs(rate_deg_s[k, nz])
        if equal_split and len(nz) > 1:
            # The paper splits the total rate equally over the commanded axes (0.3/sqrt(k)).
            mid = float(np.median(mags))
            dev = np.abs(mags - mid) / mid
            if dev.max() > RATE_RTOL:
                axis = int(nz[int(np.argmax(dev))])
                raise _error(
                    file,
                    f"unequal magnitudes on the commanded axes (others {mid:g} deg/s, "
                    f"tolerance {RATE_RTOL:g} relative)",
                    row=r, case=c, column=RATE_COLUMNS[axis], value=float(rate_deg_s[k, axis]),
                )
        if abs(norms[k] - reference) > RATE_RTOL * reference:
            axis = int(nz[0])
            raise _error(
                file,
                f"total rate {norms[k]:.6g} deg/s differs from {what} by more than "
                f"{RATE_RTOL:g} relative",
                row=r, case=c, column=RATE_COLUMNS[axis], value=float(rate_deg_s[k, axis]),
            )


def check_consistency(
    case: np.ndarray,
    rate_cmd: np.ndarray,
    firing_time_s: np.ndarray,
    jet_map: np.ndarray,
    *,
    file: str = "<lookup table>",
    rows: np.ndarray | None = None,
    cycle_s: float | None = CONTROL_CYCLE_S,
) -> None:
    """Check a lookup table's firing times against its rate commands and the jet map.

    Rules (paper section II: the thrusters fire in their "designed firing direction", Table 2;
    damping "requires equal firing times with the opposing thrusters"; control rate 40 ms):

    1. firing times are finite and >= 0;
    2. (if ``cycle_s``) every firing time is a whole number of control cycles, within
       ``TIME_ATOL_S``;
    3. a jet whose jet-map row is all zero (unused, e.g. translation jets) never fires;
    4. on each axis, the jets that fire are exactly the jets whose jet-map sign equals the
       sign of that axis's rate command -- so an axis with zero rate has no firing jet;
    5. all jets sharing an axis and sign (a pair) fire equally long, within ``TIME_ATOL_S``.

    Parameters
    ----------
    case : array_like of int, shape (n,)
        Case numbers, for messages.
    rate_cmd : array_like of float, shape (n, 3)
        Rate command per case [roll, pitch, yaw], rad/s.  Only the signs are used.
    firing_time_s : array_like of float, shape (n, 16)
        Firing time of jets 1..16 per case, s.
    jet_map : array_like of int, shape (16, 3)
        Jet map (paper Table 2): sign of the torque each jet gives about roll, pitch, yaw.
    file : str
        File name to put in messages.
    rows : array_like of int, shape (n,), optional
        1-based data row in ``file`` of each case (default ``1..n``).
    cycle_s : float or None
        Control cycle, s; None skips rule 2.

    Raises
    ------
    models.errors.InputError
        At the first broken rule, naming file, row, case, column (``jet_NN``) and value.
    """
    case = np.asarray(case, dtype=int)
    rate = np.asarray(rate_cmd, dtype=float)
    times = np.asarray(firing_time_s, dtype=float)
    jmap = np.asarray(jet_map, dtype=int)
    n = len(case)
    if rate.shape != (n, 3) or times.shape != (n, jmap.shape[0]) or jmap.shape[1:] != (3,):
        raise InputError(
            f"{file}: wrong shape: case {case.shape}, rate_cmd {rate.shape}, firing_time_s "
            f"{times.shape}, jet_map {jmap.shape}; need (n,), (n, 3), (n, jets), (jets, 3)"
        )
    rows = np.arange(1, n + 1) if rows is None else np.asarray(rows, dtype=int)
    rate_deg = np.rad2deg(rate)
    rate_sign = np.sign(rate).astype(int)
    for k in range(n):
        where = dict(row=int(rows[k]), case=int(case[k]))
        for j in range(jmap.shape[0]):
            col = f"jet_{j + 1:02d}"
            t = float(times[k, j])
            if not math.isfinite(t):
                raise _error(file, "NaN/infinite firing time", column=col, value=t, **where)
            if t < 0:
                raise _error(file, "wrong sign: firing time must be >= 0", column=col, value=t,
                             **where)
            if cycle_s is not None:
                cycles = t / cycle_s
                if abs(cycles - round(cycles)) * cycle_s > TIME_ATOL_S:
                    raise _error(
                        file,
                        f"firing time is not a whole number of {cycle_s * 1e3:g} ms control "
                        f"cycles ({cycles:.4g} cycles)",
                        column=col, value=t, **where,
                    )
            axes = np.flatnonzero(jmap[j])
            if len(axes) == 0:
                if t > 0:
                    raise _error(file, f"jet {j + 1} is unused in the jet map (no torque) but "
                                 "fires", column=col, value=t, **where)
                continue
            for a in axes:
                s = int(jmap[j, a])
                should_fire = rate_sign[k, a] == s
                jet = f"jet {j + 1} ({AXES[a]} {s:+d})"
                cmd = f"the {AXES[a]} rate command is {rate_deg[k, a]:+.4g} deg/s"
                if should_fire and t == 0:
                    raise _error(file, f"{jet} does not fire although {cmd}", column=col,
                                 value=t, **where)
                if not should_fire and t > 0:
                    raise _error(file, f"{jet} fires although {cmd}", column=col, value=t,
                                 **where)
        # Rule 5: jets with the same jet-map row (same axis and sign) are a pair.
        groups: dict[tuple, list[int]] = {}
        for j in range(jmap.shape[0]):
            if jmap[j].any():
                groups.setdefault(tuple(jmap[j]), []).append(j)
        for members in groups.values():
            first = members[0]
            for j in members[1:]:
                if abs(times[k, j] - times[k, first]) > TIME_ATOL_S:
                    raise _error(
                        file,
                        f"paired jets fire unequal times: jet {j + 1} vs jet {first + 1} "
                        f"({times[k, first]:g} s); a pair must fire equally long",
                        column=f"jet_{j + 1:02d}", value=float(times[k, j]), **where,
                    )


# --------------------------------------------------------------------------------------------
# Loaders
# --------------------------------------------------------------------------------------------
def load_mass_properties(path: PathLike | None = None) -> MassProperties:
    """Load vehicle mass properties (paper Table 1).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A ``parameter, unit, value`` CSV with parameters ``mass, cg_x, ixx, iyy, izz, thrust``
        (units e.g. kg, m, kg*m^2, N; other known units are converted).  Default: the packaged
        ``table1_mass_properties.csv``.

    Returns
    -------
    MassProperties
        SI values; ``inertia_kgm2`` has shape (3,).

    Raises
    ------
    models.errors.InputError
        Missing/unknown column or parameter, empty or non-numeric value, non-positive mass,
        inertia or thrust, wrong unit dimension, or principal moments that violate the
        triangle inequality (no rigid body has them).
    """
    raw, v = _long_table(path, "table1_mass_properties.csv", "value", _MASS_PARAMETERS)
    inertia = np.array([v["ixx"], v["iyy"], v["izz"]])
    # Principal moments of a rigid body satisfy I_a <= I_b + I_c; a violation is a typo.
    for a, name in enumerate(("ixx", "iyy", "izz")):
        if inertia[a] > inertia.sum() - inertia[a]:
            row = 1 + [r[0] for r in raw.rows].index(name)
            raise _error(
                raw.file,
                f"{name} exceeds the sum of the other two principal moments (not a rigid body)",
                row=row, column="value", value=raw.cell(row - 1, "value"),
            )
    return MassProperties(
        mass_kg=v["mass"], cg_x_m=v["cg_x"], inertia_kgm2=inertia, thrust_n=v["thrust"]
    )


def load_lookup_inputs(path: PathLike | None = None) -> LookupInputs:
    """Load the pattern-recognition logic inputs (paper Table 4).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A ``parameter, unit, value`` CSV with parameters ``maneuver_limit`` (angle),
        ``maneuver_rate``, ``rate_error_limit`` (angular rate), ``on_time_limit``,
        ``hold_time`` (time).  Default: the packaged ``table4_lookup_inputs.csv``.

    Returns
    -------
    LookupInputs
        SI values (rad, rad/s, s).

    Raises
    ------
    models.errors.InputError
        Missing/unknown column or parameter, bad or non-positive value, wrong unit dimension.

    Notes
    -----
    The paper's design rules -- maneuver rate at least three times the rate error limit, on
    time limit slightly below the 40 ms control cycle -- are recommendations, not checked here,
    so that stress studies can break them on purpose.
    """
    _, v = _long_table(path, "table4_lookup_inputs.csv", "value", _LOOKUP_PARAMETERS)
    return LookupInputs(
        maneuver_limit_rad=v["maneuver_limit"],
        maneuver_rate_rad_s=v["maneuver_rate"],
        rate_error_limit_rad_s=v["rate_error_limit"],
        on_time_limit_s=v["on_time_limit"],
        hold_time_s=v["hold_time"],
    )


def load_dispersions(path: PathLike | None = None) -> pd.DataFrame:
    """Load Monte Carlo dispersions (paper Table 5).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``name, distribution, three_sigma, unit, source``.  Default: the
        packaged ``table5_dispersions.csv`` (names mass, cg_x, ixx, iyy, izz, thrust,
        thruster_angle; all ``normal``).

    Returns
    -------
    pandas.DataFrame
        One row per dispersion, in file order, columns:
        ``name`` (str), ``distribution`` (str), ``three_sigma`` (float, SI: kg, m, kg*m^2, N,
        rad), ``si_unit`` (str), ``unit`` (str, the file's unit, for display),
        ``three_sigma_in_unit`` (float, the file's value), ``source`` (str).

    Raises
    ------
    models.errors.InputError
        Missing/unknown column, empty name, duplicate name, unknown distribution, unknown
        unit or wrong dimension for a known name, bad or negative three_sigma.
    """
    raw = _read_raw(path, "table5_dispersions.csv")
    _check_columns(raw, ("name", "distribution", "three_sigma", "unit", "source"))
    records = []
    first_row: dict[str, int] = {}
    for i in range(len(raw.rows)):
        name = raw.cell(i, "name")
        if not name.isidentifier():
            raise _error(raw.file, "name must be an identifier", row=i + 1, column="name",
                         value=name)
        if name in first_row:
            raise _error(raw.file, f"duplicate name (first on row {first_row[name]})",
                         row=i + 1, column="name", value=name)
        first_row[name] = i + 1
        dist = raw.cell(i, "distribution")
        if dist not in _DISTRIBUTIONS:
            raise _error(raw.file, f"unknown distribution; expected one of {_DISTRIBUTIONS}",
                         row=i + 1, column="distribution", value=dist)
        factor = _unit_factor(raw, i, "unit", _DISPERSION_DIMENSIONS.get(name))
        sigma = _number(raw, i, "three_sigma", minimum=0.0)
        unit = raw.cell(i, "unit")
        records.append(
            dict(
                name=name,
                distribution=dist,
                three_sigma=sigma * factor,
                si_unit=_SI_UNIT[_UNITS[unit][0]],
                unit=unit,
                three_sigma_in_unit=sigma,
                source=raw.cell(i, "source"),
            )
        )
    return pd.DataFrame.from_records(records)


def load_jet_map(path: PathLike | None = None) -> np.ndarray:
    """Load the jet map (paper Table 2): torque sign of each jet about roll, pitch, yaw.

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``jet, roll_sign, pitch_sign, yaw_sign``; jets 1..16 once each;
        signs in {-1, 0, 1}.  Default: the packaged ``table2_jet_map.csv``.

    Returns
    -------
    numpy.ndarray of int, shape (16, 3)
        Row ``j - 1`` is jet ``j``; columns roll, pitch, yaw.  All-zero rows are jets unused for
        rotation (the paper's translation jets 5-8).

    Raises
    ------
    models.errors.InputError
        Missing/unknown column, a jet number missing/duplicated/outside 1..16, a sign not in
        {-1, 0, 1}, a jet with torque on two axes (paper section IV: "the current logic does
        not allow for a single thruster to be used for multiple axes"), or an axis direction
        no jet provides (some rate cases could then never be commanded).
    """
    raw = _read_raw(path, "table2_jet_map.csv")
    _check_columns(raw, ("jet", *SIGN_COLUMNS))
    jets = _index_column(raw, "jet", N_JETS, "jet")
    jmap = np.zeros((N_JETS, 3), dtype=int)
    for i, jet in enumerate(jets):
        for a, col in enumerate(SIGN_COLUMNS):
            v = _number(raw, i, col, jet=jet)
            if v not in (-1.0, 0.0, 1.0):
                raise _error(raw.file, "sign must be -1, 0 or 1", row=i + 1, jet=jet,
                             column=col, value=raw.cell(i, col))
            jmap[jet - 1, a] = int(v)
        if np.count_nonzero(jmap[jet - 1]) > 1:
            col = SIGN_COLUMNS[int(np.flatnonzero(jmap[jet - 1])[1])]
            raise _error(raw.file, "jet gives torque on more than one axis", row=i + 1,
                         jet=jet, column=col, value=raw.cell(i, col))
    for a, col in enumerate(SIGN_COLUMNS):
        for s in (-1, 1):
            if not np.any(jmap[:, a] == s):
                raise _error(raw.file, f"no jet gives {s:+d} {AXES[a]} torque", column=col)
    return jmap


def load_rate_cases(
    path: PathLike | None = None, *, total_rate_deg_s: float | None = PAPER_TOTAL_RATE_DEG_S
) -> RateCases:
    """Load the 26 rate-command cases (paper Table 3).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``case, roll_deg_s, pitch_deg_s, yaw_deg_s`` (deg/s).  Default: the
        packaged (corrected) ``table3_rate_cases.csv``.
    total_rate_deg_s : float or None
        Required total rate ``|(roll, pitch, yaw)|`` of every case, deg/s, within
        ``RATE_RTOL`` relative.  Default 0.3 (paper section II).  None only requires all cases
        to share one total rate.

    Returns
    -------
    RateCases
        ``case`` (26,) = 1..26 and ``rate_cmd`` (26, 3) in rad/s.

    Raises
    ------
    models.errors.InputError
        Missing/unknown column; bad cell; case numbers not exactly 1..26; an all-zero row;
        a row whose sign pattern is not its case's roll-major pattern (see
        :func:`sign_patterns`), e.g. a duplicate of another case; unequal magnitudes on the
        nonzero axes; a total rate off the required one.
    """
    raw = _read_raw(path, "table3_rate_cases.csv")
    _check_columns(raw, ("case", *RATE_COLUMNS))
    case = _index_column(raw, "case", N_CASES, "case")
    rate = np.array(
        [[_number(raw, i, col, case=case[i]) for col in RATE_COLUMNS] for i in range(len(case))]
    )
    order = np.argsort(case)
    case, rate, rows = case[order], rate[order], order + 1
    _check_rate_rows(raw.file, rows, case, rate, total_rate_deg_s=total_rate_deg_s,
                     roll_major=True, equal_split=True)
    return RateCases(case=case, rate_cmd=np.deg2rad(rate))


def load_lookup_table(
    path: PathLike | None = None,
    *,
    which: str = "table7",
    rate_cases: RateCases | None = None,
    jet_map: np.ndarray | None = None,
    cycle_s: float | None = CONTROL_CYCLE_S,
    total_rate_deg_s: float | None = None,
) -> LookupTable:
    """Load and cross-check a firing-time lookup table (paper Tables 6/7 or an rcsim table).

    Two layouts are accepted, told apart by the presence of rate columns:

    * paper layout: ``case, jet_NN ...`` with one column per jet the jet map uses (for the
      paper, jets 1-4 and 9-16); unused jets are set to 0 and the rate commands are joined
      from ``rate_cases`` by case number;
    * rcsim layout (what :meth:`LookupTable.to_csv` writes): ``case, roll_deg_s, pitch_deg_s,
      yaw_deg_s, jet_01 ... jet_16``; rates come from the file and must be distinct sign
      patterns with one common total rate.

    Firing times are in seconds in both layouts.

    Parameters
    ----------
    path : str or os.PathLike, optional
        The CSV to read.  Default: the packaged paper table chosen by ``which``.
    which : {"table7", "table6"}
        Packaged table when ``path`` is None: "table6" = the paper's original lookup table
        (Appendix A), "table7" = the Monte-Carlo-updated one (Appendix B).  Ignored when
        ``path`` is given.
    rate_cases : RateCases, optional
        Rate commands for the paper layout.  Default: :func:`load_rate_cases` ().
    jet_map : array_like of int, shape (16, 3), optional
        Jet map for the cross-check.  Default: :func:`load_jet_map` ().
    cycle_s : float or None
        Control cycle, s (default 0.040, paper section II); firing times must be whole
        multiples of it.  None skips that check.
    total_rate_deg_s : float or None
        rcsim layout only: required total rate per case, deg/s (None: one common total).

    Returns
    -------
    LookupTable
        ``case`` (26,), ``rate_cmd`` (26, 3) rad/s, ``firing_time_s`` (26, 16) s, sorted by
        case.

    Raises
    ------
    models.errors.InputError
        Unknown ``which``; missing/unknown column; empty, non-numeric or negative cell; case
        numbers not exactly 1..26; rates that are not distinct nonzero sign patterns; or any
        rule of :func:`check_consistency` broken.
    """
    if which not in _PACKAGED_LOOKUP:
        raise InputError(f"which={which!r}: expected one of {', '.join(_PACKAGED_LOOKUP)}")
    if jet_map is None:
        jet_map = load_jet_map()
    jmap = np.asarray(jet_map, dtype=int)
    if jmap.shape != (N_JETS, 3):
        raise InputError(f"jet_map: expected shape ({N_JETS}, 3), got {jmap.shape}")
    raw = _read_raw(path, _PACKAGED_LOOKUP[which])
    rcsim = any(c in raw.header for c in RATE_COLUMNS)
    used = [JET_COLUMNS[j] for j in range(N_JETS) if jmap[j].any()]
    if rcsim:
        _check_columns(raw, ("case", *RATE_COLUMNS, *JET_COLUMNS), " (rcsim layout)")
        jet_cols = list(JET_COLUMNS)
    else:
        _check_columns(
            raw, ("case", *used),
            " (paper layout: only jets the jet map uses; add roll_deg_s, pitch_deg_s, "
            "yaw_deg_s and all 16 jets for the rcsim layout)",
        )
        jet_cols = used
    case = _index_column(raw, "case", N_CASES, "case")
    times = np.zeros((N_CASES, N_JETS))
    for i in range(N_CASES):
        for col in jet_cols:
            times[i, JET_COLUMNS.index(col)] = _number(raw, i, col, case=case[i], minimum=0.0)
    order = np.argsort(case)
    case, times, rows = case[order], times[order], order + 1
    if rcsim:
        rate_deg = np.array(
            [[_number(raw, i, col, case=case_i) for col in RATE_COLUMNS]
             for i, case_i in zip(order, case)]
        )
        _check_rate_rows(raw.file, rows, case, rate_deg, total_rate_deg_s=total_rate_deg_s,
                         roll_major=False, equal_split=False)
        rate = np.deg2rad(rate_deg)
    else:
        if rate_cases is None:
            rate_cases = load_rate_cases()
        lookup = {int(c): k for k, c in enumerate(rate_cases.case)}
        rate = np.array([rate_cases.rate_cmd[lookup[int(c)]] for c in case])
    check_consistency(case, rate, times, jmap, file=raw.file, rows=rows, cycle_s=cycle_s)
    return LookupTable(case=case, rate_cmd=rate, firing_time_s=times, source=raw.file)


def paper_corrections(path: PathLike | None = None) -> list[Correction]:
    """The cells where the packaged tables differ from the paper as printed.

    Read from ``models/data/corrections.csv`` -- the same file ``SOURCES.md`` documents -- so
    the code, the data and the note cannot drift apart.

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``file, case, column, paper_value, corrected_value, reason``.
        Default: the packaged ``corrections.csv``.

    Returns
    -------
    list of Correction
        In file order.  Values are in the unit of the corrected column.

    Raises
    ------
    models.errors.InputError
        Missing/unknown column, bad number, empty reason.
    """
    raw = _read_raw(path, "corrections.csv")
    _check_columns(raw, ("file", "case", "column", "paper_value", "corrected_value", "reason"))
    out = []
    for i in range(len(raw.rows)):
        for col in ("file", "column", "reason"):
            if raw.cell(i, col) == "":
                raise _error(raw.file, "empty cell", row=i + 1, column=col)
        out.append(
            Correction(
                file=raw.cell(i, "file"),
                case=_integer(raw, i, "case"),
                column=raw.cell(i, "column"),
                paper_value=_number(raw, i, "paper_value"),
                corrected_value=_number(raw, i, "corrected_value"),
                reason=raw.cell(i, "reason"),
            )
        )
    return out
