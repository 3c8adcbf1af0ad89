"""``plots/propellant_delta_v.png``: propellant used and net delta-v per case.

Two panels sharing the cases: each run as a dot (spread sideways within its case so equal
values stay visible), the case mean with its Student-t 95 % interval (``cases.csv``), and the
spec's ``[failure]`` budget as a dashed line when it sets one.  Delta-v is the inertial one
(``delta_v_N_m_s``), in mm/s: a run's translation is millimetres per second.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rcsim.analysis.engine.plots import new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: (runs column, cases.csv mean prefix, budget key, axis label, scale to the plotted unit)
PANELS = (
    ("propellant_kg", "propellant_kg", "max_propellant_kg", "propellant used per run [g]", 1e3),
    (
        "delta_v_N_m_s",
        "delta_v_N_m_s",
        "max_delta_v_m_s",
        "net delta-v of the CG, inertial [mm/s]",
        1e3,
    ),
)
COLUMNS = tuple(p[0] for p in PANELS)


def plot_propellant_delta_v(
    runs: pd.DataFrame,
    cases: pd.DataFrame,
    path: Path,
    *,
    title: str = "",
    budgets: dict | None = None,
    dpi: int = 80,
) -> Figure:
    """The figure (module docstring) of ``runs`` (``case_index`` and :data:`COLUMNS`) and
    ``cases`` (``cases.csv``), written to ``path``; returns it."""
    budgets = budgets or {}
    fig, axes = new_figure(2, 1, figsize=(9, 7.5), sharex=True)
    x = np.arange(len(cases))
    position = {int(c): i for i, c in enumerate(cases["case_index"])}
    where = runs["case_index"].map(position).to_numpy(float)
    jitter = np.random.default_rng(0).uniform(-0.25, 0.25, size=len(runs))  # display only
    for ax, (column, prefix, key, label, scale) in zip(axes, PANELS):
        ax.plot(
            where + jitter,
            runs[column] * scale,
            ".",
            color="tab:gray",
            ms=3,
            alpha=0.5,
            label="runs",
        )
        mean = cases[f"{prefix}_mean"].to_numpy(float) * scale
        lo = cases[f"{prefix}_lo95"].to_numpy(float) * scale
        hi = cases[f"{prefix}_hi95"].to_numpy(float) * scale
        err = np.vstack([mean - lo, hi - mean])
        ax.errorbar(
            x,
            mean,
            yerr=np.nan_to_num(err),
            fmt="o",
            color="tab:blue",
            ms=5,
            capsize=3,
            label="case mean, 95 % interval",
        )
        if budgets.get(key) is not None:
            ax.axhline(
                float(budgets[key]) * scale,
                color="tab:red",
                ls="--",
                label=f"budget ({key} = {float(budgets[key]):g})",
            )
        ax.set_ylabel(label)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3, axis="y")
        ax.legend(fontsize=8, loc="upper left")
    axes[-1].set_xticks(x, cases["case"], rotation=90, fontsize=7)
    fig.suptitle(title)
    fig.savefig(path, dpi=dpi)
    return fig
