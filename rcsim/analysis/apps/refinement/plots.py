"""The refinement's before/after plots (Figs 9-10 style): failures and repeated firings per
case on both seeds, and the most improved case's runs flown with the old and the refined
table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.parameters import refinement_spec
from rcsim.analysis.apps.refinement.result import Refinement
from rcsim.analysis.engine.campaign.effects import draw_effects
from rcsim.analysis.engine.campaign.outcomes import outcomes
from rcsim.analysis.engine.flight import fly_batch
from rcsim.analysis.engine.plots import AXIS_COLORS, new_figure
from rcsim.lookup.pattern_recognition import LookupController, LookupParams
from rcsim.models.tables import AXES
from rcsim.spacecraft.dispersions import draw_runs

DPI = 90
#: Most runs drawn in the before/after plot of one case.
PLOT_RUNS = 200


def most_improved_case(log: pd.DataFrame):
    """The changelog row of the changed case with the largest drop in failures (then in
    repeated firings) on the held-out seed (the original and the refined table on the same
    runs, used by no decision); None if no case changed."""
    changed = log[log["changed"]]
    if changed.empty:
        return None
    gain = (changed["failed_fresh_before"] - changed["failed_fresh_after"]) * 10_000 + (
        changed["repeated_fresh_before"] - changed["repeated_fresh_after"]
    )
    return changed.loc[gain.idxmax()]


def plot_failures_by_case(
    log: pd.DataFrame,
    path: Path,
    *,
    title: str,
    seed: int | None = None,
    fresh_seed: int | None = None,
    search_runs: int | None = None,
) -> None:
    """Failed and repeated-firing runs per case, before and after, on both seeds: each panel
    compares the same runs (the search seed's first ``search_runs`` runs of each case, or the
    held-out seed's runs), and its title names its seed."""
    fig, axes = new_figure(2, 2, figsize=(12, 6.5), sharex=True, sharey="row")
    x = np.arange(len(log))
    names = {
        "search": "search seed"
        + (f" {seed}" if seed is not None else "")
        + (f", its first {search_runs} runs per case" if search_runs else ""),
        "fresh": "held-out seed" + (f" {fresh_seed}" if fresh_seed is not None else ""),
    }
    for col, seed_name in enumerate(("search", "fresh")):
        for row, what in enumerate(("failed", "repeated")):
            ax = axes[row, col]
            before, after = log[f"{what}_{seed_name}_before"], log[f"{what}_{seed_name}_after"]
            ax.bar(x - 0.2, before, 0.4, color="tab:red", label="original table")
            ax.bar(x + 0.2, after, 0.4, color="tab:blue", label="refined table")
            ax.set_ylabel(f"{what} runs" if col == 0 else "")
            ax.grid(alpha=0.3, axis="y")
            ax.set_title(
                f"{what} runs per case, {names[seed_name]} "
                f"({int(before.sum())} -> {int(after.sum())})",
                fontsize=9,
            )
            ax.legend(fontsize=8)
        axes[1, col].set_xticks(
            x,
            [str(int(c)) + ("*" if ch else "") for c, ch in zip(log["case"], log["changed"])],
            fontsize=7,
        )
        axes[1, col].set_xlabel("rate case (* = firing time changed)")
    fig.suptitle(
        f"Lookup-table refinement: {title}; repeated = needed more than one firing "
        "to reach the commanded rate"
    )
    fig.savefig(path, dpi=DPI)


def _fly_table(ref: Refinement, table, spec, row: int, ids, params, lookup_params):
    """The history of campaign runs ``ids`` of case ``row`` flown with ``table`` by what the
    refinement flew (the built-in lookup controller, or its plug-in), with the effects those
    runs draw (valve timing, pulses, modes: as the campaign and the search flew them)."""
    cases = [spec.cases[row]] * len(ids)
    effects = draw_effects(spec.effects, spec.seed, ids, spec.n_jets)[0]
    if ref.plugin is None:
        controller = LookupController(table, lookup_params)
        return fly_batch(cases, params, controller, vehicle=spec.vehicle, **effects)
    times = np.asarray(table.firing_time_s, float)[None]
    for _, controller in ref.plugin.controllers(spec.vehicle, table, times):
        # Flown inside the loop: the candidate's file exists while the plug-in flies it.
        return fly_batch(cases, params, controller, vehicle=spec.vehicle, **effects)
    raise AssertionError("one table gives one controller")


def plot_case_before_after(ref: Refinement, case: int, path: Path) -> None:
    """Figs 9-10 style: the changed axis's body rate of the same search-seed runs of
    ``case`` (the first :data:`PLOT_RUNS`), with the old table (left) and the refined one
    (right); failed runs in red.  The title names the seed."""
    log = ref.changelog.set_index("case").loc[case]
    axis = max(AXES, key=lambda a: abs(int(log[f"{a}_change_cycles"])))
    a = AXES.index(axis)
    spec = refinement_spec(
        runs_per_case=ref.runs_per_case,
        seed=ref.seed,
        duration_s=ref.duration_s,
        vehicle=ref.vehicle,
        table=ref.table_file,
    )
    row = case - 1
    vehicle = spec.vehicle  # the refinement's vehicle, flown as its campaigns fly it
    # At most PLOT_RUNS runs: enough to see the spread, and a fixed cost however many runs
    # the search flew (the whole history of every run is kept for the plot).
    shown = min(ref.runs_per_case, PLOT_RUNS)
    ids = row * ref.runs_per_case + np.arange(shown)
    params = draw_runs(vehicle.nominal(1), spec.sigmas, spec.seed, ids).params
    lookup_params = LookupParams.from_profile(vehicle.control)
    thr = np.degrees(spec.rate_threshold_rad_s)
    fig, axes = new_figure(1, 2, figsize=(12, 4.5), sharey=True)
    cmd = np.degrees(spec.cases[row].rate_cmd_rad_s[a])
    for ax, (label, table, old_new) in zip(
        axes, (("old table", ref.original, "old"), ("refined table", ref.table, "new"))
    ):
        history = _fly_table(ref, table, spec, row, ids, params, lookup_params)
        rate = np.degrees(history.omega_B[:, :, a])
        failed = outcomes(history, spec)["failed"].to_numpy(bool)
        for fail, color in ((False, AXIS_COLORS["roll"]), (True, "tab:red")):
            sel = failed == fail
            if sel.any():
                ax.plot(history.t_s, rate[sel].T, color=color, lw=0.6, alpha=0.5)
        ax.axhspan(cmd - thr, cmd + thr, color="0.8", alpha=0.6, label=f"command +-{thr:g} deg/s")
        ax.set_title(
            f"{label}: {axis} {log[f'{axis}_{old_new}_s']:.2f} s; "
            f"{int(failed.sum())} of {shown} runs fail (red)",
            fontsize=10,
        )
        ax.set_xlabel("time [s]")
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right", fontsize=8)
    axes[0].set_ylabel(f"{axis} rate [deg/s]")
    fig.suptitle(
        f"Rate case {case}: {axis} rate of the same {shown} dispersed runs, before and after "
        f"refinement (search seed {ref.seed})"
        + ("" if ref.plugin is None else f"; flown by {ref.plugin.describe()}")
    )
    fig.savefig(path, dpi=DPI)
