"""Jet firing-time lookup tables (paper Tables 6 and 7, or one rcsim generated):
:class:`LookupTable`, :func:`load_lookup_table`, and the names of the packaged paper tables.

A table's columns are the 16 jets of the paper's vehicle, or, for a vehicle whose jets torque
several axes, six axis channels with their recipe (:mod:`rcsim.models.tables.channels`)."""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np

from rcsim.models.atomic import atomic_write
from rcsim.models.errors import InputError
from rcsim.models.tables.channels import (
    CHANNEL_COLUMNS,
    CHANNEL_MAP,
    ChannelRecipe,
    is_channel_header,
    load_recipe,
    recipe_path,
)
from rcsim.models.tables.consistency import check_consistency
from rcsim.models.tables.constants import (
    JET_COLUMNS,
    MAX_FIRING_TIME_S,
    N_CASES,
    N_JETS,
    PAPER_CYCLE_S,
    RATE_COLUMNS,
)
from rcsim.models.tables.jet_map import load_jet_map
from rcsim.models.tables.rate_cases import RateCases, check_rate_rows, load_rate_cases
from rcsim.models.tables.schema import (
    PathLike,
    check_columns,
    frozen_array,
    index_column,
    number,
    packaged,
    read_raw,
)

if TYPE_CHECKING:  # importlib.resources.abc is 3.11+; only the annotation needs it
    from importlib.resources.abc import Traversable

#: The paper's lookup tables shipped with rcsim, by name -> packaged file.  A name is accepted
#: wherever a lookup-table path is (``load_lookup_table("table6")``, ``--table table6``, a
#: campaign spec's ``table = "table6"``) and reads the installed package's own copy.
PAPER_LOOKUP_TABLES = MappingProxyType(
    {"table6": "table6_lookup_original.csv", "table7": "table7_lookup_updated.csv"}
)


@dataclass(frozen=True, eq=False)
class LookupTable:
    """A firing-time lookup table (paper Tables 6 and 7), SI: all 16 jets, or six channels.

    Attributes
    ----------
    case : numpy.ndarray of int, shape (26,)
        Case numbers 1..26, ascending.
    rate_cmd : numpy.ndarray of float, shape (26, 3)
        Rate command [roll, pitch, yaw] each row was designed for, rad/s.
    firing_time_s : numpy.ndarray of float, shape (26, 16), or (26, 6) with a recipe
        Firing time of jets 1..16 per case, s; jets that do not fire (including the unused
        translation jets 5-8) are 0.  A channel table: firing time of each channel
        (:data:`~rcsim.models.tables.channels.CHANNELS`), s.
    source : str
        Where the table was read from (for messages); ``""`` if built in memory.
    recipe : ChannelRecipe, optional
        A channel table's recipe (how each channel fires the vehicle's jets); None for a jet
        table.

    Notes
    -----
    Construction checks shapes only; :func:`load_lookup_table` and
    :func:`~rcsim.models.tables.check_consistency` check the content.
    """

    case: np.ndarray
    rate_cmd: np.ndarray
    firing_time_s: np.ndarray
    source: str = ""
    recipe: ChannelRecipe | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "case", frozen_array(self.case, int, (N_CASES,), "case"))
        object.__setattr__(
            self, "rate_cmd", frozen_array(self.rate_cmd, float, (N_CASES, 3), "rate_cmd")
        )
        object.__setattr__(
            self,
            "firing_time_s",
            frozen_array(self.firing_time_s, float, (N_CASES, len(self.columns)), "firing_time_s"),
        )

    @property
    def columns(self) -> tuple:
        """The table's firing-time column names: ``jet_01 ... jet_16`` or the six channels'."""
        return JET_COLUMNS if self.recipe is None else CHANNEL_COLUMNS

    @property
    def is_channel(self) -> bool:
        """A channel table (six axis channels and a recipe), not a jet table."""
        return self.recipe is not None

    def to_csv(self, path: PathLike, *, with_recipe: bool = True) -> Path:
        """Write the table in the rcsim layout, atomically.

        Columns: ``case, roll_deg_s, pitch_deg_s, yaw_deg_s, jet_01 ... jet_16`` (rates in
        deg/s, firing times in s); a channel table has the six channel columns instead and
        writes its recipe first, beside it (``<stem>_recipe.csv``), so that a table on disk
        always has its recipe.  Floats are written with ``repr`` so that reading the file
        back gives the same doubles (rates up to the rad<->deg conversion, a few ulp).

        The file is written to a temporary file in the target directory and moved into place
        (:func:`rcsim.models.atomic.atomic_write`), so a crash never leaves a half-written
        table that a later campaign could load.

        Parameters
        ----------
        path : str or os.PathLike
            Destination file.
        with_recipe : bool
            Write a channel table's recipe too (False: the caller writes it, e.g. with the
            table in one commit, :func:`rcsim.analysis.engine.commit.commit_files`).

        Returns
        -------
        pathlib.Path
            The written path.
        """
        rates_deg = np.rad2deg(self.rate_cmd)
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["case", *RATE_COLUMNS, *self.columns])
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

        if self.recipe is not None and with_recipe:
            self.recipe.to_csv(recipe_path(path))
        return atomic_write(Path(path), write)


def lookup_table_source(table: PathLike | Traversable) -> Path | Traversable:
    """Where a lookup table named by ``table`` is read from.

    Parameters
    ----------
    table : str, os.PathLike or Traversable
        A name of :data:`PAPER_LOOKUP_TABLES` (``"table6"``, ``"table7"``: the installed
        package's own copy) or a path to a CSV file.

    Returns
    -------
    pathlib.Path or importlib.resources.abc.Traversable
        The file to read (existence is not checked: the loader reports a missing file).

    Raises
    ------
    rcsim.models.errors.InputError
        ``table`` is a paper-table name and also a file in the current directory (ambiguous:
        write ``./table6`` for the file).
    """
    if not isinstance(table, (str, os.PathLike)):
        return table  # already a resource
    name = os.fspath(table)
    if name in PAPER_LOOKUP_TABLES:
        if Path(name).exists():  # never silently prefer one over the other
            raise InputError(
                f"{name}: ambiguous: both the packaged paper table '{name}' and a file in the "
                f"current directory; write ./{name} for the file"
            )
        return packaged(PAPER_LOOKUP_TABLES[name])
    return Path(table)


def load_lookup_table(
    path: PathLike | Traversable | None = None,
    *,
    which: str = "table7",
    rate_cases: RateCases | None = None,
    jet_map: np.ndarray | None = None,
    cycle_s: float | None = PAPER_CYCLE_S,
    total_rate_deg_s: float | None = None,
    max_firing_time_s: float | None = MAX_FIRING_TIME_S,
) -> LookupTable:
    """Load and cross-check a firing-time lookup table (paper Tables 6/7 or an rcsim table).

    Two layouts are accepted, told apart by the presence of rate columns:

    * paper layout: ``case, jet_NN ...`` with one column per jet the jet map uses (for the
      paper, jets 1-4 and 9-16); unused jets are set to 0 and the rate commands are joined
      from ``rate_cases`` by case number;
    * rcsim layout (what :meth:`LookupTable.to_csv` writes): ``case, roll_deg_s, pitch_deg_s,
      yaw_deg_s, jet_01 ... jet_16``; rates come from the file and must be distinct sign
      patterns with one common total rate.

    Firing times are in seconds in both layouts.  Both are checked against physical ranges,
    so a well-formed table in the wrong unit is refused: every total rate within
    ``RATE_TOTAL_MIN_DEG_S .. RATE_TOTAL_MAX_DEG_S`` (0.03..3 deg/s, a factor of ten around
    Table 3's 0.3 deg/s: rad/s under a deg/s header is 57x too small), every firing time a
    whole number of 40 ms cycles and at most ``max_firing_time_s`` (5 s).

    Parameters
    ----------
    path : str, os.PathLike or Traversable, optional
        The CSV to read, or the name ``"table6"`` / ``"table7"`` of a packaged paper table
        (see :func:`lookup_table_source`).  Default: the packaged paper table chosen by
        ``which``.
    which : {"table7", "table6"}
        Packaged table when ``path`` is None: "table6" = the paper's original lookup table
        (Appendix A), "table7" = the Monte-Carlo-updated one (Appendix B).  Ignored when
        ``path`` is given.
    rate_cases : RateCases, optional
        Rate commands for the paper layout.  Default: :func:`load_rate_cases` ().
    jet_map : array_like of int, shape (16, 3), optional
        Jet map for the cross-check.  Default: :func:`load_jet_map` ().
    cycle_s : float or None
        Control cycle, s (default ``PAPER_CYCLE_S`` = 0.040, paper section II); firing times
        must be whole multiples of it.  None skips that check.
    total_rate_deg_s : float or None
        rcsim layout only: required total rate per case, deg/s (None: one common total).
    max_firing_time_s : float or None
        Longest allowed firing time, s (default ``MAX_FIRING_TIME_S`` = 5 s).  None skips it.

    Returns
    -------
    LookupTable
        ``case`` (26,), ``rate_cmd`` (26, 3) rad/s, ``firing_time_s`` (26, 16) s, sorted by
        case.

    Raises
    ------
    rcsim.models.errors.InputError
        Unknown ``which``; missing file; missing/unknown column; empty, non-numeric or
        negative cell; case numbers not exactly 1..26; rates that are not distinct nonzero
        sign patterns or lie outside the physical range; or any rule of
        :func:`~rcsim.models.tables.check_consistency` broken.
    """
    if which not in PAPER_LOOKUP_TABLES:
        raise InputError(f"which={which!r}: expected one of {', '.join(PAPER_LOOKUP_TABLES)}")
    if jet_map is None:
        jet_map = load_jet_map()
    jmap = np.asarray(jet_map, dtype=int)
    if jmap.shape != (N_JETS, 3):
        raise InputError(f"jet_map: expected shape ({N_JETS}, 3), got {jmap.shape}")
    src = packaged(PAPER_LOOKUP_TABLES[which]) if path is None else lookup_table_source(path)
    raw = read_raw(src, PAPER_LOOKUP_TABLES[which])
    rcsim = any(c in raw.header for c in RATE_COLUMNS)
    all_cols = JET_COLUMNS
    recipe = None
    if is_channel_header(raw.header):
        # A channel table: its columns turn one axis each by construction; its recipe (beside
        # it) says how each fires the jets, and unserved channels must never fire.
        check_columns(raw, ("case", *RATE_COLUMNS, *CHANNEL_COLUMNS), " (channel table)")
        recipe = load_recipe(recipe_path(raw.file), table=raw.file)
        jmap = CHANNEL_MAP * recipe.served[:, None]
        all_cols = CHANNEL_COLUMNS
    if recipe is not None:
        jet_cols = list(CHANNEL_COLUMNS)
    elif rcsim:
        check_columns(raw, ("case", *RATE_COLUMNS, *JET_COLUMNS), " (rcsim layout)")
        jet_cols = list(JET_COLUMNS)
    else:
        used = [JET_COLUMNS[j] for j in range(N_JETS) if jmap[j].any()]
        check_columns(
            raw,
            ("case", *used),
            " (paper layout: only jets the jet map uses; add roll_deg_s, pitch_deg_s, "
            "yaw_deg_s and all 16 jets for the rcsim layout)",
        )
        jet_cols = used
    case = index_column(raw, "case", N_CASES, "case")
    times = np.zeros((N_CASES, len(all_cols)))
    for i in range(N_CASES):
        for col in jet_cols:
            times[i, all_cols.index(col)] = number(raw, i, col, case=case[i], minimum=0.0)
    order = np.argsort(case)
    case, times, rows = case[order], times[order], order + 1
    if rcsim:
        rate_deg = np.array(
            [
                [number(raw, i, col, case=case_i) for col in RATE_COLUMNS]
                for i, case_i in zip(order, case)
            ]
        )
        check_rate_rows(
            raw.file,
            rows,
            case,
            rate_deg,
            total_rate_deg_s=total_rate_deg_s,
            roll_major=False,
            equal_split=False,
        )
        rate = np.deg2rad(rate_deg)
    else:
        if rate_cases is None:
            rate_cases = load_rate_cases()
        lookup = {int(c): k for k, c in enumerate(rate_cases.case)}
        rate = np.array([rate_cases.rate_cmd[lookup[int(c)]] for c in case])
    check_consistency(
        case,
        rate,
        times,
        jmap,
        file=raw.file,
        rows=rows,
        cycle_s=cycle_s,
        max_firing_time_s=max_firing_time_s,
        columns=all_cols,
    )
    return LookupTable(
        case=case, rate_cmd=rate, firing_time_s=times, source=raw.file, recipe=recipe
    )
