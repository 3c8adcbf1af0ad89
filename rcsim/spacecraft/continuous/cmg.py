"""Three single-gimbal control moment gyroscopes (Smeresky & Rizzo 2020, Sec. 2.1-2.2).

Geometry.  CMG ``i`` carries a rotor of momentum ``h0`` whose direction turns with its gimbal
angle ``theta_i`` about a body-fixed gimbal axis set by the skew angle ``beta_i``.  The unit
momenta are

    h1 = ( c1,       -cb1 s1,  sb1 s1)
    h2 = (-cb2 s2,   -c2,      sb2 s2)
    h3 = (-c3,        cb3 s3,  sb3 s3)

(``c1 = cos theta_1``, ``cb1 = cos beta_1``...), whose gimbal Jacobian ``A = dh/dtheta`` is
002's Eq. (3) as we read it (rcsim/models/dai/SOURCES.md: the transcription lost its signs; these
are the signs of Wie's pyramid Jacobian, with 002's row order).  Each ``h_i`` is a unit vector
perpendicular to a fixed gimbal axis, so this is a physical array.  With every
``beta = 90 deg``, ``det A = -sin(theta_2) sin(theta_1 + theta_3)`` (Eq. 7 specialised), zero
at 002's example ``theta = 0``.

Steering.  The torque the array puts on the rigid body is ``tau = -h0 A theta_dot - omega x h``
(the body-frame derivative of the rotor momentum and its transport term: Euler's Eq. (1) of
002 with ``H_s = J omega + h``).  For a commanded torque ``u`` the inverse steering law (Eq. 4)
is ``theta_dot = -A^+ (u + omega x h) / h0`` with the Moore-Penrose pseudo-inverse ``A^+``, so
``tau = u`` exactly wherever ``A`` has full rank.  Gimbals are perfect (002: "the actuator is
assumed to be perfect and produces the actual gimbal rate commanded"), gimbal rates unlimited.

Singularities.  A gimbal set is flagged singular when ``|det A| < singular_det`` (Eq. 7).  There
the steering switches to the singularity-robust inverse ``A^T (A A^T + lam I)^-1`` with
``lam = SR_DAMPING``: it keeps gimbal rates bounded through and at the singular set, at the
cost of a torque error along the singular direction, which the delivered torque reports
honestly (the plant flies ``tau``, not ``u``).  An exactly singular ``A`` never produces a
non-finite rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcsim.models.dai import CmgSetup

# Damping of the singularity-robust inverse inside the flagged set [1] (unit-momentum A):
# small enough that the delivered torque stays within 1 % of the command at |det A| = 0.05,
# large enough to bound |theta_dot| <= |u| / (2 h0 sqrt(lam)) at an exact singularity.
SR_DAMPING = 1e-3


def unit_momenta(theta: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Unit rotor momenta, body axes: (..., 3 gimbals) -> (..., 3 components, 3 gimbals)."""
    s, c = np.sin(theta), np.cos(theta)
    sb, cb = np.sin(beta), np.cos(beta)
    h1 = np.stack([c[..., 0], -cb[..., 0] * s[..., 0], sb[..., 0] * s[..., 0]], -1)
    h2 = np.stack([-cb[..., 1] * s[..., 1], -c[..., 1], sb[..., 1] * s[..., 1]], -1)
    h3 = np.stack([-c[..., 2], cb[..., 2] * s[..., 2], sb[..., 2] * s[..., 2]], -1)
    return np.stack([h1, h2, h3], axis=-1)


def jacobian(theta: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """002 Eq. (3): ``A = dh/dtheta`` of unit momenta, (..., 3) -> (..., 3, 3) (column i: CMG i)."""
    s, c = np.sin(theta), np.cos(theta)
    sb, cb = np.sin(beta), np.cos(beta)
    col1 = np.stack([-s[..., 0], -cb[..., 0] * c[..., 0], sb[..., 0] * c[..., 0]], -1)
    col2 = np.stack([-cb[..., 1] * c[..., 1], s[..., 1], sb[..., 1] * c[..., 1]], -1)
    col3 = np.stack([s[..., 2], cb[..., 2] * c[..., 2], sb[..., 2] * c[..., 2]], -1)
    return np.stack([col1, col2, col3], axis=-1)


def determinant(theta: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """002 Eq. (7): det A of the unit-momentum Jacobian, (..., 3) -> (...)."""
    return np.linalg.det(jacobian(theta, beta))


@dataclass
class CmgState:
    """Gimbal angles of every run [rad], (n_runs, 3)."""

    theta: np.ndarray


@dataclass(frozen=True)
class CmgOutput:
    """One steering step, every array (n_runs, ...).

    Attributes
    ----------
    torque_B : (n_runs, 3)
        Torque delivered to the rigid body [N m].
    gimbal_rate : (n_runs, 3)
        Commanded (= actual) gimbal rates [rad/s].
    det : (n_runs,)
        det A at the start of the step.
    singular : (n_runs,) bool
        ``|det A| < singular_det``: steered by the singularity-robust inverse.
    """

    torque_B: np.ndarray
    gimbal_rate: np.ndarray
    det: np.ndarray
    singular: np.ndarray


class CmgArray:
    """Three SGCMGs per run, steered by the pseudo-inverse law (module docstring).

    Parameters
    ----------
    setup : CmgSetup
        Skew and initial gimbal angles, rotor momentum, singular threshold.
    """

    def __init__(self, setup: CmgSetup):
        self.setup = setup

    def initial_state(self, n_runs: int) -> CmgState:
        return CmgState(theta=np.tile(self.setup.gimbal0_rad, (n_runs, 1)))

    def momentum_B(self, state: CmgState) -> np.ndarray:
        """Total rotor momentum of each run's array, body axes [N m s], (n_runs, 3)."""
        return self.setup.wheel_momentum_nms * unit_momenta(state.theta, self.setup.skew_rad).sum(
            -1
        )

    def steer(
        self, u_B: np.ndarray, omega_B: np.ndarray, state: CmgState, dt_s: float
    ) -> tuple[CmgOutput, CmgState]:
        """Gimbal rates for the commanded torque ``u_B`` held over ``dt_s``; the torque they give.

        Parameters
        ----------
        u_B, omega_B : ndarray, (n_runs, 3)
            Commanded body torque [N m] and body rate [rad/s].
        state : CmgState
        dt_s : float
            Hold time [s]; the gimbals turn at the computed rate over it.
        """
        h0, beta = self.setup.wheel_momentum_nms, self.setup.skew_rad
        a = jacobian(state.theta, beta)
        det = np.linalg.det(a)
        singular = np.abs(det) < self.setup.singular_det
        h = self.momentum_B(state)
        wanted = -(np.asarray(u_B, float) + np.cross(omega_B, h)) / h0  # required dh/dt / h0
        # Moore-Penrose pseudo-inverse (SVD; for a full-rank square A it is A^-1); inside the
        # flagged set the singularity-robust inverse bounds the rates.
        pinv = np.linalg.pinv(a)
        if singular.any():
            at = np.swapaxes(a[singular], -1, -2)
            pinv[singular] = at @ np.linalg.inv(a[singular] @ at + SR_DAMPING * np.eye(3))
        rate = np.einsum("nij,nj->ni", pinv, wanted)
        torque = -h0 * np.einsum("nij,nj->ni", a, rate) - np.cross(omega_B, h)
        out = CmgOutput(torque_B=torque, gimbal_rate=rate, det=det, singular=singular)
        return out, CmgState(theta=state.theta + rate * dt_s)
