"""A generated lookup table on disk: the table CSV and its companion, written whole or not at all.

``rcsim lookup generate`` is this module's :func:`generate_table_files` behind a parser: both
outputs are checked before the 26 flights (an existing file is replaced only with
``overwrite``), missing parent directories are created and removed again if the writing
fails, and each file appears by an atomic rename, never half written.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from analysis.engine.output import check_out_file, make_parents, remove_parents
from lookup.jet_sets import companion_path
from lookup.table_generation import GeneratedTable, generate_table
from models.atomic import atomic_write
from models.errors import InputError


@dataclass(frozen=True)
class TableFiles:
    """What :func:`generate_table_files` made: the generation and the two paths."""

    generated: GeneratedTable
    table: Path
    settling: Path


def generate_table_files(
    out: str | os.PathLike,
    *,
    settling_out: str | os.PathLike | None = None,
    jets_off=(),
    overwrite: bool = False,
    vehicle: str | os.PathLike | None = None,
) -> TableFiles:
    """Generate the lookup table (:func:`lookup.table_generation.generate_table`) and write
    ``out`` and its companion (default ``<out stem>_settling.csv``).

    Raises
    ------
    InputError
        About ``out`` or ``settling_out``: an existing file without ``overwrite``, a path the
        system refuses, the two paths equal, or ``settling_out`` with ``jets_off`` (the loader
        finds a table's jet set only in its companion beside it); about ``jets_off``: the
        library's jet-set rule (:func:`lookup.jet_sets.check_jets_off`); about ``vehicle``:
        an invalid vehicle file, or one whose jets do not each turn one axis as Table 2's do
        (the pattern-recognition table assumes that jet map; fly such a vehicle with the
        allocator controller).
    """
    jets_off = tuple(jets_off or ())
    if jets_off and settling_out is not None:
        raise InputError(
            f"{settling_out}: not with jets_off; the table loads only with its "
            "companion beside it, named <TABLE stem>_settling.csv",
            parameter="settling_out",
            value=str(settling_out),
        )
    # Both outputs are checked before the 26 flights, not after.
    table = check_out_file(out, overwrite=overwrite, parameter="out")
    settling = check_out_file(
        settling_out or companion_path(table), overwrite=overwrite, parameter="settling_out"
    )
    if settling == table:
        raise InputError(
            f"{settling}: is the table itself (out)", parameter="settling_out", value=str(settling)
        )
    flying = {}
    if vehicle is not None:
        flying = _vehicle_generation(vehicle)
    gen = generate_table(jets_off=jets_off, **flying)
    frame = gen.settling_frame()
    created = make_parents(table) + make_parents(settling)
    try:
        atomic_write(table, lambda tmp: gen.table.to_csv(tmp))
        atomic_write(settling, lambda tmp: frame.to_csv(tmp, index=False))
    except BaseException:
        remove_parents(created)
        raise
    return TableFiles(gen, table, settling)


def _vehicle_generation(vehicle: str | os.PathLike) -> dict:
    """The :func:`generate_table` arguments that fly a vehicle file instead of the packaged
    vehicle: its model, nominal parameters and valve limits."""
    from models.tables import load_jet_map
    from spacecraft.vehicle_file import FlyingVehicle
    from spacecraft.vehicle_file.authority import jet_map_mismatch

    flying = FlyingVehicle.load(vehicle)
    differs = jet_map_mismatch(flying.definition, load_jet_map())
    if differs:
        raise InputError(
            f"{flying.definition.source}: the lookup table's pattern recognition needs the "
            f"paper's jet map (Table 2: each jet turns one axis), but {differs}; fly this "
            "vehicle with the allocator controller (rcsim lookup database --vehicle gives its "
            "per-jet responses)",
            parameter="vehicle",
            value=str(vehicle),
        )
    return {
        "model": flying.model,
        "params": flying.nominal(1),
        "propulsion": flying.propulsion(),
    }
