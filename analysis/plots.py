"""Paper-style plots of one flight (Gambone Figs 1-2, 5-8, 17-20).

Inputs are :func:`analysis.flight.history_frame` tables (degrees, deg/s, seconds).
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # files only; no display on analysis machines or CI
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

AXIS_COLORS = {"roll": "tab:blue", "pitch": "tab:orange", "yaw": "tab:green"}
# Which jets torque which axis (Table 2); used only to group jets in the plots.
AXIS_JETS = {"roll": (1, 2, 3, 4), "pitch": (9, 10, 11, 12), "yaw": (13, 14, 15, 16)}


def plot_attitude_error(frame: pd.DataFrame, path, *, title: str = "") -> None:
    """Attitude error per axis versus time (Fig. 1)."""
    fig, ax = plt.subplots(figsize=(8, 4.2), constrained_layout=True)
    for axis, color in AXIS_COLORS.items():
        ax.plot(frame["t_s"], frame[f"att_err_{axis}_deg"], color=color, label=axis)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("attitude error [deg]")
    ax.set_title(f"{title}: attitude error" if title else "Attitude error")
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_rates_and_jets(frame: pd.DataFrame, path, *, title: str = "") -> None:
    """Body rate per axis with that axis's jet commands (Fig. 2), one panel per axis."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True, constrained_layout=True)
    t = frame["t_s"].to_numpy()
    for ax, (axis, color) in zip(axes, AXIS_COLORS.items()):
        ax.plot(t, frame[f"rate_{axis}_deg_s"], color=color, label=f"{axis} rate")
        ax.set_ylabel(f"{axis} rate [deg/s]")
        ax.grid(alpha=0.3)
        twin = ax.twinx()
        for k, jet in enumerate(AXIS_JETS[axis]):
            on = frame[f"jet_{jet:02d}_on_s"].to_numpy()
            if np.any(on > 0):
                # Offset each jet slightly so overlapping pair commands stay visible.
                twin.step(t, on * 1e3 + 0.6 * k, where="post", lw=0.9, label=f"jet {jet}")
        twin.set_ylabel("on-time [ms/cycle]")
        twin.set_ylim(-2, 50)
        lines = ax.get_legend_handles_labels()
        jets = twin.get_legend_handles_labels()
        ax.legend(lines[0] + jets[0], lines[1] + jets[1], loc="upper right", fontsize=7, ncol=5)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"{title}: rates and jet commands" if title else "Rates and jet commands")
    fig.savefig(path, dpi=110)
    plt.close(fig)
