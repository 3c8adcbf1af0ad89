"""Which jets a lookup table was made for, recorded beside it, so that a table generated for a
vehicle with failed jets (:func:`rcsim.lookup.table_generation.generate_table` ``jets_off``) loads.

A table for the full vehicle is checked at load against Table 2 (the jet map).  A table
generated without some jets fires none of them, and pairs with one jet left fire that jet
alone: checked against Table 2 it would be refused.  Its companion file
(``<table stem>_settling.csv``, written beside it by ``rcsim lookup generate``) has a
``jets_off`` column; :func:`load_table_for_jets` reads it and checks the table against the jet
map *of the vehicle it was made for* (Table 2 without those jets).

Imports ``models`` and ``rcsim.lookup.table_generation``'s helpers only.
"""
from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

from rcsim.models.errors import InputError
from rcsim.models.tables import LookupTable, load_jet_map, load_lookup_table


def companion_path(table: str | os.PathLike) -> Path:
    """``<dir>/<stem>_settling.csv`` of a table CSV."""
    p = Path(table)
    return p.with_name(f"{p.stem}_settling.csv")


def jets_off_of(table: str | os.PathLike) -> tuple:
    """Jets (1..16) the table at path ``table`` was generated without, from its companion
    file; ``()`` when there is no companion or it records none."""
    from rcsim.lookup.table_generation import check_jets_off

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
        raise InputError(f"{comp}: column jets_off: jet numbers 1..16 separated by spaces "
                         f"expected, got {text!r}") from None


def load_table_for_jets(table: str | os.PathLike, jets_off=None) -> tuple[LookupTable, tuple]:
    """Load a table CSV checked against the jets of the vehicle it was made for.

    Parameters
    ----------
    table : path
    jets_off : sequence of int, optional
        Default: what the companion file records.

    Returns
    -------
    (LookupTable, jets_off)
    """
    from rcsim.lookup.table_generation import check_jets_off, jet_map_without

    jets_off = jets_off_of(table) if jets_off is None else check_jets_off(jets_off)
    if not jets_off:
        return load_lookup_table(table), ()
    return load_lookup_table(table, jet_map=jet_map_without(load_jet_map(), jets_off)), jets_off
