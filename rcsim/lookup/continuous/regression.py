"""Euler's rotational equation as a linear regression in the inertia (001 Eqs. 5-7, 002 Eq. 10).

``J w_dot + w x J w = Phi(w, w_dot) Theta`` with ``Theta = (Jxx, Jxy, Jxz, Jyy, Jyz, Jzz)``.
Column ``i`` of Phi is ``E_i w_dot + w x (E_i w)`` for the symmetric basis matrix ``E_i`` of
``Theta_i``; this equals, term by term, the expanded torques of 001 App. A.3 (checked in
``tests/lookup/test_continuous_controllers.py``).  The transcriptions of 001 Eq. (6) and
002 Eq. (10) lost their signs and layout; this construction does not depend on them.
"""

from __future__ import annotations

import numpy as np

# Symmetric basis E_i of Theta = (Jxx, Jxy, Jxz, Jyy, Jyz, Jzz), (6, 3, 3).
_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
BASIS = np.zeros((6, 3, 3))
for _i, (_r, _c) in enumerate(_PAIRS):
    BASIS[_i, _r, _c] = BASIS[_i, _c, _r] = 1.0


def theta_from_inertia(inertia: np.ndarray) -> np.ndarray:
    """Theta (..., 6) of inertia tensors (..., 3, 3) [kg m^2]."""
    inertia = np.asarray(inertia, float)
    return np.stack([inertia[..., r, c] for r, c in _PAIRS], axis=-1)


def inertia_from_theta(theta: np.ndarray) -> np.ndarray:
    """Inertia tensors (..., 3, 3) of Theta (..., 6)."""
    return np.einsum("...i,ijk->...jk", np.asarray(theta, float), BASIS)


def regressor(omega: np.ndarray, omega_dot: np.ndarray) -> np.ndarray:
    """Phi (..., 3, 6) of body rates and accelerations (..., 3) [rad/s, rad/s^2]."""
    omega, omega_dot = np.asarray(omega, float), np.asarray(omega_dot, float)
    e_wdot = np.einsum("ijk,...k->...ji", BASIS, omega_dot)  # (..., 3, 6)
    e_w = np.einsum("ijk,...k->...ij", BASIS, omega)  # (..., 6, 3)
    cross = np.cross(omega[..., None, :], e_w)  # (..., 6, 3)
    return e_wdot + np.swapaxes(cross, -1, -2)


def feedforward(inertia: np.ndarray, omega_d: np.ndarray, omega_dot_d: np.ndarray) -> np.ndarray:
    """Nonlinear feedforward ``u = J wd_dot + wd x J wd`` [N m] (001 Sec. 2.4, 002 Eq. 8).

    Parameters
    ----------
    inertia : ndarray, (3, 3) or (n, 3, 3)
    omega_d, omega_dot_d : ndarray, (n, 3)
    """
    j_wd = np.einsum("...ij,...j->...i", inertia, omega_d)
    return np.einsum("...ij,...j->...i", inertia, omega_dot_d) + np.cross(omega_d, j_wd)
