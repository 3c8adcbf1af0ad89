"""Paper-style plots of one flight (Gambone Figs 1-2, 5-8, 17-20), and the figure factory.

Inputs are :func:`rcsim.analysis.engine.flight.history_frame` tables (degrees, deg/s, seconds).
Every rcsim figure is made by :func:`new_figure`: matplotlib's object API, never pyplot, so
importing or calling rcsim's plotting never switches the backend of a user's notebook, never
pops up a window, and is safe from several threads at once (campaign chunks).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

AXIS_COLORS = {"roll": "tab:blue", "pitch": "tab:orange", "yaw": "tab:green"}

# Jets of each axis by torque sign (Table 2), for plotting only: + jets drawn up, - jets down.
SIGNED_JETS = {
    "roll": ((2, 4), (1, 3)),
    "pitch": ((10, 12), (9, 11)),
    "yaw": ((14, 16), (13, 15)),
}
# First / second jet of a pair (the paper's); a coupled layout has more jets of one sign on an
# axis, drawn in the further colours.
JET_COLORS = ("tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")
# Smallest rate axis span [deg/s]: keeps an idle axis's 1e-30 deg/s numerical noise flat
# instead of autoscaling it to full height.
MIN_RATE_SPAN_DEG_S = 0.05


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize=(8.0, 4.2), **subplot_kw):
    """A constrained-layout :class:`matplotlib.figure.Figure` and its axes (as
    ``pyplot.subplots`` returns them), detached from pyplot: save it with ``fig.savefig``.

    Parameters
    ----------
    nrows, ncols : int
    figsize : (float, float)
        Inches.
    **subplot_kw
        Passed to :meth:`Figure.subplots` (``sharex``, ``squeeze``, ...).
    """
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots(nrows, ncols, **subplot_kw)


def signed_jets_of(jet_signs: np.ndarray) -> dict:
    """:data:`SIGNED_JETS` of a vehicle from its torque signs (``(n_jets, 3)`` in {-1, 0, 1},
    :func:`rcsim.analysis.engine.campaign.outcomes.jet_signs`): per axis, the (1-based) jets that
    torque it positively and negatively (a canted jet appears on every axis it torques)."""
    signs = np.asarray(jet_signs)
    return {
        axis: tuple(tuple(int(j) + 1 for j in np.flatnonzero(signs[:, a] == s)) for s in (1, -1))
        for a, axis in enumerate(("roll", "pitch", "yaw"))
    }


def signed_jets(ax, t, frame, axis: str, *, offset_ms: float = 1.0, signed=None) -> None:
    """Jet on-times of ``axis`` in ms per cycle, + jets up and - jets down (pairs offset);
    ``signed``: the jets by axis and sign (default Table 2's, :data:`SIGNED_JETS`)."""
    for sign, jets in zip((1, -1), (SIGNED_JETS if signed is None else signed)[axis]):
        for k, jet in enumerate(jets):
            on = frame[f"jet_{jet:02d}_on_s"].to_numpy()
            if np.any(on > 0):
                y = sign * (on * 1e3 + offset_ms * k) * (on > 0)
                ax.step(
                    t,
                    y,
                    where="post",
                    lw=0.9,
                    color=JET_COLORS[k % len(JET_COLORS)],
                    ls="-" if sign > 0 else "--",
                    label=f"jet {jet} ({'+' if sign > 0 else '-'})",
                )


def plot_axes_jets(
    frame, path, *, title: str, axes=("roll", "pitch", "yaw"), windows=None, signed=None
) -> None:
    """Per axis: body rate (top) and signed jet commands (bottom), optionally zoomed.

    Parameters
    ----------
    frame : pandas.DataFrame
        :func:`rcsim.analysis.engine.flight.history_frame` output.
    axes : sequence of str
        Axes to show, one column pair of panels each.
    windows : sequence of (t0, t1), optional
        Time windows [s] shown as extra zoomed columns (e.g. the two firings of Figs 5-6).
    signed : dict, optional
        The jets by axis and sign (:func:`signed_jets_of` of the flown vehicle); default Table
        2's (:data:`SIGNED_JETS`).
    """
    spans = [None] + list(windows or [])
    fig, grid = new_figure(
        2 * len(axes),
        len(spans),
        figsize=(max(3.4 * len(spans) + 2.4, 8.0), 1.6 * 2 * len(axes) + 0.6),
        sharex="col",
        squeeze=False,
    )
    t_all = frame["t_s"].to_numpy()
    for c, span in enumerate(spans):
        sel = np.ones_like(t_all, bool) if span is None else (t_all >= span[0]) & (t_all <= span[1])
        t = t_all[sel]
        sub = frame[sel]
        for r, axis in enumerate(axes):
            ax_rate, ax_jet = grid[2 * r, c], grid[2 * r + 1, c]
            rate = sub[f"rate_{axis}_deg_s"].to_numpy()
            ax_rate.plot(
                t, rate, color=AXIS_COLORS[axis], lw=1.2, marker="." if span else None, ms=3
            )
            lo, hi = float(rate.min()), float(rate.max())
            if hi - lo < MIN_RATE_SPAN_DEG_S:
                mid = 0.5 * (hi + lo)
                ax_rate.set_ylim(mid - MIN_RATE_SPAN_DEG_S / 2, mid + MIN_RATE_SPAN_DEG_S / 2)
            ax_rate.grid(alpha=0.3)
            signed_jets(ax_jet, t, sub, axis, signed=signed)
            ax_jet.set_ylim(-48, 48)
            ax_jet.axhline(0.0, color="0.6", lw=0.6)
            ax_jet.grid(alpha=0.3)
            if c == 0:
                ax_rate.set_ylabel(f"{axis} rate\n[deg/s]")
                ax_jet.set_ylabel(f"{axis} jets\n[ms/cycle]")
                if ax_jet.get_legend_handles_labels()[0]:
                    ax_jet.legend(loc="upper right", fontsize=7, ncol=2)
        grid[0, c].set_title(
            "whole flight" if span is None else f"zoom {span[0]:g}-{span[1]:g} s", fontsize=9
        )
        grid[-1, c].set_xlabel("time [s]")
    fig.suptitle(f"{title}: rates and jet commands (+ jets up, - jets down)", fontsize=10)
    fig.savefig(path, dpi=85)  # big multi-panel figure: keeps the PNG under 200 KB


def plot_attitude_error(frame: pd.DataFrame, path, *, title: str = "") -> None:
    """Attitude error per axis versus time (Fig. 1)."""
    fig, ax = new_figure(figsize=(8, 4.2))
    for axis, color in AXIS_COLORS.items():
        ax.plot(frame["t_s"], frame[f"att_err_{axis}_deg"], color=color, label=axis)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("attitude error [deg]")
    ax.set_title(f"{title}: attitude error" if title else "Attitude error")
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    fig.savefig(path, dpi=110)


def plot_rates_and_jets(frame: pd.DataFrame, path, *, title: str = "", signed=None) -> None:
    """Body rate per axis with that axis's jet commands (Fig. 2): :func:`plot_axes_jets`
    over the whole flight (``signed``: the flown vehicle's jets by axis and sign)."""
    plot_axes_jets(frame, path, title=title, signed=signed)
