"""Which jets a lookup table was made for, recorded beside it, so that a table generated for a
vehicle with failed jets (:func:`rcsim.lookup.table_generation.generate_table` ``jets_off``) loads.

A table for the full vehicle is checked at load against Table 2 (the jet map).  A table
generated without some jets fires none of them, and pairs with one jet left fire that jet
alone: checked against Table 2 it would be refused.  Its companion file
(``<table stem>_settling.csv``, written beside it by ``rcsim lookup generate``) has a
``jets_off`` column; :func:`load_table_for_jets` reads it and checks the table against the jet
map *of the vehicle it was made for* (Table 2 without those jets).

Owns the jet-set rules: which jet sets a table can be made for (:func:`check_jets_off`) and
the jet map of the jets left (:func:`jet_map_without`).  A *channel table* (a vehicle whose jets
torque several axes, :mod:`rcsim.lookup.channels`) records its jets off in its recipe instead, and
is checked against the vehicle it was solved for (:func:`check_table_vehicle`).  Imports
``models``, ``spacecraft`` and :mod:`rcsim.lookup.channels` only.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rcsim.lookup.channels import check_recipe_vehicle
from rcsim.lookup.jet_numbers import jet_numbers
from rcsim.models.errors import InputError
from rcsim.models.tables import (
    LookupTable,
    is_channel_table,
    load_jet_map,
    load_lookup_table,
    load_recipe,
    recipe_path,
)
from rcsim.spacecraft.vehicle.model import AXES, N_JETS

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle


def companion_path(table: str | os.PathLike) -> Path:
    """``<dir>/<stem>_settling.csv`` of a table CSV."""
    p = Path(table)
    return p.with_name(f"{p.stem}_settling.csv")


def jets_off_of(table: str | os.PathLike) -> tuple:
    """Jets (1..16) the table at path ``table`` was generated without, from its companion
    file; ``()`` when there is no companion or it records none.  A channel table's come from
    its recipe (the vehicle's jet numbers)."""
    if is_channel_table(table):
        return load_recipe(recipe_path(table), table=str(table)).jets_off
    comp = companion_path(table)
    if not comp.is_file():
        return ()
    try:
        frame = pd.read_csv(comp, usecols=lambda c: c == "jets_off", dtype=str)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise InputError(f"{comp}: cannot read the table's companion file: {exc}") from None
    if "jets_off" not in frame or frame["jets_off"].isna().all():
        return ()
    values = set(frame["jets_off"].dropna())
    if len(values) != 1:
        raise InputError(f"{comp}: column jets_off: one jet set expected, got {sorted(values)}")
    text = values.pop()
    try:
        return check_jets_off([int(j) for j in text.split()])
    except (ValueError, InputError):
        raise InputError(
            f"{comp}: column jets_off: jet numbers 1..16 separated by spaces expected, got {text!r}"
        ) from None


def load_table_for_jets(
    table: str | os.PathLike, jets_off=None, *, cycle_s: float | None
) -> tuple[LookupTable, tuple]:
    """Load a table CSV checked against the jets of the vehicle it was made for.

    Parameters
    ----------
    table : path
    jets_off : sequence of int, optional
        Default: what the companion file records.
    cycle_s : float or None
        The control cycle its firing times are whole multiples of [s]: the flying vehicle's
        (None: not checked; :func:`rcsim.models.tables.load_lookup_table`).

    Returns
    -------
    (LookupTable, jets_off)

    A channel table loads with its recipe, which records its jets off (``jets_off`` given
    must equal them).
    """
    if is_channel_table(table):
        tab = load_lookup_table(table, cycle_s=cycle_s)
        assert tab.recipe is not None
        if jets_off is not None and tuple(sorted(jets_off)) != tab.recipe.jets_off:
            raise InputError(
                f"{table}: its recipe is for jets {list(tab.recipe.jets_off)} off, not "
                f"{list(jets_off)}",
                parameter="jets_off",
                value=list(jets_off),
            )
        return tab, tab.recipe.jets_off
    jets_off = jets_off_of(table) if jets_off is None else check_jets_off(jets_off)
    if not jets_off:
        try:
            return load_lookup_table(table, cycle_s=cycle_s), ()
        except InputError as exc:
            raise _with_companion_hint(exc, table) from None
    jet_map = jet_map_without(load_jet_map(), jets_off)
    return load_lookup_table(table, jet_map=jet_map, cycle_s=cycle_s), jets_off


def _with_companion_hint(exc: InputError, table) -> InputError:
    """``exc`` plus, when some jets fire in no case of the file, the likely cause: a table
    generated for failed jets (``lookup generate --jets-off``) without its companion file."""

    try:
        frame = pd.read_csv(table, comment="#")
    except Exception:  # the loader's own error already says what is wrong with the file
        return exc
    jets = [c for c in frame.columns if str(c).startswith("jet_")]
    rotating = np.flatnonzero(np.any(load_jet_map() != 0, axis=1)) + 1  # jets 5-8 never do
    silent = [
        c
        for c in jets
        if str(c)[4:].isdigit()
        and int(str(c)[4:]) in rotating
        and pd.to_numeric(frame[c], errors="coerce").fillna(0).eq(0).all()
    ]
    if not silent:
        return exc
    stem = Path(table).stem
    return InputError(
        f"{exc}; {', '.join(silent)} {'fires' if len(silent) == 1 else 'fire'} in no case: "
        f"a table generated with --jets-off loads only with its companion "
        f"{stem}_settling.csv beside it",
        parameter=getattr(exc, "parameter", None),
        value=getattr(exc, "value", None),
    )


def check_jets_off(jets_off) -> tuple:
    """``jets_off`` as a sorted tuple of distinct jet numbers 1..16 that leaves every rotation
    axis at least one jet (a table for an axis without jets commands nothing); InputError
    otherwise."""
    jets = jet_numbers(jets_off, N_JETS)
    torque = load_jet_map()  # (16, 3): the sign of each jet's torque per axis, Table 2
    for a, axis in enumerate(AXES):
        axis_jets = {j + 1 for j in range(N_JETS) if torque[j, a] != 0}
        if axis_jets <= set(jets):
            raise InputError(
                f"every {axis} jet ({', '.join(map(str, sorted(axis_jets)))}) is "
                f"off; no table can control {axis}",
                parameter="jets_off",
                value=list(jets_off),
            )
    return jets


def jet_map_without(jet_map: np.ndarray, jets_off) -> np.ndarray:
    """The jet map with the rows of ``jets_off`` (1..16) zeroed: the jets left."""
    out = np.array(jet_map, int)
    if len(jets_off):
        out[np.asarray(jets_off, int) - 1] = 0
    return out


def check_table_vehicle(table: LookupTable, vehicle: Vehicle) -> None:
    """Refuse flying ``table`` on ``vehicle`` when they do not belong together: a channel table
    only on the vehicle file its recipe was solved for (same SHA-256)."""
    recipe = table.recipe
    if recipe is None:
        return
    check_recipe_vehicle(recipe, vehicle, what=table.source or "<lookup table>")
