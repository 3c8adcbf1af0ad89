"""Figure 4 of Pittella & Sands (2023): final angle against final rate, with sigma ellipses.

Plots :attr:`rcsim.analysis.apps.studies.noisy_sensor.StudyResult.runs`; imports nothing from the
study module (it re-exports these names).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

#: Smallest half-width of a scatter panel's axis (nondimensional); a deterministic outcome
#: (e.g. open-loop final rate, zero up to 1e-16) then plots as a line, not as magnified
#: round-off.  0.01 is one sensor standard deviation of the paper's noise.
PLOT_MIN_HALF_SPAN = 0.01


def sigma_ellipse(x: np.ndarray, y: np.ndarray, k: float, n_points: int = 121) -> np.ndarray:
    """Points of the ``k``-sigma covariance ellipse of samples ``(x, y)``.

    Uses the eigen-decomposition of the sample covariance (so correlated outcomes get a
    tilted ellipse; the paper's MATLAB draws axis-aligned ones with semi-axes ``k sigma``).
    Degenerate (zero) spreads give a degenerate ellipse, never a warning.

    Returns
    -------
    ndarray, shape (2, n_points)
    """
    cov = np.cov(np.vstack([x, y]))
    evals, evecs = np.linalg.eigh(cov)
    angle = np.linspace(0.0, 2.0 * np.pi, n_points)
    circle = np.vstack([np.cos(angle), np.sin(angle)])
    scale = k * np.sqrt(np.clip(evals, 0.0, None))
    return np.array([[x.mean()], [y.mean()]]) + evecs @ (scale[:, None] * circle)


def plot_scatter(runs: pd.DataFrame, path: Path, *, measured: bool = False) -> None:
    """Paper Figure 4: final angle vs final rate per architecture, 1-3 sigma, mean ``+``.

    Parameters
    ----------
    runs : DataFrame
        As in :class:`StudyResult`.
    path : Path
        PNG file to write.
    measured : bool
        Plot the final sensor readings instead of the true final state.
    """
    suffix = "_measured" if measured else ""
    groups = list(runs.groupby("architecture", sort=False))
    ncols = 3
    nrows = -(-len(groups) // ncols)
    # matplotlib's object API, not pyplot: never switches the backend of a user's session.
    fig = Figure(figsize=(12, 3.9 * nrows))
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for ax, (panel, (label, group)) in zip(axes.flat, enumerate(groups)):
        x = group[f"theta_f{suffix}"].to_numpy()
        y = group[f"omega_f{suffix}"].to_numpy()
        ax.scatter(x, y, s=4, color="tab:blue", alpha=0.35, linewidths=0)
        for k in (1, 2, 3):
            ex, ey = sigma_ellipse(x, y, k)
            ax.plot(ex, ey, "k-", lw=0.9)
        ax.plot(x.mean(), y.mean(), "k+", ms=12, mew=2)
        cost = group["J"].to_numpy()
        ax.set_title(
            f"({chr(ord('a') + panel)}) {label}\nJ = {cost.mean():.4f} ± {cost.std(ddof=1):.4f}",
            fontsize=10,
        )
        ax.set_xlabel(r"$\theta_f$")
        ax.set_ylabel(r"$\omega_f$")
        ax.grid(True, alpha=0.3)
        ax.ticklabel_format(useOffset=False)
        _floor_span(ax, x.mean(), y.mean())
    for ax in list(axes.flat)[len(groups) :]:
        ax.set_visible(False)
    n = runs["run"].nunique()
    fig.suptitle(f"Final state, N = {n} runs per architecture; rings 1, 2, 3 sigma, + mean")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def _floor_span(ax, x0: float, y0: float, half_span: float = PLOT_MIN_HALF_SPAN) -> None:
    """Widen axes narrower than ``2 half_span`` so round-off spreads are not magnified."""
    for get, set_, centre in ((ax.get_xlim, ax.set_xlim, x0), (ax.get_ylim, ax.set_ylim, y0)):
        low, high = get()
        if high - low < 2.0 * half_span:
            set_(centre - half_span, centre + half_span)
