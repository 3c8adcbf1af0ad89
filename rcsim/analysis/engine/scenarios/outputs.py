"""Scenario outputs: one flight's directory (``history.parquet``, ``metrics.csv``,
``summary.json``, plots), the two controllers' comparison, the paper's figure set."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pandas as pd

from rcsim.analysis.engine.flight import history_frame
from rcsim.analysis.engine.output import atomic_dir, check_out_dir
from rcsim.analysis.engine.scenarios.catalog import PaperScenario, all_scenarios, get_scenario
from rcsim.analysis.engine.scenarios.figure_set import write_figure_set
from rcsim.analysis.engine.scenarios.flying import (
    check_scenario_vehicle,
    compare_controllers,
    comparison_markdown,
    scenario_metrics,
    summarize,
)
from rcsim.analysis.engine.scenarios.plots import plot_scenario
from rcsim.spacecraft.simulation import History
from rcsim.spacecraft.vehicle import Vehicle


def write_scenario(
    history: History,
    scenario: PaperScenario,
    out_dir: str | os.PathLike,
    *,
    controller: str,
    command: str | None = None,
    overwrite: bool = False,
    vehicle: Vehicle | None = None,
) -> dict[str, Path]:
    """Write ``history.parquet`` (all runs, column ``run``), ``metrics.csv``,
    ``summary.json`` and the paper-style plots into ``out_dir``, atomically.

    ``command`` (e.g. ``"scenario run"``) is recorded in the directory's marker, and
    ``overwrite`` allows replacing an earlier output of that command
    (:func:`rcsim.analysis.engine.output.atomic_dir`).  ``vehicle``: the one flown (default
    the paper's), whose profile sets the settling tolerances and whose name the summary
    records."""
    vehicle = Vehicle.load(vehicle)
    frames = []
    for i in range(history.n_runs):  # post-processing only; the flight was batched
        f = history_frame(history, i)
        f.insert(0, "run", i)
        frames.append(f)
    frame = pd.concat(frames, ignore_index=True)
    control = vehicle.control
    metrics = scenario_metrics(history, scenario, control)
    summary = {
        "scenario": scenario.name,
        "controller": controller,
        "vehicle": vehicle.record(),
        "description": scenario.description,
        "figures": scenario.figures,
        **summarize(metrics),
    }
    title = f"{controller}: {scenario.name}"
    with atomic_dir(out_dir, command, overwrite=overwrite) as tmp:
        frame.to_parquet(tmp / "history.parquet", index=False)
        metrics.to_csv(tmp / "metrics.csv", index=False)
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2, allow_nan=True) + "\n")
        plots = plot_scenario(history, scenario, tmp, title=title, control=control)
    out = Path(out_dir)
    return {
        name: out / name
        for name in ("history.parquet", "metrics.csv", "summary.json", *[p.name for p in plots])
    }


def write_comparison(
    out_dir: str | os.PathLike,
    names=None,
    *,
    table=None,
    overwrite: bool = False,
    vehicle: Vehicle | None = None,
) -> tuple[pd.DataFrame, str]:
    """Fly every scenario (or ``names``) with both controllers on ``vehicle`` (default the
    paper's) and write ``comparison.csv`` and ``comparison.md`` into ``out_dir`` (checked
    before any flight).

    Returns the comparison frame and its Markdown.
    """
    vehicle = Vehicle.load(vehicle)
    for name in names or all_scenarios():
        check_scenario_vehicle(get_scenario(name), vehicle)  # fail before flying anything
    check_out_dir(out_dir, "scenario compare", overwrite=overwrite)
    frame = compare_controllers(names, table=table, vehicle=vehicle)
    md = comparison_markdown(frame, vehicle.control)
    with atomic_dir(out_dir, "scenario compare", overwrite=overwrite) as tmp:
        frame.to_csv(tmp / "comparison.csv", index=False)
        (tmp / "comparison.md").write_text(md)
    return frame, md


def write_figures(out_dir: str | os.PathLike, *, table=None, overwrite: bool = False) -> list[str]:
    """The paper's figure set (:func:`~rcsim.analysis.engine.scenarios.figure_set.write_figure_set`)
    as an output directory of ``rcsim scenario figures``; returns the file names."""
    check_out_dir(out_dir, "scenario figures", overwrite=overwrite)
    with atomic_dir(out_dir, "scenario figures", overwrite=overwrite) as tmp:
        return write_figure_set(tmp, table=table)
