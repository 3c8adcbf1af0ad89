"""FFD, FB, FFD+FB and hybrid FFD+FB+DAI as one batched step function with explicit state.

Every step ``k`` (time ``t_k``, torque held over ``[t_k, t_k + dt]``):

* observer (001 Eq. 4, :mod:`.observer`) -> ``theta_hat``, ``omega_hat`` per Euler angle, from
  the measurements and torques up to ``k - 1`` (the one step of lag 002 Sec. 4.2 mentions);
* FFD: ``u_ffd = J wd_dot + wd x J wd = Phi_d Theta`` (001 Sec. 2.4, 002 Eq. 8) with the
  desired rates at the middle of the hold, ``t_k + dt/2``: the held torque then integrates the
  continuous feedforward with midpoint-rule accuracy, O(dt^2);
* FB: the PDI of 001 Eq. (3), ``u_fb = Kp (theta_d - theta_hat) + Kd (theta_d' - omega_hat)
  + Ki int(theta_d - theta_hat) dt + w_hat x J w_hat`` per Euler angle (the decoupling term's
  sign is lost in the transcription; + cancels the gyroscopic term of Eq. 1, SOURCES.md);
* DAI (hybrid only), three readings of the papers (``docs/dai.md`` compares them):

  - ``ffd+fb+dai``, the papers' (default): Smeresky & Rizzo Eqs. (9), (13),
    ``Theta_hat = (Phi^T Phi)^-1 Phi^T delta_u`` with ``delta_u`` the *feedback correction*,
    and the learned term ``Phi_d Theta_hat`` added to the command as "an additional control
    input ... in addition to that of our PID algorithm" (Wilt & Sands).  The feedforward keeps
    the model inertia.  Physically: the learned term takes over, along the trajectory's
    regressor, the torque the feedback has been supplying -- an inertia error learned from
    the loop's own corrections.
  - ``ffd+fb+dai-total``, the earlier reading: the self-awareness statement
    ``u = Phi_d Theta_hat`` (001 Eq. 5) solved over the *total* torque applied, for
    ``Theta_hat = Theta_model + dTheta``, and the feedforward then uses ``Theta_hat``.
    Physically: the inertia that explains everything the actuators did, feedback torque
    that is not inertia (noise, disturbances, ringing) included.

  - ``ffd+fb+dai-integral``, 001 App. B's ``Theta_dot`` signal: integral learning
    ``dTheta_hat/dt = g Phi_d^T u_fb`` (one explicit Euler step per control step, after the
    step's torque is computed), with the feedforward flying ``J = J_model + Theta_hat``
    (001 App. A.2, "Learn [J]", adds ``Theta_hat`` to the model's entries).  ``g`` is
    :attr:`ControllerConfig.dai_gain_s3` [s^3].  Physically: a gradient adaptation of the
    feedforward's inertia -- the feedback torque that correlates with the desired
    acceleration (what an inertia error makes the feedback supply) is integrated into the
    estimate, at the rate ``g |Phi_d|^2``; feedback that does not correlate with it (noise,
    ringing) averages out instead of being fitted, no feedback learns nothing, and with no
    desired acceleration (a coast, the quiescent period) the estimate holds.

  The first two solve their statements over every step so far, weighted by
  ``exp(-age / memory)``:
  ``dTheta = W^+ r`` with ``W = sum lam^(k-j) Phi_j^T Phi_j`` and ``r = sum lam^(k-j)
  Phi_j^T y_j`` (``y`` the feedback correction, or ``u - Phi Theta_model``) -- the
  Moore-Penrose solution of the stacked, weighted statements (``(A^T A)^+ A^T = A^+`` for any
  A); directions the trajectory does not excite are not learned.  With no memory (one
  statement) the papers' reading is a projection, ``Phi_d Phi_d^+ u_fb``: for a yaw-only
  trajectory that is the yaw feedback itself whenever the desired acceleration is not zero,
  i.e. a doubled yaw feedback (``tests/lookup/test_continuous_controllers.py``).

Controllers see arrays only: measured Euler angles in, commanded body torque out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcsim.lookup.continuous.observer import observer_matrices, observer_step
from rcsim.lookup.continuous.regression import (
    inertia_from_theta,
    regressor,
    theta_from_inertia,
)
from rcsim.lookup.continuous.trajectory import SinusoidalTrajectory
from rcsim.models.errors import InputError
from rcsim.spacecraft.continuous.kinematics import body_rate_from_euler

METHODS = ("ffd", "fb", "ffd+fb", "ffd+fb+dai", "ffd+fb+dai-total", "ffd+fb+dai-integral")
#: The DAI methods and the learning law each reads from the papers (module docstring).
DAI_LAWS = {
    "ffd+fb+dai": "feedback correction, added to the command (the papers')",
    "ffd+fb+dai-total": "total torque, into the feedforward's inertia",
    "ffd+fb+dai-integral": (
        "integral of the feedback correction, dTheta/dt = g Phi_d^T u_fb, into the "
        "feedforward's inertia (001 App. B Theta_dot)"
    ),
}
#: The DAI method that learns by integration (needs :attr:`ControllerConfig.dai_gain_s3`).
INTEGRAL_LAW = "ffd+fb+dai-integral"
# Relative cut-off of the pseudo-inverse: singular values of W below it (unexcited inertia
# directions; exactly zero for a single-axis trajectory) are dropped.
PINV_RCOND = 1e-10


def dai_update(
    info: np.ndarray,
    rhs: np.ndarray,
    phi_d: np.ndarray,
    u: np.ndarray,
    theta_model: np.ndarray,
    lam: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Add one self-awareness statement ``u = Phi_d (Theta_model + dTheta)`` and re-solve.

    The papers' reading passes the feedback correction as ``u`` and a zero ``theta_model``
    (the statement ``u_fb = Phi_d dTheta``).

    Parameters
    ----------
    info : ndarray, (n_runs, 6, 6); rhs : ndarray, (n_runs, 6)
        Weighted sums ``W`` and ``r`` so far (module docstring).
    phi_d : ndarray, (3, 6) or (n_runs, 3, 6)
        Regression matrix of the desired rates (:func:`.regression.regressor`).
    u : ndarray, (n_runs, 3)
        Torque applied [N m].
    theta_model : ndarray, (6,)
        The model inertia [kg m^2].
    lam : float
        Forgetting factor per statement, in (0, 1].

    Returns
    -------
    info, rhs, d_theta
        Updated sums and ``dTheta = W^+ r`` (Moore-Penrose), (n_runs, 6) [kg m^2].
    """
    phi_b = np.broadcast_to(phi_d, (u.shape[0],) + np.shape(phi_d)[-2:])
    info = lam * info + np.einsum("nki,nkj->nij", phi_b, phi_b)
    resid = u - np.einsum("nki,i->nk", phi_b, theta_model)
    rhs = lam * rhs + np.einsum("nki,nk->ni", phi_b, resid)
    d_theta = np.einsum("nij,nj->ni", np.linalg.pinv(info, rcond=PINV_RCOND, hermitian=True), rhs)
    return info, rhs, d_theta


def integral_update(
    d_theta: np.ndarray, phi_d: np.ndarray, u_fb: np.ndarray, gain_s3: float, dt_s: float
) -> np.ndarray:
    """One explicit Euler step of ``dTheta_hat/dt = g Phi_d^T u_fb`` (001 App. B ``Theta_dot``).

    Parameters
    ----------
    d_theta : ndarray, (n_runs, 6)
        Learned inertia change so far [kg m^2].
    phi_d : ndarray, (3, 6) or (n_runs, 3, 6)
        Regression matrix of the desired rates [rad/s^2].
    u_fb : ndarray, (n_runs, 3)
        Feedback torque of this step [N m].
    gain_s3 : float
        Learning gain ``g`` [s^3] (kg m^2 / s per (rad/s^2 * N m)).
    dt_s : float
        Step [s].

    Returns
    -------
    ndarray, (n_runs, 6)
        ``d_theta + g dt Phi_d^T u_fb`` [kg m^2].  With the feedback supplying an inertia error
        exactly, ``u_fb = Phi_d (dTheta_true - d_theta)``, the error decays by the factor
        ``1 - g dt Phi_d^T Phi_d`` a step: ``exp(-g |Phi_d|^2 t)`` as ``dt -> 0``.
    """
    phi_b = np.broadcast_to(phi_d, (u_fb.shape[0],) + np.shape(phi_d)[-2:])
    return d_theta + (gain_s3 * dt_s) * np.einsum("nki,nk->ni", phi_b, u_fb)


@dataclass(frozen=True)
class ControllerConfig:
    """Parameters of :class:`ContinuousController` (SI).

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    inertia_B : ndarray, (3, 3)
        The controller's model inertia [kg m^2] (the nominal vehicle; never the true one).
    pdi_gains, observer_gains : ndarray, (3,)
        ``(Kp, Kd, Ki)``.
    dt_s : float
        Control (= physics) step [s].
    dai_memory_s : float
        Forgetting time constant of the DAI regression [s] (the first two readings).
    dai_gain_s3 : float or None
        Learning gain ``g`` of the integral reading [s^3] (:func:`integral_update`);
        required by ``ffd+fb+dai-integral`` (``rcsim/models/dai/parameters.csv``,
        ``dai.learning_gain``), unused by the other methods.
    """

    method: str
    inertia_B: np.ndarray
    pdi_gains: np.ndarray
    observer_gains: np.ndarray
    dt_s: float
    dai_memory_s: float = 5.0
    dai_gain_s3: float | None = None

    def __post_init__(self):
        if self.method not in METHODS:
            raise InputError(
                f"must be one of {', '.join(METHODS)}, got {self.method!r}",
                parameter="method",
                value=self.method,
            )
        if not (math.isfinite(self.dt_s) and self.dt_s > 0):
            raise InputError(f"must be > 0, got {self.dt_s}", parameter="dt_s", value=self.dt_s)
        if self.method == INTEGRAL_LAW:
            g = self.dai_gain_s3
            if g is None or isinstance(g, bool) or not (math.isfinite(g) and g > 0):
                raise InputError(
                    f"must be a number > 0 [s^3] for {INTEGRAL_LAW}, got {g!r}",
                    parameter="dai_gain_s3",
                    value=g,
                )


@dataclass
class ControllerState:
    """Explicit controller state, every array (n_runs, ...).

    Attributes
    ----------
    x_hat : (n_runs, 3 axes, 3)
        Observer state (theta_hat, omega_hat, xi) per Euler angle.
    integral : (n_runs, 3)
        Integral of the angle error [rad s].
    u_prev, y_prev : (n_runs, 3)
        Last torque [N m] and measurement [rad] (observer inputs); y_prev NaN before the first.
    info : (n_runs, 6, 6); rhs : (n_runs, 6); d_theta : (n_runs, 6)
        DAI regression sums and the learned inertia change [kg m^2].
    u_fb : (n_runs, 3)
        Last feedback torque [N m] (telemetry).
    """

    x_hat: np.ndarray
    integral: np.ndarray
    u_prev: np.ndarray
    y_prev: np.ndarray
    info: np.ndarray
    rhs: np.ndarray
    d_theta: np.ndarray
    u_fb: np.ndarray


class ContinuousController:
    """Batched FFD / FB / FFD+FB / FFD+FB+DAI controller (module docstring).

    Parameters
    ----------
    config : ControllerConfig
    trajectory : SinusoidalTrajectory
    """

    def __init__(self, config: ControllerConfig, trajectory: SinusoidalTrajectory):
        self.config = config
        self.trajectory = trajectory
        self.theta_model = theta_from_inertia(config.inertia_B)
        self._ad, self._bd, self._ld = observer_matrices(
            np.diag(config.inertia_B), config.observer_gains, config.dt_s
        )
        self._lam = math.exp(-config.dt_s / config.dai_memory_s)
        self._ffd = config.method != "fb"
        self._fb = config.method != "ffd"
        self._dai = config.method in DAI_LAWS
        self._learn_total = config.method == "ffd+fb+dai-total"
        self._learn_integral = config.method == INTEGRAL_LAW
        self._gain_s3 = 0.0 if config.dai_gain_s3 is None else float(config.dai_gain_s3)

    def initial_state(self, n_runs: int) -> ControllerState:
        z3 = np.zeros((n_runs, 3))
        return ControllerState(
            x_hat=np.zeros((n_runs, 3, 3)),
            integral=z3.copy(),
            u_prev=z3.copy(),
            y_prev=np.full((n_runs, 3), np.nan),
            info=np.zeros((n_runs, 6, 6)),
            rhs=np.zeros((n_runs, 6)),
            d_theta=np.zeros((n_runs, 6)),
            u_fb=z3.copy(),
        )

    def step(
        self, t_s: float, euler_meas: np.ndarray, state: ControllerState
    ) -> tuple[np.ndarray, ControllerState]:
        """Commanded body torque [N m] (n_runs, 3) at ``t_s`` from measured Euler angles [rad]."""
        cfg, n = self.config, euler_meas.shape[0]
        if np.isnan(state.y_prev).all():
            # First sample: the observer starts at the measured attitude, at rest (001 App. C
            # and 002 Sec. 3 start every run at rest).
            x_hat = np.zeros((n, 3, 3))
            x_hat[..., 0] = euler_meas
        else:
            x_hat = observer_step(
                state.x_hat, state.u_prev, state.y_prev, self._ad, self._bd, self._ld
            )
        u = np.zeros((n, 3))
        integral, u_fb = state.integral, np.zeros((n, 3))
        if self._fb:
            ang_d, rate_d, _ = self.trajectory.euler(t_s)
            err = ang_d - x_hat[..., 0]
            integral = state.integral + err * cfg.dt_s
            kp, kd, ki = cfg.pdi_gains
            w_hat = body_rate_from_euler(x_hat[..., 0], x_hat[..., 1], np.zeros((n, 3)))[0]
            u_fb = (
                kp * err
                + kd * (rate_d - x_hat[..., 1])
                + ki * integral
                + np.cross(w_hat, w_hat @ cfg.inertia_B.T)
            )
            u = u + u_fb
        info, rhs, d_theta = state.info, state.rhs, state.d_theta
        if self._ffd:
            _, w_d, wdot_d = self.trajectory.body(t_s + 0.5 * cfg.dt_s)
            phi_d = regressor(w_d, wdot_d)  # (3, 6), the same for every run
            # Model feedforward plus the learned term Phi_d dTheta: inside the feedforward's
            # inertia (total-torque and integral readings) or as an added input (the
            # papers'); the same sum.
            u = u + (self.theta_model + d_theta) @ phi_d.T
            if self._dai and np.any(phi_d):
                if self._learn_integral:
                    # After the torque: this step's feedback teaches the next steps.
                    d_theta = integral_update(d_theta, phi_d, u_fb, self._gain_s3, cfg.dt_s)
                elif self._learn_total:
                    info, rhs, d_theta = dai_update(
                        info, rhs, phi_d, u, self.theta_model, self._lam
                    )
                else:
                    info, rhs, d_theta = dai_update(
                        info, rhs, phi_d, u_fb, np.zeros_like(self.theta_model), self._lam
                    )
        return u, ControllerState(
            x_hat=x_hat,
            integral=integral,
            u_prev=u,
            y_prev=np.asarray(euler_meas, float),
            info=info,
            rhs=rhs,
            d_theta=d_theta,
            u_fb=u_fb,
        )

    def telemetry(self, state: ControllerState) -> dict[str, np.ndarray]:
        """Theta_hat (n_runs, 6) [kg m^2] and the feedback torque (n_runs, 3) [N m]."""
        return {"theta_hat": self.theta_model + state.d_theta, "u_fb": state.u_fb}

    def model_inertia(self, state: ControllerState) -> np.ndarray:
        """The controller's current inertia, model + learned, (n_runs, 3, 3) [kg m^2]."""
        return inertia_from_theta(self.theta_model + state.d_theta)
