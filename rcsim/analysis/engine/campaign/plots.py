"""Campaign plots in the manner of Gambone Figs 9-14, from ``envelopes.parquet`` and
``runs.parquet``.

* ``plots/case-<name>.png`` (Figs 9-14): per axis, the body rate envelope over all runs (min-max
  band, mean line, command dashed), the attitude-error envelope, and the firing activity --
  the fraction of runs firing that axis's jets in each control cycle.
* ``plots/summary.png``: failures per case, firings per run per case, and the histogram of
  final rate errors (Fig 16).
* ``plots/propellant_delta_v.png``: propellant used and net delta-v per case, runs and case
  means with intervals, against the spec's budgets
  (:mod:`~rcsim.analysis.engine.campaign.budget_plots`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.ticker import MaxNLocator

from rcsim.analysis.engine import runs_table
from rcsim.analysis.engine.campaign.budget_plots import COLUMNS as BUDGET_COLUMNS
from rcsim.analysis.engine.campaign.budget_plots import plot_propellant_delta_v
from rcsim.analysis.engine.plots import new_figure
from rcsim.spacecraft.vehicle.model import AXES

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from rcsim.analysis.engine.campaign.spec import CampaignSpec

COLORS = {"roll": "tab:blue", "pitch": "tab:orange", "yaw": "tab:green"}
DPI = 80  # keeps a 3-panel figure near 60-90 KB


def plot_case(
    env: pd.DataFrame, name: str, path: Path, *, title: str = "", rate_cmd_deg_s=None
) -> Figure:
    """Envelope plot of one case (``env``: its rows of envelopes.parquet), written to
    ``path``; returns the figure."""
    t = env["t_s"].to_numpy()
    n = env["n_runs"].to_numpy()
    fig, axes = new_figure(3, 1, figsize=(8, 7.5), sharex=True)
    for axis in AXES:
        c = COLORS[axis]
        axes[0].fill_between(
            t,
            env[f"rate_{axis}_deg_s_min"],
            env[f"rate_{axis}_deg_s_max"],
            color=c,
            alpha=0.25,
            lw=0,
        )
        axes[0].plot(t, env[f"rate_{axis}_deg_s_mean"], color=c, lw=1.2, label=axis)
        if rate_cmd_deg_s is not None:
            axes[0].axhline(
                rate_cmd_deg_s[AXES.index(axis)], color=c, ls="--", lw=0.8, label=f"{axis} command"
            )
        axes[1].fill_between(
            t,
            env[f"att_err_{axis}_deg_min"],
            env[f"att_err_{axis}_deg_max"],
            color=c,
            alpha=0.25,
            lw=0,
        )
        axes[1].plot(t, env[f"att_err_{axis}_deg_mean"], color=c, lw=1.2, label=axis)
        axes[2].step(
            t, 100.0 * env[f"firing_{axis}_runs"] / n, where="post", color=c, lw=1.0, label=axis
        )
    axes[0].set_ylabel("body rate [deg/s]")
    axes[1].set_ylabel("attitude error [deg]")
    axes[2].set_ylabel("runs firing the axis [%]")
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        # "best": the bands fill the corners a fixed location would cover in some cases.
        ax.legend(loc="best", fontsize=8, ncol=3, framealpha=0.8)
    runs = int(n.max()) if n.size else 0
    fig.suptitle(
        _wrapped(f"{title or name}: {runs} runs", 78)
        + "\n(band: min-max over runs, line: mean, dashed: command)"
    )
    fig.savefig(path, dpi=DPI)
    return fig


def _wrapped(text: str, width: int) -> str:
    """A title on as many lines as it needs (a long table file name would run off both
    edges of the figure: a centred title is cut at both ends); ``width`` in characters of
    the title font that fit the figure."""
    import textwrap

    return "\n".join(textwrap.wrap(text, width, break_on_hyphens=False)) or text


def plot_summary(
    runs: pd.DataFrame,
    cases: pd.DataFrame,
    path: Path,
    *,
    title: str = "",
    rate_threshold_deg_s: float | None = None,
) -> Figure:
    """Failures and firings per case, and the final rate-error histogram (Fig 16), written to
    ``path``; returns the figure."""
    fig, axes = new_figure(3, 1, figsize=(9, 8.5))
    x = np.arange(len(cases))
    axes[0].bar(x, cases["failed_pct"], color="tab:red")
    axes[0].set_ylabel("failed runs [%]")
    axes[1].bar(x, cases["firings_per_run_mean"], color="tab:gray", label="mean")
    axes[1].plot(x, cases["firings_per_run_max"], "k_", ms=10, label="max")
    axes[1].set_ylabel("jet firings per run")
    axes[1].legend(fontsize=8)
    for ax in axes[:2]:
        ax.set_xticks(x, cases["case"], rotation=90, fontsize=7)
        ax.grid(alpha=0.3, axis="y")
    err = runs[[f"final_rate_err_{a}_deg_s" for a in AXES]].abs().max(axis=1).dropna()
    axes[2].hist(err, bins=40, color="tab:blue")
    axes[2].yaxis.set_major_locator(MaxNLocator(integer=True))  # counts of runs
    if rate_threshold_deg_s is not None:
        axes[2].axvline(
            rate_threshold_deg_s,
            color="tab:red",
            ls="--",
            label=f"failure threshold {rate_threshold_deg_s:g} deg/s",
        )
        axes[2].legend(fontsize=8)
    axes[2].set_xlabel("final |rate error|, worst axis [deg/s]")
    axes[2].set_ylabel("runs")
    fig.suptitle(_wrapped(title, 88))
    fig.savefig(path, dpi=DPI)
    return fig


def plot_campaign(out: Path, spec: CampaignSpec) -> list[Path]:
    """All plots of a finished campaign directory into ``out/plots``."""

    folder = out / runs_table.PLOTS
    folder.mkdir(exist_ok=True)
    who = spec.controller + (f" ({Path(spec.table).name})" if spec.table else "")
    paths = []
    env_path = out / runs_table.ENVELOPES
    if env_path.exists():
        env = pd.read_parquet(env_path)
        for c, case in enumerate(spec.cases):
            rows = env[env["case_index"] == c]
            if rows.empty:
                continue
            path = folder / f"case-{case.name}.png"
            plot_case(
                rows,
                case.name,
                path,
                title=f"{who}: {case.name}",
                rate_cmd_deg_s=np.degrees(case.rate_cmd_rad_s),
            )
            paths.append(path)
    cols = [f"final_rate_err_{a}_deg_s" for a in AXES]
    runs = pd.read_parquet(out / runs_table.RUNS, columns=cols)
    cases = pd.read_csv(out / runs_table.CASES)
    path = folder / "summary.png"
    n_runs, n_failed = int(cases["runs"].sum()), int(cases["failed"].sum())
    pct = 100.0 * n_failed / n_runs if n_runs else 0.0
    plot_summary(
        runs,
        cases,
        path,
        title=f"{who}: {n_runs} runs, {n_failed} failed ({pct:.3g} %)",
        rate_threshold_deg_s=spec.resolved["failure"]["rate_error_deg_s"],
    )
    paths.append(path)
    path = folder / "propellant_delta_v.png"
    runs = pd.read_parquet(out / runs_table.RUNS, columns=["case_index", *BUDGET_COLUMNS])
    plot_propellant_delta_v(
        runs,
        cases,
        path,
        title=f"{who}: propellant and translation",
        budgets=spec.resolved["failure"],
        dpi=DPI,
    )
    paths.append(path)
    return paths
