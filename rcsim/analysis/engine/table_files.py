"""A generated lookup table on disk: the table CSV and its companion, written whole or not at all.

``rcsim lookup generate`` is this module's :func:`generate_table_files` behind a parser: both
outputs (and a channel table's recipe) are checked before the 26 flights (an existing file is
replaced only with ``overwrite``), missing parent directories are created and removed again if
the writing fails, and the files are committed together (:func:`write_table_files`): all of
them or none, never one half written.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from rcsim.analysis.engine.commit import commit_files
from rcsim.analysis.engine.output import check_out_file, make_parents, remove_parents
from rcsim.analysis.engine.output_places import refuse_own_inputs
from rcsim.lookup import generation
from rcsim.lookup.generation import is_coupled
from rcsim.lookup.jet_sets import companion_path
from rcsim.lookup.row_tuning import DEFAULT_TARGET_FRACTION
from rcsim.lookup.table_generation import GeneratedTable
from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle import Vehicle


def generate_table(
    vehicle: Vehicle | str | os.PathLike | None = None,
    *,
    jets_off=(),
    target_fraction: float = DEFAULT_TARGET_FRACTION,
) -> GeneratedTable:
    """The lookup table of ``vehicle`` (a :class:`~rcsim.spacecraft.vehicle.Vehicle`, a
    packaged name, a vehicle file; None: the paper's), resolved once here, at the public edge:
    :func:`rcsim.lookup.generation.generate_table` (its ``jets_off``, ``target_fraction`` and
    what it raises; an invalid vehicle file raises :class:`InputError` too).  In memory; the
    files are :func:`generate_table_files`'."""
    return generation.generate_table(
        Vehicle.load(vehicle), jets_off=jets_off, target_fraction=target_fraction
    )


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
    vehicle: Vehicle,
    target_fraction: float = DEFAULT_TARGET_FRACTION,
) -> TableFiles:
    """Generate ``vehicle``'s lookup table (:func:`rcsim.lookup.generation.generate_table`) and
    write ``out`` and its companion (default ``<out stem>_settling.csv``); every row tuned to
    end its nominal case within ``target_fraction`` of the failure threshold
    (:mod:`rcsim.lookup.row_tuning`).

    Raises
    ------
    InputError
        About ``out`` or ``settling_out``: an existing file without ``overwrite``, a path the
        system refuses, the two paths equal, or ``settling_out`` with ``jets_off`` (the loader
        finds a table's jet set only in its companion beside it); about ``jets_off``: the
        library's jet-set rule (:func:`rcsim.lookup.jet_sets.check_jets_off`, or for a channel
        table :func:`rcsim.lookup.channels.solve_recipe`'s); about ``vehicle``: rate cases its
        jets cannot reach.

    A vehicle whose jets do not each turn one axis as Table 2's do gets a *channel table*
    (:mod:`rcsim.lookup.channel_generation`): six axis channels and the recipe that fires the jets,
    written beside the table as ``<out stem>_recipe.csv``.
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
    refuse_own_inputs([table, settling], {"vehicle": vehicle.source})
    if settling == table:
        raise InputError(
            f"{settling}: is the table itself (out)", parameter="settling_out", value=str(settling)
        )
    channels = is_coupled(vehicle)
    if channels:
        from rcsim.models.tables import recipe_path

        check_out_file(recipe_path(table), overwrite=overwrite, parameter="out")
    gen = generation.generate_table(vehicle, jets_off=jets_off, target_fraction=target_fraction)
    created = make_parents(table) + make_parents(settling)
    try:
        write_table_files(gen, table, settling)
    except BaseException:
        remove_parents(created)
        raise
    return TableFiles(gen, table, settling)


def write_table_files(gen: GeneratedTable, table: Path, settling: Path) -> None:
    """Write a generated table, its companion and (a channel table) its recipe as one commit
    (:func:`rcsim.analysis.engine.commit.commit_files`): all or none, also on a full disk.
    The table goes last: on disk it never lacks the companion (its jet set) or the recipe."""
    from rcsim.models.tables import recipe_path

    frame = gen.settling_frame()
    recipe = gen.table.recipe
    parts: list[tuple[Path, Callable[[str], object]]] = []
    if recipe is not None:
        parts.append((recipe_path(table), recipe.to_csv))
    parts.append((settling, lambda tmp: frame.to_csv(tmp, index=False)))
    parts.append((table, lambda tmp: gen.table.to_csv(tmp, with_recipe=False)))
    commit_files(parts)
