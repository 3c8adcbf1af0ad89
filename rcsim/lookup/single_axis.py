"""Single-axis rest-to-rest control laws of Pittella & Sands (Sensors 2023, 23, 3169).

The task (paper Eqs. 1-6) is nondimensional: rotate one unit of angle in one unit of time,
rest to rest, ``theta(0) = omega(0) = 0``, ``theta(1) = theta_d = 1``, ``omega(1) = 0``, for
a rigid body ``dtheta/dt = omega``, ``domega/dt = u / I`` with cost ``J = 1/2 int_0^1 u^2 dt``
of the *commanded* control ``u``.  Angles are in units of ``theta_d`` (radians when
``theta_d`` is given in radians), times in units of the manoeuvre time, ``u`` in units of
``theta_d`` per time squared times inertia.

Every architecture is a batched, continuous-time control law

    ``u, state_dot = law(t, theta_m, omega_m, state, params)``

over ``n_runs`` Monte Carlo runs at once: ``t`` is a scalar time, ``theta_m`` and
``omega_m`` are the *measured* (noisy) angle and rate, shape ``(n_runs,)``, ``state`` is the
controller's own state, shape ``(n_runs, n_states)`` (``n_states`` may be 0), ``u`` has
shape ``(n_runs,)`` and ``state_dot`` (the time derivative of ``state``) has the shape of
``state``.  The integrator evaluates the law at each Runge-Kutta stage and advances the
controller state together with the plant, as Simulink's ``ode4`` does for the paper's
continuous blocks.  Laws are pure: no globals, no hidden memory, no loop over runs.

Interpretations of the paper (see ``docs/noisy-sensor.md``):

* Eq. 6 reads ``u = (1/I) domega/dt`` (i.e. ``domega/dt = I u``); we use the physical
  ``domega/dt = u / I`` (torque = inertia x angular acceleration).  The integrator owns it.
* The patching filters are fed by the open-loop optimal ``u*`` (Eq. 12), never by
  measurements: the measurements enter only through the P+V law they feed (Eq. 14).
* Eq. 15 is evaluated with the *optimal* ``omega*`` and ``theta*`` (the paper: "entering the
  optimal values u*, omega*, theta*"), i.e. the transfer function of Eqs. 16-17.
* RTOC switches to open loop when ``|det A(t0)|`` of Eq. 13 drops below
  :data:`RTOC_DET_MIN`; because ``det A(t0) = (1 - t0)^4 / 12`` depends on time only, the
  switch is a function of ``t`` and needs no latch state.

References
----------
A. Pittella and T. Sands, "Proposals for Surmounting Sensor Noises", Sensors 23 (2023)
3169: Eqs. 1-6 (task), 7-9 (P+V gains), 10-12 (open-loop optimal), 13 (RTOC), 14-17
(control-law inversion), Section 2.5-2.6 (double-integrator filters), Table 1 (gains).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: Default RTOC switch threshold on ``|det A(t0)|`` (Eq. 13).  ``det A = T^4 / 12`` with
#: ``T = 1 - t0`` the time to go, so 1e-5 switches at ``T = (12e-5)^(1/4) ~= 0.105``.  Why
#: there: the re-solved control's gain on the measured angle is ``6 / T^2``; with the paper's
#: sensor (standard deviation 0.01) the noise-driven command ``6 * 0.01 / T^2`` equals the
#: peak optimal command ``|u*|max = 6`` at ``T = 0.1``, so past that point RTOC mostly
#: steers on noise.  The value sits between the RK4 stage times 0.895 and 0.9 (stages fall
#: on multiples of 0.005), so rounding never decides which side a stage lands on.
RTOC_DET_MIN = 1e-5


# --------------------------------------------------------------------------------------
# Open-loop optimal solution (paper Eqs. 10-12) and its integrals.
# --------------------------------------------------------------------------------------
def optimal_control(t, theta_d: float = 1.0):
    """Open-loop optimal control ``u*(t) = theta_d (6 - 12 t)`` (paper Eq. 12).

    Parameters
    ----------
    t : float or ndarray
        Nondimensional time in [0, 1].
    theta_d : float
        Commanded rotation (nondimensional, 1 in the paper).

    Returns
    -------
    float or ndarray
        Control, same shape as ``t``.
    """
    return theta_d * (6.0 - 12.0 * np.asarray(t, dtype=float))


def optimal_rate(t, theta_d: float = 1.0):
    """Optimal rate ``omega*(t) = theta_d (6 t - 6 t^2)``, the integral of Eq. 12 (I = 1)."""
    t = np.asarray(t, dtype=float)
    return theta_d * (6.0 * t - 6.0 * t**2)


def optimal_angle(t, theta_d: float = 1.0):
    """Optimal angle ``theta*(t) = theta_d (3 t^2 - 2 t^3)``, the double integral of Eq. 12."""
    t = np.asarray(t, dtype=float)
    return theta_d * (3.0 * t**2 - 2.0 * t**3)


# --------------------------------------------------------------------------------------
# P+V gain design (paper Eqs. 7-9).
# --------------------------------------------------------------------------------------
def pv_gains(settling_time: float = 1.0, zeta: float = 0.7, tolerance: float = 0.02):
    """Unrounded P+V gains for a settling time and damping ratio (paper Eqs. 7-9).

    Eq. 7 solved for ``omega_n``: ``omega_n = -ln(tol sqrt(1 - zeta^2)) / (zeta t_s)``;
    then ``K_P = omega_n^2`` (Eq. 8) and ``K_V = 2 zeta sqrt(K_P)`` (Eq. 9).

    Parameters
    ----------
    settling_time : float
        Settling time (nondimensional time units).
    zeta : float
        Damping ratio, in (0, 1).
    tolerance : float
        Settling band as a fraction of the step (0.02 for the 2 % criterion).

    Returns
    -------
    tuple of float
        ``(K_P, K_V)``; the paper rounds them to 37 and 8.5.
    """
    omega_n = -np.log(tolerance * np.sqrt(1.0 - zeta**2)) / (zeta * settling_time)
    kp = omega_n**2
    return float(kp), float(2.0 * zeta * np.sqrt(kp))


def pv_damping(kp: float, kv: float) -> float:
    """Damping ratio ``zeta = K_V / (2 sqrt(K_P))`` of the P+V loop (paper Eq. 9, I = 1)."""
    return float(kv / (2.0 * np.sqrt(kp)))


def pv_settling_time(kp: float, kv: float, tolerance: float = 0.02) -> float:
    """Envelope settling time of the P+V loop from paper Eq. 7 (nondimensional time)."""
    zeta = pv_damping(kp, kv)
    return float(-np.log(tolerance * np.sqrt(1.0 - zeta**2)) / (zeta * np.sqrt(kp)))


# --------------------------------------------------------------------------------------
# RTOC linear system (paper Eq. 13).
# --------------------------------------------------------------------------------------
def rtoc_matrix(t0: float) -> np.ndarray:
    """Matrix ``A(t0)`` of paper Eq. 13, shape (4, 4), unknowns ``(a, b, c, d)``.

    Rows: angle and rate of the cubic ``theta(t) = a t^3/6 + b t^2/2 + c t + d`` at ``t0``,
    then at the final time 1.  ``t0 = 0`` gives Eq. 11.
    """
    return np.array(
        [
            [t0**3 / 6.0, t0**2 / 2.0, t0, 1.0],
            [t0**2 / 2.0, t0, 1.0, 0.0],
            [1.0 / 6.0, 0.5, 1.0, 1.0],
            [0.5, 1.0, 1.0, 0.0],
        ]
    )


# --------------------------------------------------------------------------------------
# Parameters (frozen dataclasses).
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PVParams:
    """Gains of a P+V loop ``u = K_P (theta_ref - theta) - K_V omega`` (paper Eq. 14).

    Attributes
    ----------
    kp : float
        Proportional gain (1 / time^2, nondimensional).
    kv : float
        Velocity gain on the measured rate, not the rate error (1 / time).
    theta_d : float
        Commanded rotation (nondimensional).
    """

    kp: float = 37.0
    kv: float = 8.5
    theta_d: float = 1.0


@dataclass(frozen=True)
class OpenLoopParams:
    """Open-loop optimal control; ``theta_d`` is the commanded rotation (nondimensional)."""

    theta_d: float = 1.0


@dataclass(frozen=True)
class RTOCParams:
    """Real-time optimal control (paper Eq. 13).

    Attributes
    ----------
    theta_d : float
        Commanded rotation (nondimensional).
    det_min : float
        Switch to open-loop optimal control once ``|det A(t0)| < det_min``; see
        :data:`RTOC_DET_MIN` for the default and why.
    """

    theta_d: float = 1.0
    det_min: float = RTOC_DET_MIN


# --------------------------------------------------------------------------------------
# Control laws: u, state_dot = law(t, theta_m, omega_m, state, params).
# --------------------------------------------------------------------------------------
def _no_state(theta_m: np.ndarray) -> np.ndarray:
    return np.empty((theta_m.shape[0], 0))


def pv_law(t, theta_m, omega_m, state, params: PVParams):
    """P+V control to the constant command ``theta_d`` (paper Eq. 14); stateless.

    Parameters
    ----------
    t : float
        Time (unused; kept for the common signature).
    theta_m, omega_m : ndarray, shape (n_runs,)
        Measured angle and rate.
    state : ndarray, shape (n_runs, 0)
        No controller state.
    params : PVParams

    Returns
    -------
    u : ndarray, shape (n_runs,)
    state_dot : ndarray, shape (n_runs, 0)
    """
    u = params.kp * (params.theta_d - theta_m) - params.kv * omega_m
    return u, _no_state(theta_m)


def open_loop_law(t, theta_m, omega_m, state, params: OpenLoopParams):
    """Open-loop optimal control ``u*(t)`` (paper Eq. 12); ignores the measurements."""
    u = np.full(theta_m.shape, optimal_control(t, params.theta_d))
    return u, _no_state(theta_m)


def rtoc_law(t, theta_m, omega_m, state, params: RTOCParams):
    """Real-time optimal control: re-solve paper Eq. 13 from the measured state.

    ``A(t) (a, b, c, d) = (theta_m, omega_m, theta_d, 0)`` is solved for all runs at once
    (one matrix, ``n_runs`` right-hand sides) and ``u = a t + b`` (Eq. 10).  Once
    ``|det A(t)| < params.det_min`` the law returns the open-loop optimal ``u*(t)``.

    Returns
    -------
    u : ndarray, shape (n_runs,)
    state_dot : ndarray, shape (n_runs, 0)
    """
    matrix = rtoc_matrix(float(t))
    if abs(np.linalg.det(matrix)) < params.det_min:
        return open_loop_law(t, theta_m, omega_m, state, OpenLoopParams(params.theta_d))
    rhs = np.stack(
        [theta_m, omega_m, np.full_like(theta_m, params.theta_d), np.zeros_like(theta_m)]
    )
    coeffs = np.linalg.solve(matrix, rhs)  # (4, n_runs): a, b, c, d per run
    return coeffs[0] * t + coeffs[1], _no_state(theta_m)


def double_integrator_law(t, theta_m, omega_m, state, params: PVParams):
    """P+V tracking the twice-integrated optimal control (paper Section 2.5).

    The patching filter integrates ``u*(t)`` twice; its state is ``(omega*, theta*)`` and
    ``theta*`` replaces ``theta_d`` in Eq. 14.  The velocity term still acts on the measured
    rate, not on the rate error, as Eq. 14 prescribes.

    Parameters
    ----------
    state : ndarray, shape (n_runs, 2)
        Filter integrator states ``(omega*, theta*)``.

    Returns
    -------
    u : ndarray, shape (n_runs,)
    state_dot : ndarray, shape (n_runs, 2)
        ``(u*, omega*)``.
    """
    u_star = optimal_control(t, params.theta_d)
    u = params.kp * (state[:, 1] - theta_m) - params.kv * omega_m
    return u, _filter_derivative(u_star, state)


def control_inversion_law(t, theta_m, omega_m, state, params: PVParams):
    """P+V fed through the control-law-inversion patching filter (paper Eqs. 14-17).

    The filter ``Theta_d(s) / U*(s) = (s^2 + K_V s + K_P) / (K_P s^2)`` (Eq. 17) is
    realised as the same double integrator of ``u*`` plus feedthrough,
    ``theta_ref = u*/K_P + (K_V/K_P) omega* + theta*`` (Eq. 15 with optimal values), so that
    ``u = u* + K_P (theta* - theta_m) + K_V (omega* - omega_m)``: the optimal control plus a
    tracking correction that vanishes on the optimal trajectory.

    Parameters
    ----------
    state : ndarray, shape (n_runs, 2)
        Filter integrator states ``(omega*, theta*)``.

    Returns
    -------
    u : ndarray, shape (n_runs,)
    state_dot : ndarray, shape (n_runs, 2)
    """
    u_star = optimal_control(t, params.theta_d)
    theta_ref = u_star / params.kp + (params.kv / params.kp) * state[:, 0] + state[:, 1]
    u = params.kp * (theta_ref - theta_m) - params.kv * omega_m
    return u, _filter_derivative(u_star, state)


def _filter_derivative(u_star: float, state: np.ndarray) -> np.ndarray:
    """Derivative of the double-integrator filter state ``(omega*, theta*)``."""
    state_dot = np.empty_like(state)
    state_dot[:, 0] = u_star
    state_dot[:, 1] = state[:, 0]
    return state_dot


# --------------------------------------------------------------------------------------
# The six architectures of the paper, in the order of its Table 1.
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Architecture:
    """One control architecture: a law, its parameters and its state size.

    Attributes
    ----------
    key : str
        Machine name (``pv``, ``open_loop``, ...).
    label : str
        Row name of the paper's Table 1.
    law : callable
        ``u, state_dot = law(t, theta_m, omega_m, state, params)``.
    params : frozen dataclass
    n_states : int
        Rows of the controller state array.
    """

    key: str
    label: str
    law: Callable
    params: object
    n_states: int = 0

    def initial_state(self, n_runs: int) -> np.ndarray:
        """Controller state at rest, shape ``(n_runs, n_states)``."""
        return np.zeros((n_runs, self.n_states))

    def __call__(self, t, theta_m, omega_m, state):
        return self.law(t, theta_m, omega_m, state, self.params)


#: Gains the paper tuned by hand for the double-integrator filter (Table 1 note 2).
TUNED_GAINS = PVParams(kp=78.0, kv=0.65)

ARCHITECTURES: tuple[Architecture, ...] = (
    Architecture("pv", "P+V", pv_law, PVParams()),
    Architecture("open_loop", "Open-loop optimal", open_loop_law, OpenLoopParams()),
    Architecture("rtoc", "RTOC", rtoc_law, RTOCParams()),
    Architecture("double_integrator", "Double integrator", double_integrator_law, PVParams(), 2),
    Architecture(
        "double_integrator_tuned", "Double int., tuned", double_integrator_law, TUNED_GAINS, 2
    ),
    Architecture("control_inversion", "Control inversion", control_inversion_law, PVParams(), 2),
)
