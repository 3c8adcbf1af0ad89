"""Discrete Luenberger observer of each Euler angle (001 Eq. 4; 001 Table 5, 002 Table 1 gains).

Per axis ``i`` the model is the double integrator driven by the commanded torque and an unknown
constant torque ``d`` (the integral channel of the papers' PID-type observer, 002 Fig. 6):
``theta' = omega``, ``omega' = (u + d) / J_ii``, ``d' = 0``; only the angle is measured.  Its
exact zero-order-hold discretization over the step gives ``Ad`` and ``Bd``, and the observer
is 001 Eq. (4) verbatim::

    x_hat(k+1) = Ad x_hat(k) + Bd u(k) + Ld (y(k) - C x_hat(k)),   x = (theta, omega, d)

The gains set the estimation-error poles: a continuous PID observer with gains
``(Kp, Kd, Ki)`` has the error polynomial ``J s^3 + Kd s^2 + Kp s + Ki``; ``Ld`` places the
discrete poles at ``exp(s_i dt)`` of its roots (Ackermann's formula).  Discretizing the
continuous observer itself instead (a zero-order hold on the *measurement*) would bias the
estimate by about ``omega dt / 2`` -- the angle moves during the step while the held sample
does not -- which at the papers' gains is larger than the tracking errors being compared;
with pole placement the error dynamics are ``e(k+1) = (Ad - Ld C) e(k)`` exactly.
"""

from __future__ import annotations

import numpy as np

_C = np.array([1.0, 0.0, 0.0])


def error_poles(j: float, gains: np.ndarray) -> np.ndarray:
    """Continuous error poles [1/s] of the PID observer: roots of J s^3 + Kd s^2 + Kp s + Ki."""
    kp, kd, ki = gains
    return np.roots([j, kd, kp, ki])


def observer_matrices(
    j_axis: np.ndarray, gains: np.ndarray, dt_s: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ad (3, 3, 3), Bd (3, 3), Ld (3, 3) for the three axes (first index: axis).

    Parameters
    ----------
    j_axis : ndarray, (3,)
        Model inertia of each axis [kg m^2] (the diagonal of the nominal J).
    gains : ndarray, (3,)
        Observer ``(Kp, Kd, Ki)``.
    dt_s : float
        Step [s].
    """
    ad, bd, ld = np.empty((3, 3, 3)), np.empty((3, 3)), np.empty((3, 3))
    for axis, j in enumerate(j_axis):  # three axes, once at construction
        a = np.array([[1.0, dt_s, dt_s**2 / (2 * j)], [0.0, 1.0, dt_s / j], [0.0, 0.0, 1.0]])
        ad[axis] = a
        bd[axis] = [dt_s**2 / (2 * j), dt_s / j, 0.0]
        # Ackermann: L = p(A) O^-1 e3, p the desired characteristic polynomial.
        coeffs = np.real(np.poly(np.exp(error_poles(j, gains) * dt_s)))
        p_a = sum(c * np.linalg.matrix_power(a, 3 - i) for i, c in enumerate(coeffs))
        obs = np.stack([_C, _C @ a, _C @ a @ a])
        ld[axis] = p_a @ np.linalg.solve(obs, np.array([0.0, 0.0, 1.0]))
    return ad, bd, ld


def observer_step(
    x_hat: np.ndarray, u: np.ndarray, y: np.ndarray, ad: np.ndarray, bd: np.ndarray, ld: np.ndarray
) -> np.ndarray:
    """One step of Eq. (4) for every run and axis.

    Parameters
    ----------
    x_hat : ndarray, (n_runs, 3 axes, 3 states)
        (theta [rad], omega [rad/s], d [N m]) per axis.
    u, y : ndarray, (n_runs, 3)
        Torque held over the step [N m] and measured angles [rad].
    ad, bd, ld : from :func:`observer_matrices`

    Returns
    -------
    ndarray, (n_runs, 3, 3)
        The next estimate.
    """
    # Innovation wrapped to (-pi, pi]: a measured angle that wraps at +-180 deg is not a jump.
    innovation = np.angle(np.exp(1j * (y - x_hat[..., 0])))
    return (
        np.einsum("aij,naj->nai", ad, x_hat)
        + bd[None] * u[..., None]
        + ld[None] * innovation[..., None]
    )
