"""Authority along one axis direction: the LP under ``rcsim vehicle check``
(:mod:`rcsim.spacecraft.vehicle.authority`) and the sanity warnings
(:mod:`rcsim.spacecraft.vehicle.sanity`).

Angular accelerations are ``I^-1 tau`` with the full inertia (products included), every jet at
most fully on (duties ``0 <= u <= 1``), the other two axes' angular accelerations zero.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

from rcsim.spacecraft.vehicle.definition import VehicleDef
from rcsim.spacecraft.vehicle.mjcf import force_torque
from rcsim.spacecraft.vehicle.model import AXES

#: The six axis directions in the order they are reported: +roll, -roll, +pitch, ...
DIRECTIONS = tuple((a, s) for a in range(3) for s in (1, -1))


def direction_name(axis: int, sign: int) -> str:
    return f"{'+' if sign > 0 else '-'}{AXES[axis]}"


def pure_axis_authority(
    accel: np.ndarray, axis: int, sign: int, available: np.ndarray, force: np.ndarray | None = None
) -> tuple[float, np.ndarray | None]:
    """Largest ``sign * (accel u)[axis]`` with the other axes zero, ``0 <= u <= 1`` on the
    available jets (and zero net force when ``force`` (3, n) is given).

    Returns the authority [rad/s^2] and the duties (least total duty among the optimal ones),
    or ``(0.0, None)`` when the direction cannot be reached.
    """
    n = accel.shape[1]
    rows, bounds, best = _authority_lp(accel, axis, sign, available, force)
    if best.status != 0 or -best.fun <= 1e-12 * np.abs(accel).max():
        return 0.0, None
    value = -best.fun
    zero = np.zeros(rows.shape[0])
    # the same authority with the least total duty: no idle pair in the answer
    lean = linprog(
        np.ones(n),
        A_ub=-sign * accel[axis][None],
        b_ub=[-value * (1 - 1e-9)],
        A_eq=rows,
        b_eq=zero,
        bounds=bounds,
        method="highs",
    )
    return value, lean.x if lean.status == 0 else best.x


def _authority_lp(accel, axis, sign, available, force=None):
    """The LP of :func:`pure_axis_authority`: its equality rows, bounds and optimum."""
    rows = accel[[b for b in range(3) if b != axis]]
    if force is not None:
        rows = np.vstack([rows, force])
    bounds = [(0.0, 1.0 if available[j] else 0.0) for j in range(accel.shape[1])]
    zero = np.zeros(rows.shape[0])
    best = linprog(-sign * accel[axis], A_eq=rows, b_eq=zero, bounds=bounds, method="highs")
    return rows, bounds, best


def reachable(accel: np.ndarray, axis: int, sign: int, available: np.ndarray) -> bool:
    """Whether ``sign * axis`` can be reached with the available jets: the first LP of
    :func:`pure_axis_authority` alone (its value positive), not the second (the duties)."""
    best = _authority_lp(accel, axis, sign, available)[2]
    return best.status == 0 and -best.fun > 1e-12 * np.abs(accel).max()


def axis_authorities(vehicle: VehicleDef) -> np.ndarray:
    """Pure-axis authority of +roll, -roll, +pitch, -pitch, +yaw, -yaw, (6,) [rad/s^2] (every
    jet available, at most fully on; 0 for an unreachable direction)."""
    accel = np.linalg.solve(vehicle.inertia_kg_m2, force_torque(vehicle)[3:])
    every = np.ones(vehicle.n_jets, bool)
    return np.array([pure_axis_authority(accel, a, s, every)[0] for a, s in DIRECTIONS])
