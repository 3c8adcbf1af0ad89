"""3-2-1 Euler angles, quaternions and body rates, batched over runs.

Quaternions are scalar-first ``[w, x, y, z]`` (MuJoCo's) and give the body attitude in the
inertial frame N: ``v_N = R(q) v_B``.  Euler angles ``(phi, theta, psi)`` are the 3-2-1
(yaw-pitch-roll) sequence, ``R_NB = Rz(psi) Ry(theta) Rx(phi)``, as 002 Sec. 3 resolves them
("a 3-2-1 rotation sequence with the atan2 trigonometry function").
"""

from __future__ import annotations

import numpy as np


def euler321_from_quat(q: np.ndarray) -> np.ndarray:
    """Euler angles (phi, theta, psi) [rad] of quaternions ``q`` (..., 4) -> (..., 3)."""
    w, x, y, z = np.moveaxis(np.asarray(q, float), -1, 0)
    phi = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    theta = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    psi = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([phi, theta, psi], axis=-1)


def quat_from_euler321(euler: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4) of 3-2-1 Euler angles (..., 3) [rad]."""
    half = 0.5 * np.asarray(euler, float)
    c, s = np.cos(half), np.sin(half)
    c1, c2, c3 = np.moveaxis(c, -1, 0)
    s1, s2, s3 = np.moveaxis(s, -1, 0)
    return np.stack(
        [
            c1 * c2 * c3 + s1 * s2 * s3,
            s1 * c2 * c3 - c1 * s2 * s3,
            c1 * s2 * c3 + s1 * c2 * s3,
            c1 * c2 * s3 - s1 * s2 * c3,
        ],
        axis=-1,
    )


def body_rate_from_euler(
    euler: np.ndarray, euler_rate: np.ndarray, euler_acc: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Body rate and its derivative from 3-2-1 Euler angles and their derivatives.

    Parameters
    ----------
    euler, euler_rate, euler_acc : ndarray, (..., 3)
        (phi, theta, psi) [rad], their rates [rad/s] and accelerations [rad/s^2].

    Returns
    -------
    omega_B, omega_dot_B : ndarray, (..., 3)
        [rad/s], [rad/s^2].  omega = (phi' - psi' s_th, th' c_ph + psi' c_th s_ph,
        psi' c_th c_ph - th' s_ph) and its time derivative (product rule).
    """
    ph, th, _ = np.moveaxis(np.asarray(euler, float), -1, 0)
    dph, dth, dps = np.moveaxis(np.asarray(euler_rate, float), -1, 0)
    aph, ath, aps = np.moveaxis(np.asarray(euler_acc, float), -1, 0)
    sph, cph, sth, cth = np.sin(ph), np.cos(ph), np.sin(th), np.cos(th)
    omega = np.stack(
        [dph - dps * sth, dth * cph + dps * cth * sph, dps * cth * cph - dth * sph], axis=-1
    )
    omega_dot = np.stack(
        [
            aph - aps * sth - dps * dth * cth,
            ath * cph
            - dth * dph * sph
            + aps * cth * sph
            - dps * dth * sth * sph
            + dps * dph * cth * cph,
            aps * cth * cph
            - dps * dth * sth * cph
            - dps * dph * cth * sph
            - ath * sph
            - dth * dph * cph,
        ],
        axis=-1,
    )
    return omega, omega_dot


def dcm_NB(q: np.ndarray) -> np.ndarray:
    """Rotation matrices R_NB (..., 3, 3) of quaternions (..., 4): ``v_N = R_NB v_B``."""
    q = np.asarray(q, float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def angle_between(q_a: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """Principal rotation angle [rad] between attitudes ``q_a`` and ``q_b`` (..., 4).

    ``2 atan2(|v|, |w|)`` of the relative quaternion ``conj(q_a) q_b``: accurate down to
    1e-16 rad, where ``2 arccos(|q_a . q_b|)`` bottoms out near 1e-8 rad.
    """
    a, b = np.asarray(q_a, float), np.asarray(q_b, float)
    aw, av = a[..., :1], -a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    w = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    v = aw * bv + bw * av + np.cross(av, bv)
    return 2.0 * np.arctan2(np.linalg.norm(v, axis=-1), np.abs(w[..., 0]))
