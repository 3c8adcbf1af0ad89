"""Navigation: attitude and rate errors from the true state (perfect sensors by default).

Quaternions are scalar-first ``[w, x, y, z]`` (MuJoCo's convention) and rotate body-frame
vectors into the inertial frame N: ``q_BN`` is the attitude of B in N.  The attitude error is
the rotation vector of ``q_cmd^-1 * q`` (body relative to the commanded frame; its components
are the same in both frames since a rotation leaves its own axis fixed): positive when the body
is rotated past the command in the positive sense, so a controller drives it to zero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of scalar-first quaternions, shapes (..., 4)."""
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = aw * bw - ax * bx - ay * by - az * bz
    out[..., 1] = aw * bx + ax * bw + ay * bz - az * by
    out[..., 2] = aw * by - ax * bz + ay * bw + az * bx
    out[..., 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (inverse of a unit quaternion), shape (..., 4)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _norm(v: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis, keeping it: (..., k) -> (..., 1)."""
    return np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]


def quat_from_rotvec(v: np.ndarray) -> np.ndarray:
    """Unit quaternion of the rotation vector ``v`` [rad], (..., 3) -> (..., 4)."""
    v = np.asarray(v, float)
    angle = _norm(v)
    out = np.empty(v.shape[:-1] + (4,))
    out[..., 0:1] = np.cos(0.5 * angle)
    # sin(angle/2)/angle = sinc(angle / 2 pi) / 2 with numpy's normalised sinc: exact at zero.
    out[..., 1:] = (0.5 * np.sinc(angle / (2.0 * np.pi))) * v
    return out


def rotvec_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation vector [rad] of a unit quaternion, (..., 4) -> (..., 3), angle in [0, pi]."""
    sign = np.where(q[..., 0:1] < 0, -1.0, 1.0)  # the shorter of the two equivalent rotations
    w = np.minimum(sign * q[..., 0:1], 1.0)
    vec = sign * q[..., 1:]
    s = _norm(vec)
    angle = 2.0 * np.arctan2(s, w)
    # angle / s -> 2 / w as s -> 0 (w -> 1); the guard only avoids 0/0 at exactly zero.
    k = np.divide(angle, s, out=np.full_like(s, 2.0), where=s > 1e-12)
    return k * vec


def euler321_deg(q: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw [deg] (3-2-1 sequence) of ``q_BN``, (..., 4) -> (..., 3)."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.degrees(np.stack([roll, pitch, yaw], axis=-1))


@dataclass(frozen=True)
class Guidance:
    """Commanded attitude and body rate for ``n_runs`` runs.

    The commanded frame starts at ``q_cmd0_BN`` and turns at the constant body rate
    ``omega_cmd_B``: ``q_cmd(t) = q_cmd0 * exp(omega_cmd t / 2)``.  A zero rate is an attitude
    command (a maneuver or a hold); a nonzero rate is a rate command whose attitude follows it,
    so a vehicle flying the commanded rate sees no attitude error.

    Attributes
    ----------
    q_cmd0_BN : ndarray, (n_runs, 4)
    omega_cmd_B : ndarray, (n_runs, 3)  [rad/s]
    """

    q_cmd0_BN: np.ndarray
    omega_cmd_B: np.ndarray

    @classmethod
    def attitude(cls, att_cmd_rad: np.ndarray) -> Guidance:
        """Rest-to-rest maneuver to the rotation vector ``att_cmd_rad`` (n_runs, 3) from
        identity."""
        att = np.atleast_2d(np.asarray(att_cmd_rad, float))
        return cls(quat_from_rotvec(att), np.zeros_like(att))

    @classmethod
    def rate(cls, omega_cmd_B: np.ndarray) -> Guidance:
        """Rate command (n_runs, 3) [rad/s] from the identity attitude."""
        omega = np.atleast_2d(np.asarray(omega_cmd_B, float))
        q0 = np.zeros((omega.shape[0], 4))
        q0[:, 0] = 1.0
        return cls(q0, omega)

    def at(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Commanded ``(q_cmd_BN (n, 4), omega_cmd_B (n, 3))`` at time ``t_s``."""
        if not self.omega_cmd_B.any():  # attitude command: the commanded frame stands still
            return self.q_cmd0_BN, self.omega_cmd_B
        return quat_mul(self.q_cmd0_BN, quat_from_rotvec(self.omega_cmd_B * t_s)), self.omega_cmd_B

    def attitudes_at(self, t_s: np.ndarray) -> np.ndarray:
        """Commanded attitudes at the times ``t_s`` (k,), shape (k, n_runs, 4): :meth:`at` of
        each time in one pass, bit for bit (elementwise numpy, a rotating command only).

        The closed loop takes a block of cycles' commands at once: a rate command's attitude
        per cycle is a dozen numpy calls on (n_runs, 4) arrays (``docs/performance.md``)."""
        t = np.asarray(t_s, float)[:, None, None]
        if not self.omega_cmd_B.any():
            return np.broadcast_to(self.q_cmd0_BN, (t.shape[0],) + self.q_cmd0_BN.shape)
        return quat_mul(self.q_cmd0_BN[None], quat_from_rotvec(self.omega_cmd_B[None] * t))


class CommandBlocks:
    """The commanded attitude of each control cycle of a flight, computed a block of cycles at
    a time and once per distinct command (:meth:`Guidance.attitudes_at`; bit for bit
    :meth:`Guidance.at` of every run): a campaign chunk flies a few cases' commands, and a rate
    command's attitude per cycle was a dozen numpy calls on (n_runs, 4) arrays.

    Parameters
    ----------
    guidance : Guidance
    cycle_s : float
        Control cycle [s]: cycle ``k`` starts at ``k * cycle_s``.
    """

    BLOCK = 64  # cycles per block: (64, distinct commands, 4) floats

    def __init__(self, guidance: Guidance, cycle_s: float):
        self.cycle_s = cycle_s
        self.q0 = guidance.q_cmd0_BN
        self.rotating = bool(guidance.omega_cmd_B.any())
        self.first, self.block = 0, np.empty((0, 0, 4))
        if self.rotating:
            # Distinct commands by their bytes (a signed zero is its own command).
            rows = np.ascontiguousarray(np.hstack([guidance.q_cmd0_BN, guidance.omega_cmd_B]))
            keys = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
            _, index, self.inverse = np.unique(keys, return_index=True, return_inverse=True)
            self.distinct = Guidance(guidance.q_cmd0_BN[index], guidance.omega_cmd_B[index])

    def at(self, k: int) -> np.ndarray:
        """Commanded ``q_cmd_BN`` (n_runs, 4) at cycle ``k``'s start."""
        if not self.rotating:  # attitude commands: the commanded frame stands still
            return self.q0
        if not self.first <= k < self.first + self.block.shape[0]:
            self.first = k
            ticks = np.arange(k, k + self.BLOCK)
            self.block = self.distinct.attitudes_at(ticks * self.cycle_s)
        return self.block[k - self.first][self.inverse]


@dataclass(frozen=True)
class NavState:
    """What a controller sees at the start of a control cycle (arrays over runs).

    Attributes
    ----------
    t_s : float
        Time [s].
    q_BN : ndarray, (n_runs, 4)
    omega_B : ndarray, (n_runs, 3)
        Body rate [rad/s].
    att_err_B : ndarray, (n_runs, 3)
        Attitude error rotation vector [rad] (actual relative to commanded).
    rate_err_B : ndarray, (n_runs, 3)
        ``omega_B - omega_cmd_B`` [rad/s].
    omega_cmd_B : ndarray, (n_runs, 3)
        Commanded body rate [rad/s].
    """

    t_s: float
    q_BN: np.ndarray
    omega_B: np.ndarray
    att_err_B: np.ndarray
    rate_err_B: np.ndarray
    omega_cmd_B: np.ndarray

    @property
    def n_runs(self) -> int:
        return int(self.omega_B.shape[0])


def navigate(t_s: float, q_BN: np.ndarray, omega_B: np.ndarray, guidance: Guidance) -> NavState:
    """Errors of the state ``(q_BN, omega_B)`` against ``guidance`` at time ``t_s``."""
    q_cmd, omega_cmd = guidance.at(t_s)
    att_err = rotvec_from_quat(quat_mul(quat_conj(q_cmd), q_BN))
    return NavState(t_s, q_BN, omega_B, att_err, omega_B - omega_cmd, omega_cmd)
