"""Independent reference for the closed loop: replay a flight's jet commands with SciPy DOP853.

Given what a flight's jets delivered in each control cycle (``History.on_time_s``: with no
valve delays, jet ``j`` is on over ``[0, on_time]`` of each cycle) and its disturbance torque,
integrate the rigid-body attitude equations

    q' = q (0, w) / 2,        I w' = tau(t) - w x I w,

with ``tau(t)`` the sum of the torques about the CG of the jets on at ``t``
(:func:`rcsim.spacecraft.vehicle.run_parameters.torque_per_jet_B`, built from the MJCF geometry but
never from MuJoCo's integrator) plus the disturbance, by DOP853 (rtol 1e-12, atol 1e-14) *between
the exact switch instants*, so the forcing is constant in every integration interval.  The result
is the attitude at every cycle boundary: what the simulation should have produced for the same
commands.  Used by ``benchmarks/convergence.py``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from rcsim.spacecraft.navigation import quat_mul
from rcsim.spacecraft.vehicle.run_parameters import RunParameters, torque_per_jet_B

RTOL, ATOL = 1e-12, 1e-14


def _rhs(inertia: np.ndarray, torque: np.ndarray):
    def f(_, x):
        q, w = x[:4], x[4:]
        dq = 0.5 * quat_mul(q, np.concatenate([[0.0], w]))
        dw = (torque - np.cross(w, inertia * w)) / inertia
        return np.concatenate([dq, dw])

    return f


def replay_run(
    params: RunParameters,
    model,
    on_time_s: np.ndarray,
    cycle_s: float,
    q0: np.ndarray,
    w0: np.ndarray,
    disturbance_n_m: np.ndarray,
) -> np.ndarray:
    """Attitude at every cycle boundary of one run, ``(n_cycles + 1, 4)``.

    Parameters
    ----------
    params : RunParameters
        One run.
    on_time_s : ndarray, (n_cycles, 16)
        Delivered on-time per cycle [s] (jets on from each cycle's start).
    q0, w0 : ndarray, (4,), (3,)
        Initial attitude and body rate [rad/s].
    disturbance_n_m : ndarray, (3,)
        Constant body-frame torque [N m].
    """
    tau_j = torque_per_jet_B(params, model)[0]  # (16, 3)
    inertia = params.inertia_B[0]
    x = np.concatenate([q0, w0]).astype(float)
    out = [x[:4].copy()]
    for on in on_time_s:
        cuts = np.unique(np.concatenate([[0.0, cycle_s], on[(on > 0) & (on < cycle_s)]]))
        for a, b in zip(cuts[:-1], cuts[1:]):
            mid = 0.5 * (a + b)
            torque = tau_j[on > mid].sum(axis=0) + disturbance_n_m
            x = solve_ivp(
                _rhs(inertia, torque), (a, b), x, method="DOP853", rtol=RTOL, atol=ATOL
            ).y[:, -1]
        x[:4] /= np.linalg.norm(x[:4])
        out.append(x[:4].copy())
    return np.array(out)
