"""The validation core shared by every table loader: CSV reading, cell parsing, units, errors.

Every failure is a :class:`rcsim.models.errors.InputError` whose one-line message names the
file, the row (1-based data row, plus the case or jet number when known), the column and the
bad value, so an analyst can go straight to the cell.  Nothing here knows a table family; the
family modules (``mass_properties``, ``jet_map``, ...) say which columns and parameters they
need.  Internal to :mod:`rcsim.models.tables`: other packages use the loaders, not these.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rcsim.models.errors import InputError

if TYPE_CHECKING:  # importlib.resources.abc is 3.11+; only the annotation needs it
    from importlib.resources.abc import Traversable

PathLike = str | os.PathLike

# Unit string -> (physical dimension, factor to SI).  Long tables carry their unit per row, so
# a user file in other units (lbf, ms, rad) converts instead of silently being misread.
UNITS: dict[str, tuple[str, float]] = {
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
SI_UNIT = {
    "mass": "kg",
    "length": "m",
    "inertia": "kg*m^2",
    "force": "N",
    "angle": "rad",
    "angular_rate": "rad/s",
    "time": "s",
}

_NO_VALUE = object()


def frozen_array(values, dtype, shape: tuple[int, ...], what: str) -> np.ndarray:
    """A read-only copy of ``values`` with the given dtype, checked to have ``shape``."""
    arr = np.array(values, dtype=dtype)  # a copy: callers cannot mutate our state through it
    if arr.shape != shape:
        raise InputError(f"{what}: expected shape {shape}, got {arr.shape}")
    arr.flags.writeable = False
    return arr


def where(file: str, row=None, column=None, case=None, jet=None) -> str:
    """``"file, row 3 (case 2), column 'x'"``: the location part of a message."""
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


def cell_error(file, problem, *, row=None, column=None, case=None, jet=None, value=_NO_VALUE):
    """An :class:`InputError` ``"<where>: <problem> (got <value>)"`` on one line."""
    msg = f"{where(file, row, column, case, jet)}: {problem}"
    if value is not _NO_VALUE:
        msg += f" (got {value!r})"
    return InputError(msg.replace("\n", " "))


@dataclass
class RawTable:
    """A CSV file as stripped strings; ``rows[i]`` is 1-based data row ``i + 1``."""

    file: str
    header: list[str]
    rows: list[list[str]]

    def cell(self, i: int, column: str) -> str:
        return self.rows[i][self.header.index(column)]


def packaged(name: str) -> Traversable:
    """The installed package's own copy of data file ``name`` (``rcsim/models/data/<name>``)."""
    return files("rcsim.models") / "data" / name


def read_raw(path: PathLike | Traversable | None, default_name: str) -> RawTable:
    """Read a CSV (``path``, or the packaged ``default_name`` if None) into a :class:`RawTable`.

    A UTF-8 byte-order mark is accepted (spreadsheet programs put one on exported CSV); blank
    lines are skipped; a short row is padded with empty cells so the empty-cell check names the
    first missing column; a long row is refused.
    """
    if path is None:
        src = packaged(default_name)
    elif isinstance(path, (str, os.PathLike)):
        src = Path(path)
    else:  # a Traversable, e.g. a packaged copy from importlib.resources
        src = path
    label = str(src)
    try:
        # utf-8-sig: tolerate the byte-order mark spreadsheet programs put on exported CSV.
        with src.open("r", encoding="utf-8-sig", newline="") as fh:  # type: ignore[call-overload]
            text = fh.read()
    except FileNotFoundError:
        raise InputError(f"{label}: file not found") from None
    except IsADirectoryError:
        raise InputError(f"{label}: is a directory, not a CSV file") from None
    except PermissionError:
        raise InputError(f"{label}: permission denied (cannot read the file)") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{label}: not UTF-8 text ({exc.reason})") from None
    except OSError as exc:  # e.g. a FIFO or a vanished network mount: an OS refusal, not a bug
        raise InputError(f"{label}: cannot read ({exc.strerror or exc})") from None
    records = [r for r in csv.reader(io.StringIO(text)) if any(c.strip() for c in r)]
    if not records:
        raise InputError(f"{label}: empty file (no header row)")
    header = [c.strip() for c in records[0]]
    rows = []
    for i, rec in enumerate(records[1:], start=1):
        cells = [c.strip() for c in rec]
        if len(cells) > len(header):
            raise cell_error(
                label,
                f"{len(cells)} fields but the header has {len(header)}",
                row=i,
                column=f"<extra field {len(header) + 1}>",
                value=cells[len(header)],
            )
        rows.append(cells + [""] * (len(header) - len(cells)))
    if not rows:
        raise InputError(f"{label}: no data rows")
    return RawTable(label, header, rows)


def check_columns(raw: RawTable, required: Sequence[str], hint: str = "") -> None:
    """Refuse empty, duplicate, missing or unknown column names (the header is exactly
    ``required``, in any order)."""
    seen = set()
    for name in raw.header:
        if name == "":
            raise cell_error(raw.file, "empty column name", row="header", column=name)
        if name in seen:
            raise cell_error(raw.file, "duplicate column", row="header", column=name)
        seen.add(name)
    expected = f"expected columns {', '.join(required)}{hint}"
    for name in required:
        if name not in seen:
            raise cell_error(raw.file, f"missing column; {expected}", row="header", column=name)
    for name in raw.header:
        if name not in required:
            raise cell_error(raw.file, f"unknown column; {expected}", row="header", column=name)


def number(
    raw: RawTable, i: int, column: str, *, case=None, jet=None, minimum=None, strict=False
) -> float:
    """Parse cell (row ``i`` 0-based, ``column``) as a finite float, optionally bounded below
    (``> minimum`` if ``strict`` else ``>= minimum``)."""
    text = raw.cell(i, column)
    loc = dict(row=i + 1, column=column, case=case, jet=jet)
    if text == "":
        raise cell_error(raw.file, "empty cell", **loc)
    try:
        value = float(text)
    except ValueError:
        raise cell_error(raw.file, "not a number", value=text, **loc) from None
    if not math.isfinite(value):
        raise cell_error(raw.file, "NaN/infinite value", value=text, **loc)
    if minimum is not None and (value <= minimum if strict else value < minimum):
        bound = f"> {minimum:g}" if strict else f">= {minimum:g}"
        raise cell_error(raw.file, f"wrong sign: must be {bound}", value=text, **loc)
    return value


def integer(raw: RawTable, i: int, column: str, *, case=None) -> int:
    """Parse a cell as an integer (``3`` or ``3.0``; not ``3.5``)."""
    value = number(raw, i, column, case=case)
    if value != int(value):
        raise cell_error(
            raw.file, "not an integer", row=i + 1, column=column, value=raw.cell(i, column)
        )
    return int(value)


def index_column(raw: RawTable, column: str, count: int, what: str) -> np.ndarray:
    """Parse a 1..count numbering column; every number exactly once.  Returns the numbers in
    file order, shape (count,)."""
    numbers = []
    first_row: dict[int, int] = {}
    for i in range(len(raw.rows)):
        n = integer(raw, i, column)
        if not 1 <= n <= count:
            raise cell_error(
                raw.file,
                f"{what} number outside 1..{count} (the table has exactly {count} {what}s)",
                row=i + 1,
                column=column,
                value=raw.cell(i, column),
            )
        if n in first_row:
            raise cell_error(
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
        raise cell_error(
            raw.file,
            f"wrong shape: {what} {missing[0]} missing (need {what}s 1..{count}, got "
            f"{len(raw.rows)} rows)",
            case=missing[0] if what == "case" else None,
            column=column,
        )
    return np.array(numbers, dtype=int)


def unit_factor(raw: RawTable, i: int, column: str, dimension: str | None) -> float:
    """Factor to SI of the unit in cell (``i``, ``column``); refuse an unknown unit or one of
    another dimension than ``dimension`` (None: any known unit)."""
    unit = raw.cell(i, column)
    if unit not in UNITS:
        raise cell_error(
            raw.file,
            f"unknown unit; known: {', '.join(UNITS)}",
            row=i + 1,
            column=column,
            value=unit,
        )
    unit_dim, factor = UNITS[unit]
    if dimension is not None and unit_dim != dimension:
        raise cell_error(
            raw.file,
            f"unit of {unit_dim} where a {dimension} unit (e.g. {SI_UNIT[dimension]}) is needed",
            row=i + 1,
            column=column,
            value=unit,
        )
    return factor


def long_table(
    path, default_name: str, value_column: str, spec: Mapping[str, tuple[str, bool]]
) -> tuple[RawTable, dict[str, float]]:
    """Read a ``parameter, unit, <value_column>`` table; return SI values keyed by parameter.

    ``spec`` maps each parameter to ``(dimension, must be strictly positive)``; every
    parameter must appear exactly once and no other.
    """
    raw = read_raw(path, default_name)
    check_columns(raw, ("parameter", "unit", value_column))
    out: dict[str, float] = {}
    first_row: dict[str, int] = {}
    for i in range(len(raw.rows)):
        name = raw.cell(i, "parameter")
        if name not in spec:
            raise cell_error(
                raw.file,
                f"unknown parameter; expected {', '.join(spec)}",
                row=i + 1,
                column="parameter",
                value=name,
            )
        if name in first_row:
            raise cell_error(
                raw.file,
                f"duplicate parameter (first on row {first_row[name]})",
                row=i + 1,
                column="parameter",
                value=name,
            )
        first_row[name] = i + 1
        dimension, positive = spec[name]
        factor = unit_factor(raw, i, "unit", dimension)
        value = number(raw, i, value_column, minimum=0.0 if positive else None, strict=positive)
        out[name] = value * factor
    for name in spec:
        if name not in out:
            raise cell_error(raw.file, f"parameter '{name}' missing", column="parameter")
    return raw, out
