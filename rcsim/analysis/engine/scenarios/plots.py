"""Plots of the named scenarios and of lookup tables (Gambone Figs 3-4, 17-18).

Single-run scenarios reuse :mod:`rcsim.analysis.engine.plots` (attitude error; rates with jet
commands).  Added here: all runs' rates of a batch (rate damping, Figs 3-4), the attitude-hold
view with the maneuver limit and no-firing region (Figs 17-18), and heat maps of a lookup
table's firing times (Figs 3-4: command vs damping).  Figures are built with matplotlib's
object API (:func:`rcsim.analysis.engine.plots.new_figure`): importing this never touches pyplot's
global state or the user's backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rcsim.analysis.engine.flight import history_frame
from rcsim.analysis.engine.plots import (
    AXIS_COLORS,
    new_figure,
    plot_attitude_error,
    plot_rates_and_jets,
    signed_jets,
)

DPI = 100


def plot_scenario(history, scenario, out_dir, *, title: str, control) -> list[Path]:
    """The plots of one scenario flight into ``out_dir``; returns their paths (``control``:
    the flown vehicle's profile, whose maneuver limit and band the hold view draws)."""
    out_dir = Path(out_dir)
    paths = []
    if history.n_runs > 1:
        paths.append(out_dir / "rates_all_runs.png")
        plot_runs_rates(history, paths[-1], title=title, labels=[r.name for r in scenario.runs])
        return paths
    frame = history_frame(history, 0)
    paths += [out_dir / "attitude_error.png", out_dir / "rates_jets.png"]
    plot_attitude_error(frame, paths[0], title=title)
    plot_rates_and_jets(frame, paths[1], title=title)
    if scenario.name.startswith("attitude-hold"):
        paths.append(out_dir / "hold.png")
        plot_hold(frame, paths[-1], title=title, **hold_lines(scenario, control))
    return paths


def hold_lines(scenario, control) -> dict:
    """The maneuver limit and no-firing band the hold view draws [deg]: the flown profile's,
    the band as the scenario sets it when it does (``no_fire_band_rad``)."""
    band = scenario.lookup_options.get("no_fire_band_rad", control.maneuver_band_rad)
    return {
        "maneuver_limit_deg": float(np.degrees(control.maneuver_limit_rad)),
        "band_deg": float(np.degrees(band)),
    }


def plot_runs_rates(history, path, *, title: str, labels=None) -> None:
    """Body rate of every run per axis versus time (deg/s), one panel per axis."""
    fig, axes = new_figure(3, 1, figsize=(8, 7), sharex=True)
    t = history.t_s
    for a, (ax, (axis, color)) in enumerate(zip(axes, AXIS_COLORS.items())):
        ax.plot(t, np.degrees(history.omega_B[:, :, a]).T, color=color, lw=0.8, alpha=0.6)
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set_ylabel(f"{axis} rate [deg/s]")
        ax.grid(alpha=0.3)
    axes[0].set_title(f"{title}: body rates of {history.n_runs} runs")
    axes[-1].set_xlabel("time [s]")
    fig.savefig(path, dpi=DPI)


def plot_hold(frame, path, *, title: str, maneuver_limit_deg: float, band_deg: float) -> None:
    """Total attitude error with the maneuver limit and no-firing region (shaded when on),
    yaw rate, and signed yaw jet commands (Figs 17-18)."""
    fig, (ax0, ax1, ax2) = new_figure(3, 1, figsize=(8, 7), sharex=True)
    t = frame["t_s"].to_numpy()
    att = np.sqrt(sum(frame[f"att_err_{a}_deg"] ** 2 for a in AXIS_COLORS))
    ax0.plot(t, att, color="k", lw=1.0, label="total attitude error")
    ax0.axhline(maneuver_limit_deg, color="tab:red", lw=1.0, label="maneuver limit")
    if band_deg > 0:
        ax0.axhspan(
            maneuver_limit_deg - band_deg,
            maneuver_limit_deg + band_deg,
            color="tab:red",
            alpha=0.12,
            label=f"no-firing region +-{band_deg:g} deg",
        )
    ax0.set_ylabel("attitude error [deg]")
    ax0.set_ylim(0, max(1.0, float(att.max()) * 1.1))
    ax0.grid(alpha=0.3)
    ax0.legend(loc="lower right", fontsize=8)
    ax0.set_title(f"{title}: attitude hold")
    ax1.plot(t, frame["rate_yaw_deg_s"], color=AXIS_COLORS["yaw"], label="yaw rate")
    ax1.axhline(0.0, color="0.6", lw=0.6)
    ax1.set_ylabel("yaw rate [deg/s]")
    ax1.grid(alpha=0.3)
    signed_jets(ax2, t, frame, "yaw")
    ax2.axhline(0.0, color="0.6", lw=0.6)
    ax2.set_ylim(-48, 48)
    ax2.set_ylabel("yaw jets [ms/cycle]\n(+ up, - down)")
    ax2.grid(alpha=0.3)
    ax2.legend(loc="upper right", fontsize=7, ncol=4)
    ax2.set_xlabel("time [s]")
    fig.savefig(path, dpi=DPI)


def plot_table_heatmap(
    firing_time_s, path, *, title: str, cycle_s: float, rate_cmd_rad_s=None
) -> None:
    """Firing time per case and jet as a heat map annotated in control cycles.

    Parameters
    ----------
    firing_time_s : ndarray, (26, 16)
    cycle_s : float
        The control cycle the annotations count [s] (the generating vehicle's).
    rate_cmd_rad_s : ndarray, (26, 3), optional
        Adds the sign pattern to each case label.
    """
    ft = np.asarray(firing_time_s, float)
    used = np.flatnonzero(ft.any(axis=0))
    fig, ax = new_figure(figsize=(7.5, 8))
    im = ax.imshow(ft[:, used], aspect="auto", cmap="viridis", vmin=0)
    for i in range(ft.shape[0]):
        for k, j in enumerate(used):
            if ft[i, j] > 0:
                ax.text(
                    k,
                    i,
                    f"{ft[i, j] / cycle_s:.0f}",
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="w" if ft[i, j] < 0.7 * ft.max() else "k",
                )
    ax.set_xticks(range(len(used)), [str(j + 1) for j in used])
    labels = [str(c + 1) for c in range(ft.shape[0])]
    if rate_cmd_rad_s is not None:
        sym = {-1: "-", 0: "0", 1: "+"}
        labels = [
            f"{c + 1} ({''.join(sym[int(s)] for s in np.sign(r))})"
            for c, r in enumerate(np.asarray(rate_cmd_rad_s))
        ]
    ax.set_yticks(range(ft.shape[0]), labels, fontsize=7)
    ax.set_xlabel("jet")
    ax.set_ylabel("case (roll, pitch, yaw sign)")
    ax.set_title(title, fontsize=10)
    fig.colorbar(im, ax=ax, label="firing time [s] (numbers: control cycles)")
    fig.savefig(path, dpi=DPI)


def plot_sweep_case(command_hist, damping_hist, case_index: int, path, *, title: str) -> None:
    """Rates and jet commands of one case: from rest to the command (left) and from the
    command rate to rest (right) -- paper Figs 3-4 side by side."""
    fig, axes = new_figure(3, 2, figsize=(10, 7), sharex=True)
    jets_of = {"roll": (1, 2, 3, 4), "pitch": (9, 10, 11, 12), "yaw": (13, 14, 15, 16)}
    for col, (hist, label) in enumerate(
        ((command_hist, "rate command"), (damping_hist, "rate damping"))
    ):
        t = hist.t_s
        n_show = min(len(t), int(np.ceil(0.8 / (t[1] - t[0]))))
        for a, (axis, color) in enumerate(AXIS_COLORS.items()):
            ax = axes[a, col]
            ax.plot(
                t[:n_show],
                np.degrees(hist.omega_B[case_index, :n_show, a]),
                color=color,
                marker=".",
                ms=3,
                label=f"{axis} rate",
            )
            ax.set_ylabel(f"{axis} [deg/s]")
            ax.grid(alpha=0.3)
            twin = ax.twinx()
            for k, jet in enumerate(jets_of[axis]):
                on = hist.on_time_s[case_index, :n_show, jet - 1]
                if on.any():
                    twin.step(
                        t[:n_show], on * 1e3 + 0.8 * k, where="post", lw=0.8, label=f"jet {jet}"
                    )
            twin.set_ylim(-2, 60)
            if col == 1:
                twin.set_ylabel("ms/cycle")
            h0, l0 = ax.get_legend_handles_labels()
            h1, l1 = twin.get_legend_handles_labels()
            ax.legend(h0 + h1, l0 + l1, loc="center right", fontsize=7)
        axes[0, col].set_title(label)
        axes[-1, col].set_xlabel("time [s]")
    fig.suptitle(title)
    fig.savefig(path, dpi=DPI)
