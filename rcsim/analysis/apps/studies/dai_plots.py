"""Time-history figures of the DAI study (001 Figs. 2-4, 002 Figs. 7-10 style).

Each figure shows the nominal run (row 0 of the batch) of every method of a scenario.  Built
with :func:`rcsim.analysis.engine.plots.new_figure` (matplotlib's object API, never pyplot).
"""

from __future__ import annotations

import numpy as np

from rcsim.analysis.engine.plots import new_figure
from rcsim.spacecraft.continuous.kinematics import angle_between, euler321_from_quat

METHOD_LABELS = {
    "ffd": "FFD",
    "fb": "FB (PDI)",
    "ffd+fb": "FFD + FB",
    "ffd+fb+dai": "FFD + FB + DAI (learns the feedback correction)",
    "ffd+fb+dai-total": "FFD + FB + DAI (learns the total torque)",
    "ffd+fb+dai-integral": "FFD + FB + DAI (integrates the feedback, Theta_dot)",
}
# Floor of the log error axis [deg]: below it the errors are round-off of the attitude.
ERROR_FLOOR_DEG = 1e-12


def _yaw_error_deg(res) -> np.ndarray:
    yaw = euler321_from_quat(res.history.q_BN[0])[:, 2]
    return np.degrees(np.angle(np.exp(1j * (yaw - res.reference["euler"][:, 2]))))


def plot_scenario(name: str, results: list, path) -> None:
    """Yaw angle, |yaw tracking error| (log), principal-angle error and yaw torque vs time."""
    fig, axes = new_figure(4, 1, figsize=(8.0, 9.0), sharex=True)
    t = results[0].history.t_s
    axes[0].plot(t, np.degrees(results[0].reference["euler"][:, 2]), "k--", lw=1.0, label="desired")
    for res in results:
        label = METHOD_LABELS[res.method]
        h = res.history
        axes[0].plot(h.t_s, np.degrees(euler321_from_quat(h.q_BN[0])[:, 2]), lw=1.0, label=label)
        axes[1].semilogy(
            h.t_s, np.maximum(np.abs(_yaw_error_deg(res)), ERROR_FLOOR_DEG), lw=0.8, label=label
        )
        ang = np.degrees(angle_between(h.q_BN[0], res.reference["q"]))
        axes[2].semilogy(h.t_s, np.maximum(ang, ERROR_FLOOR_DEG), lw=0.8, label=label)
        axes[3].plot(h.t_s, h.u_act_B[0, :, 2], lw=0.8, label=label)
    axes[0].set_ylabel("yaw psi [deg]")
    axes[1].set_ylabel("|psi - psi_d| [deg]")
    axes[2].set_ylabel("attitude error [deg]")
    axes[3].set_ylabel("yaw torque [N m]")
    axes[3].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    fig.suptitle(f"{name}: nominal run")
    fig.savefig(path, dpi=110)


def plot_theta_hat(name: str, results: list, path) -> None:
    """Theta_hat (model + learned inertia) of the nominal run vs time, for each DAI reading."""
    fig, axes = new_figure(2, 3, figsize=(10.0, 5.5), sharex=True)
    labels = ("Jxx", "Jxy", "Jxz", "Jyy", "Jyz", "Jzz")
    for res in results:
        if "dai" not in res.method:
            continue
        theta = res.history.telemetry["theta_hat"][0]
        for i, ax in enumerate(axes.ravel()):
            ax.plot(res.history.t_s, theta[:, i], lw=1.0, label=METHOD_LABELS[res.method])
    for i, ax in enumerate(axes.ravel()):
        ax.set_title(f"Theta_hat {labels[i]} [kg m^2]", fontsize=9)
        ax.grid(True, alpha=0.3)
    # In the Jxy panel: a yaw maneuver leaves it flat, so the legend hides no curve.
    axes[0, 1].legend(fontsize=7, loc="lower center")
    for ax in axes[1]:
        ax.set_xlabel("time [s]")
    fig.suptitle(f"{name}: DAI self-awareness estimate (nominal run)")
    fig.savefig(path, dpi=110)


def plot_timestep(coarse, fine, path) -> None:
    """002 Fig. 8: yaw tracking error of FFD+FB at 0.01 s and at 0.001 s."""
    fig, ax = new_figure(1, 1, figsize=(8.0, 4.0))
    for res, label in ((coarse, "0.01 s step"), (fine, "0.001 s step")):
        ax.semilogy(
            res.history.t_s,
            np.maximum(np.abs(_yaw_error_deg(res)), ERROR_FLOOR_DEG),
            lw=0.8,
            label=label,
        )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|psi - psi_d| [deg]")
    ax.set_title("FFD + FB, 30 deg yaw (002): time-step comparison")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=110)
