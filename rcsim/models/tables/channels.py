"""Axis channels of a lookup table for a vehicle whose jets torque several axes, and their recipes.

The paper's lookup logic (Gambone sec. II) needs each table column to turn the vehicle about one
axis in one direction (its Table 2: a jet pair per axis and sign); sec. IV names the limit ("does
not allow for a single thruster to be used for multiple axes").  For a coupled layout the table's
columns are six *channels*, ``+roll, -roll, +pitch, -pitch, +yaw, -yaw`` (:data:`CHANNELS`),
and each channel has a *recipe*: the on-time fraction of every jet (each in ``[0, 1]``, the
longest 1) that makes a pure rate change about the channel's axis, coupled torque and
translation cancelled at least propellant (solved by :mod:`rcsim.lookup.channels` with the
allocator's LP).  A channel fired for ``t`` seconds fires jet ``j`` for ``fraction[j] * t``.

A channel table is a :class:`~rcsim.models.tables.LookupTable` with six columns
(:data:`CHANNEL_COLUMNS`) and a :class:`ChannelRecipe`; on disk the table CSV (``case, roll_deg_s,
pitch_deg_s, yaw_deg_s, plus_roll ... minus_yaw``) and, beside it, ``<table stem>_recipe.csv`` (one
row per channel: the jet fractions, the channel's nominal angular acceleration, and the vehicle file
it was solved for with its SHA-256, the jets off and the minimum on-time).  This module holds that
data and its file format; it knows no vehicle model (the bottom layer).
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rcsim.models.atomic import atomic_write
from rcsim.models.errors import InputError
from rcsim.models.tables.constants import AXES
from rcsim.models.tables.schema import PathLike, cell_error, read_raw

#: The six channels, in column order: +roll, -roll, +pitch, -pitch, +yaw, -yaw.
CHANNELS = tuple(f"{s}{axis}" for axis in AXES for s in ("+", "-"))
#: Their CSV column names (``+`` and ``-`` are awkward at the start of a spreadsheet cell).
CHANNEL_COLUMNS = tuple(f"{w}_{axis}" for axis in AXES for w in ("plus", "minus"))
#: The channels' "jet map" (6, 3): the axis and sign each channel turns (Table 2's role).
CHANNEL_MAP = np.array(
    [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=int
)
#: Tolerance on "the longest fraction is 1" and "a fraction is in [0, 1]" (fractions are read
#: from ``repr`` text: exact to the last bit; 1e-9 also accepts hand-rounded files).
FRACTION_ATOL = 1e-9
_SHA = re.compile(r"^[0-9a-f]{64}$")


def channel_name(index: int) -> str:
    """``"+yaw"`` for channel 4: how reports and messages name a channel."""
    return CHANNELS[index]


@dataclass(frozen=True, eq=False)
class ChannelRecipe:
    """How each channel of a channel table fires the vehicle's jets.

    Attributes
    ----------
    fractions : ndarray, (6, n_jets)
        On-time of jet ``j`` per second of channel ``k`` (in ``[0, 1]``; a served channel's
        longest is 1, an unserved one -- no jet combination left turns that way -- is all 0).
    accel_rad_s2 : ndarray, (6, 3)
        Nominal body angular acceleration of each channel fired at its recipe [rad/s^2]
        (roll, pitch, yaw; the off-axis components are the LP's zero, to its tolerance).
    vehicle : str
        The vehicle file the recipe was solved for: a packaged name or an absolute path.
    vehicle_sha256 : str
        SHA-256 of that file when the recipe was solved (a changed file is refused).
    jets_off : tuple of int
        Jets (1-based) the recipe may not use (``rcsim lookup generate --jets-off``).
    min_on_s : float
        The vehicle's minimum on-time [s] (a new pulse shorter than this is not made; the
        channel delivery owes short shares until they reach it).
    source : str
        Where the recipe was read from (messages); ``""`` if built in memory.
    """

    fractions: np.ndarray
    accel_rad_s2: np.ndarray
    vehicle: str
    vehicle_sha256: str
    jets_off: tuple = ()
    min_on_s: float = 0.0
    source: str = ""

    def __post_init__(self) -> None:
        frac = np.array(self.fractions, float)
        if frac.ndim != 2 or frac.shape[0] != len(CHANNELS) or frac.shape[1] < 1:
            raise InputError(f"fractions: expected shape (6, n_jets), got {frac.shape}")
        accel = np.array(self.accel_rad_s2, float)
        if accel.shape != (len(CHANNELS), 3):
            raise InputError(f"accel_rad_s2: expected shape (6, 3), got {accel.shape}")
        frac.flags.writeable = False
        accel.flags.writeable = False
        object.__setattr__(self, "fractions", frac)
        object.__setattr__(self, "accel_rad_s2", accel)
        object.__setattr__(self, "jets_off", tuple(int(j) for j in self.jets_off))

    @property
    def n_jets(self) -> int:
        return int(self.fractions.shape[1])

    @property
    def served(self) -> np.ndarray:
        """(6,) bool: the channel fires some jet."""
        return self.fractions.max(axis=1) > 0

    def to_csv(self, path: PathLike) -> Path:
        """Write the recipe CSV atomically (floats as ``repr``: read back bit for bit)."""
        jets = [f"jet_{j + 1:02d}" for j in range(self.n_jets)]
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["channel", *jets, *_ACCEL_COLUMNS, *_META_COLUMNS])
        accel_deg = np.degrees(self.accel_rad_s2)
        for k, name in enumerate(CHANNEL_COLUMNS):
            writer.writerow(
                [name]
                + [repr(float(v)) for v in self.fractions[k]]
                + [repr(float(v)) for v in accel_deg[k]]
                + [
                    self.vehicle,
                    self.vehicle_sha256,
                    " ".join(str(j) for j in self.jets_off),
                    repr(float(self.min_on_s)),
                ]
            )

        def write(tmp: str) -> None:
            with open(tmp, "w", encoding="utf-8", newline="") as fh:
                fh.write(buf.getvalue())
                fh.flush()
                os.fsync(fh.fileno())

        return atomic_write(Path(path), write)


_ACCEL_COLUMNS = tuple(f"{axis}_deg_s2" for axis in AXES)
_META_COLUMNS = ("vehicle", "vehicle_sha256", "jets_off", "min_on_s")


def recipe_path(table: PathLike) -> Path:
    """``<dir>/<stem>_recipe.csv``: where a channel table's recipe lives."""
    p = Path(table)
    return p.with_name(f"{p.stem}_recipe.csv")


def is_channel_header(header) -> bool:
    """Whether a table CSV's header names channel columns (a channel table)."""
    return any(c in header for c in CHANNEL_COLUMNS)


def is_channel_table(table) -> bool:
    """Whether the CSV at ``table`` (a path; anything else: False) is a channel table, by its
    header.  A file that cannot be read is not one: the table loader reports why."""
    if not isinstance(table, (str, os.PathLike)):
        return False
    try:
        with open(table, encoding="utf-8-sig", newline="") as fh:
            for line in fh:
                if line.strip():
                    header = next(csv.reader([line]), [])
                    return is_channel_header([c.strip() for c in header])
    except (OSError, UnicodeDecodeError):
        return False
    return False


def load_recipe(path: PathLike, *, table: str | None = None) -> ChannelRecipe:
    """Read and check a recipe CSV (:meth:`ChannelRecipe.to_csv`'s layout).

    Parameters
    ----------
    path : path
        The recipe file.
    table : str, optional
        The table it belongs to, for the message when the file is missing.

    Raises
    ------
    InputError
        Missing file (named with the table that needs it), missing/unknown column, channel
        rows not exactly the six, a fraction outside ``[0, 1]``, a served channel whose longest
        fraction is not 1, a fraction on a jet the recipe says is off, metadata that differs
        between rows, a malformed SHA-256 or minimum on-time.
    """
    if table is not None and not Path(path).is_file():
        raise InputError(
            f"{table}: a channel table (columns {', '.join(CHANNEL_COLUMNS)}) loads only with "
            f"its recipe {Path(path).name} beside it (written by `rcsim lookup generate`); "
            f"{path} not found"
        )
    raw = read_raw(path, "")
    file = raw.file
    header = raw.header
    jets = [c for c in header if c.startswith("jet_")]
    n = len(jets)
    expect = ["channel", *(f"jet_{j + 1:02d}" for j in range(n)), *_ACCEL_COLUMNS, *_META_COLUMNS]
    if n == 0 or header != expect:
        raise cell_error(
            file,
            "wrong columns; expected channel, jet_01 ... jet_NN, "
            f"{', '.join(_ACCEL_COLUMNS)}, {', '.join(_META_COLUMNS)}",
            row="header",
            value=",".join(header),
        )
    names = [r[0] for r in raw.rows]
    if sorted(names) != sorted(CHANNEL_COLUMNS) or len(names) != len(CHANNEL_COLUMNS):
        raise cell_error(
            file,
            f"channel rows must be exactly {', '.join(CHANNEL_COLUMNS)}",
            column="channel",
            value=names,
        )
    frac = np.zeros((len(CHANNELS), n))
    accel = np.zeros((len(CHANNELS), 3))
    meta: dict[str, set] = {c: set() for c in _META_COLUMNS}
    for i, row in enumerate(raw.rows):
        k = CHANNEL_COLUMNS.index(row[0])
        for j, col in enumerate(jets):
            v = _number(raw, i, col)
            if not -FRACTION_ATOL <= v <= 1 + FRACTION_ATOL:
                raise cell_error(
                    file, "on-time fraction outside 0..1", row=i + 1, column=col, value=v
                )
            frac[k, j] = min(max(v, 0.0), 1.0)
        for a, col in enumerate(_ACCEL_COLUMNS):
            accel[k, a] = math.radians(_number(raw, i, col))
        for c in _META_COLUMNS:
            meta[c].add(raw.cell(i, c))
        longest = float(frac[k].max())
        if longest > 0 and abs(longest - 1.0) > FRACTION_ATOL:
            raise cell_error(
                file,
                f"channel {row[0]}: its longest fraction must be 1 (the channel's time is its "
                "longest jet's)",
                row=i + 1,
                column=jets[int(frac[k].argmax())],
                value=longest,
            )
    for c, values in meta.items():
        if len(values) != 1:
            raise cell_error(file, "must be the same on every row", column=c, value=sorted(values))
    vehicle, sha, off_text, min_on_text = (meta[c].pop() for c in _META_COLUMNS)
    if not vehicle:
        raise cell_error(
            file, "empty: the vehicle file the recipe was solved for", column="vehicle"
        )
    if not _SHA.match(sha):
        raise cell_error(file, "not a SHA-256 (64 hex digits)", column="vehicle_sha256", value=sha)
    try:
        jets_off = tuple(int(j) for j in off_text.split())
    except ValueError:
        raise cell_error(
            file, "jet numbers separated by spaces expected", column="jets_off", value=off_text
        ) from None
    bad = [j for j in jets_off if not 1 <= j <= n]
    if bad or len(set(jets_off)) != len(jets_off):
        raise cell_error(
            file, f"jet numbers 1..{n}, each once, expected", column="jets_off", value=off_text
        )
    on_off = [j for j in jets_off if frac[:, j - 1].any()]
    if on_off:
        raise cell_error(
            file,
            f"jet {on_off[0]} is off (column jets_off) but a channel fires it",
            column=f"jet_{on_off[0]:02d}",
        )
    try:
        min_on = float(min_on_text)
    except ValueError:
        min_on = math.nan
    if not (math.isfinite(min_on) and 0 <= min_on < 1):
        raise cell_error(file, "a time in 0..1 s expected", column="min_on_s", value=min_on_text)
    return ChannelRecipe(
        fractions=frac,
        accel_rad_s2=accel,
        vehicle=vehicle,
        vehicle_sha256=sha,
        jets_off=jets_off,
        min_on_s=min_on,
        source=file,
    )


def _number(raw, i: int, column: str) -> float:
    text = raw.cell(i, column)
    try:
        value = float(text)
    except ValueError:
        raise cell_error(raw.file, "not a number", row=i + 1, column=column, value=text) from None
    if not math.isfinite(value):
        raise cell_error(raw.file, "NaN/infinite value", row=i + 1, column=column, value=text)
    return value
