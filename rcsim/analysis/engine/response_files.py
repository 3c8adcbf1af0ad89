"""The per-jet response database on disk (``rcsim lookup database``): Parquet, summary, plot.

:func:`write_response_database` checks the three outputs before any flight (an existing file is
replaced only with ``overwrite``), flies the database
(:func:`rcsim.lookup.response_database.response_database`) and writes, as one commit (all three
or none, :func:`rcsim.analysis.engine.commit.commit_files`):

* ``DB`` (Parquet): one row per jet, on-time and dispersed vehicle;
* ``<DB stem>_summary.csv``: per jet, rate and velocity change per second of firing and their
  spread over the dispersed vehicles (:func:`rcsim.lookup.response_database.response_summary`);
* ``<DB stem>.png``: that rate response per jet, with 3-sigma bars.

The Parquet file's metadata (key ``rcsim``, JSON) names the vehicle file and its SHA-256, the
seed, the dispersed vehicles, the on-times flown and those dropped (below the vehicle's
minimum on-time, a pulse its valves never make), the valve timing flown when the vehicle has
one (``valve_timing``), and the code version.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.engine.campaign.results import code_version
from rcsim.analysis.engine.commit import commit_files
from rcsim.analysis.engine.output import check_out_file, make_parents, remove_parents
from rcsim.analysis.engine.plots import AXIS_COLORS, new_figure
from rcsim.lookup.response_database import response_database, response_summary
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.model import AXES


@dataclass(frozen=True)
class ResponseFiles:
    """What :func:`write_response_database` wrote."""

    database: Path
    summary: Path
    plot: Path
    frame: pd.DataFrame
    table: pd.DataFrame


def write_response_database(
    vehicle: Vehicle | str | os.PathLike,
    out: str | os.PathLike,
    *,
    n_vehicles: int = 64,
    seed: int = 1,
    overwrite: bool = False,
    nthread: int = 0,
) -> ResponseFiles:
    """Fly and write the per-jet response database of ``vehicle`` (module docstring).

    Raises
    ------
    InputError
        An invalid vehicle file; an output that exists without ``overwrite`` or that the
        system refuses; ``n_vehicles`` < 1.
    """
    database = check_out_file(
        out, overwrite=overwrite, parameter="out", inputs={"vehicle": vehicle}
    )
    summary = check_out_file(
        database.with_name(f"{database.stem}_summary.csv"), overwrite=overwrite, parameter="out"
    )
    plot = check_out_file(database.with_suffix(".png"), overwrite=overwrite, parameter="out")
    vehicle = Vehicle.load(vehicle)  # a name or a file: resolved once, before the flights
    frame = response_database(vehicle, n_vehicles=n_vehicles, seed=seed, nthread=nthread)
    table = response_summary(frame)
    meta: dict = {
        "vehicle": vehicle.definition.source,
        "vehicle_name": vehicle.definition.name,
        "vehicle_sha256": vehicle.sha256,
        "seed": seed,
        "n_vehicles": n_vehicles,
        "on_times_s": sorted(set(frame["on_time_s"].tolist())),
        "min_on_s": vehicle.definition.min_on_s,
        "dropped_on_times_s": frame.attrs["dropped_on_times_s"],
        "code_version": code_version(),
    }
    if vehicle.definition.has_delays:  # the valve timing flown (the file's), when it has one
        meta["valve_timing"] = vehicle.definition.delay_record()
    fig = _plot(vehicle, table, n_vehicles)
    created = make_parents(database)
    try:
        # One commit, the database last: all three files or none, also on a full disk.
        commit_files(
            [
                (summary, lambda tmp: table.to_csv(tmp, index=False)),
                (plot, lambda tmp: fig.savefig(tmp, dpi=110, format="png")),
                (database, lambda tmp: _to_parquet(frame, tmp, meta)),
            ]
        )
    except BaseException:
        remove_parents(created)
        raise
    return ResponseFiles(database, summary, plot, frame, table)


def _to_parquet(frame: pd.DataFrame, path: str, meta: dict) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrow = pa.Table.from_pandas(frame, preserve_index=False)
    schema = arrow.schema.with_metadata(
        {**(arrow.schema.metadata or {}), b"rcsim": json.dumps(meta).encode()}
    )
    pq.write_table(arrow.cast(schema), path)


def _plot(flying: Vehicle, table: pd.DataFrame, n_vehicles: int):
    """Rate change per second of firing of every jet, per axis, with 3-sigma bars."""
    fig, ax = new_figure(figsize=(10.0, 4.6))
    x = np.arange(len(table))
    for k, axis in enumerate(AXES):
        mean = np.degrees(table[f"dw_{axis}_rad_s_per_s"].to_numpy())
        sd = np.degrees(table[f"dw_{axis}_rad_s_per_s_sd"].to_numpy())
        ax.errorbar(
            x + (k - 1) * 0.25, mean, yerr=3 * sd, fmt="o", ms=4, capsize=2,
            color=AXIS_COLORS[axis], label=axis,
        )  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xticks(x, table["jet"], rotation=60)
    ax.set_ylabel("rate change per second of firing\n[deg/s per s]")
    ax.set_title(
        f"Per-jet response of {flying.definition.name!r}: each jet fired alone "
        f"(mean, bars 3 sd over {n_vehicles} vehicles dispersed by its [dispersions])"
    )
    ax.legend(title="axis", loc="best")
    ax.grid(axis="y", alpha=0.3)
    return fig
