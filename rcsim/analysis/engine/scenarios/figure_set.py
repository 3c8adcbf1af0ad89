"""The lookup controller's paper figure set (``docs/figures/lookup_*.png``).

Figs 3-4 come from a fresh table generation on the nominal vehicle; the others from flying the
named scenarios with the lookup controller.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from rcsim.analysis.engine.flight import history_frame
from rcsim.analysis.engine.plots import plot_attitude_error, plot_axes_jets
from rcsim.analysis.engine.scenarios.catalog import get_scenario
from rcsim.analysis.engine.scenarios.flying import fly_scenario
from rcsim.analysis.engine.scenarios.plots import (
    hold_lines,
    plot_hold,
    plot_runs_rates,
    plot_sweep_case,
    plot_table_heatmap,
)
from rcsim.lookup.generation import generate_table
from rcsim.spacecraft.vehicle import Vehicle

#: The docs figure set: file name -> (scenario, plot kind).  Kinds: "att" attitude error,
#: "jets" rates with jet commands per axis, "hold" the attitude-hold view.
FIGURES = {
    "lookup_fig05_single_axis_attitude.png": ("single-axis-yaw", "att"),
    "lookup_fig06_single_axis_jets.png": ("single-axis-yaw", "jets"),
    "lookup_fig07_three_axis_attitude.png": ("three-axis-5deg", "att"),
    "lookup_fig08_three_axis_jets.png": ("three-axis-5deg", "jets"),
    "lookup_fig17_hold_no_band.png": ("attitude-hold-disturbed-no-band", "hold"),
    "lookup_fig18_hold_band.png": ("attitude-hold-disturbed", "hold"),
    "lookup_fig19_disturbed_attitude.png": ("disturbed-three-axis", "att"),
    "lookup_fig20_disturbed_jets.png": ("disturbed-three-axis", "jets"),
    "lookup_fig21_large_attitude.png": ("large-90deg", "att"),
    "lookup_fig22_24_large_jets.png": ("large-90deg", "jets"),
    "lookup_fig25_slow_attitude.png": ("slow-0.1deg-s", "att"),
    "lookup_fig26_28_slow_jets.png": ("slow-0.1deg-s", "jets"),
}


def firing_windows(frame, before_s: float = 0.3, after_s: float = 1.2):
    """Zoom windows [s] around the first and the last firing of a flight (empty if none)."""
    jets = frame.filter(regex=r"^jet_\d\d_on_s$").to_numpy()
    t = frame["t_s"].to_numpy()
    firing = np.flatnonzero(jets.sum(axis=1) > 0)
    if firing.size == 0:
        return []
    first, last = t[firing[0]], t[firing[-1]]
    return [(max(first - before_s, 0.0), first + after_s), (last - after_s, last + before_s)]


def write_figure_set(out_dir, *, table=None, progress: bool | None = None) -> list[str]:
    """Write the lookup controller's paper figure set (``lookup_*.png``) into ``out_dir``.

    Figs 3-4 come from a fresh table generation (nominal vehicle); the others from flying the
    named scenarios with the lookup controller (``table``: default the packaged table).
    Returns the file names.  ``progress``: a progress bar on stderr (steps done, ETA);
    default only when stderr is a terminal.
    """
    from tqdm import tqdm

    out_dir = Path(out_dir)
    flights = list(dict.fromkeys(scn for scn, _ in FIGURES.values()))
    bar = tqdm(
        total=2 + len(flights),
        unit="step",
        desc="scenario figures",
        file=sys.stderr,
        disable=not (sys.stderr.isatty() if progress is None else progress),
        dynamic_ncols=True,
    )
    with bar:
        bar.set_postfix_str("table generation")
        names = _write_table_figures(out_dir, table, bar)
        flown = {}
        for scn_name in flights:
            bar.set_postfix_str(scn_name)
            flown[scn_name] = history_frame(
                fly_scenario(get_scenario(scn_name), "lookup", table=table), 0
            )
            bar.update(1)
    for name, (scn_name, kind) in FIGURES.items():
        frame = flown[scn_name]
        title = f"lookup: {scn_name}"
        if kind == "att":
            plot_attitude_error(frame, out_dir / name, title=title)
        elif kind == "jets":
            axes = ("yaw",) if scn_name == "single-axis-yaw" else ("roll", "pitch", "yaw")
            plot_axes_jets(
                frame, out_dir / name, title=title, axes=axes, windows=firing_windows(frame)
            )
        else:
            lines = hold_lines(get_scenario(scn_name), Vehicle.load().control)  # the paper's
            plot_hold(frame, out_dir / name, title=title, **lines)
        names.append(name)
    return names


def _write_table_figures(out_dir: Path, table, bar) -> list[str]:
    """Figs 3-4 from a fresh table generation, and the rate damping of the 26 rates."""
    paper = Vehicle.load()  # the paper's vehicle: its Figs 3-4
    gen = generate_table(paper)
    bar.update(1)
    rate = np.asarray(gen.table.rate_cmd)
    names = [
        "lookup_fig03_rate_command.png",
        "lookup_fig04_rate_damping.png",
        "lookup_fig03_04_case26.png",
        "lookup_rate_damping_runs.png",
    ]
    plot_table_heatmap(
        gen.table.firing_time_s,
        out_dir / names[0],
        rate_cmd_rad_s=rate,
        cycle_s=paper.control.cycle_s,
        title="Fig 3: firing time from rest to each rate command (generated)",
    )
    plot_table_heatmap(
        gen.damping_firing_time_s,
        out_dir / names[1],
        rate_cmd_rad_s=rate,
        cycle_s=paper.control.cycle_s,
        title="Fig 4: firing time to damp each rate to zero; equal times on "
        f"opposing jets in {int(gen.damping_equal.sum())}/26 cases",
    )
    plot_sweep_case(
        gen.command.history,
        gen.damping.history,
        25,
        out_dir / names[2],
        title="Case 26 (+,+,+) 0.3 deg/s: rate command vs rate damping",
    )
    bar.set_postfix_str("rate-damping")
    damp = get_scenario("rate-damping")
    plot_runs_rates(
        fly_scenario(damp, "lookup", table=table),
        out_dir / names[3],
        title="lookup controller: rate damping of the 26 Table 3 rates",
    )
    bar.update(1)
    return names
