"""Sinusoidal rest-to-rest trajectory: quiescent, maneuver and observation periods.

Each Euler angle goes from its start to its end value along half a cosine over the maneuver
period (the sinusoidal trajectory of 002 Sec. 2.1 / ref. 14, ``A sin(w t + phi) + b``):

    angle(t) = a0 + (a1 - a0) (1 - cos(pi tau / T)) / 2,   tau = t - t_quiescent in [0, T]

held at ``a0`` before (quiescent period) and at ``a1`` after (observation period).  Rate is
zero at both ends; acceleration jumps there, as in the papers.  002 prints ``w_f = pi/2`` for
its 5 s maneuver; ``pi / T`` is the value a rest-to-rest half-cosine over T needs
(rcsim/models/dai/SOURCES.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcsim.models.errors import InputError
from rcsim.spacecraft.continuous.kinematics import body_rate_from_euler, quat_from_euler321


@dataclass(frozen=True)
class SinusoidalTrajectory:
    """Rest-to-rest Euler-angle trajectory.

    Parameters
    ----------
    start_rad, end_rad : array-like, (3,)
        Initial and final 3-2-1 Euler angles (phi, theta, psi) [rad].
    quiescent_s, maneuver_s : float
        Start of the maneuver and its length [s].
    """

    start_rad: tuple
    end_rad: tuple
    quiescent_s: float
    maneuver_s: float

    def __post_init__(self):
        if not (math.isfinite(self.maneuver_s) and self.maneuver_s > 0):
            raise InputError(
                f"must be > 0, got {self.maneuver_s}", parameter="maneuver_s", value=self.maneuver_s
            )
        if not (math.isfinite(self.quiescent_s) and self.quiescent_s >= 0):
            raise InputError(
                f"must be >= 0, got {self.quiescent_s}",
                parameter="quiescent_s",
                value=self.quiescent_s,
            )

    def euler(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Desired Euler angles, rates and accelerations at ``t_s``, (3,) each."""
        a0, a1 = np.asarray(self.start_rad, float), np.asarray(self.end_rad, float)
        half = 0.5 * (a1 - a0)
        w = math.pi / self.maneuver_s
        tau = t_s - self.quiescent_s
        if tau <= 0:
            return a0.copy(), np.zeros(3), np.zeros(3)
        if tau >= self.maneuver_s:
            return a1.copy(), np.zeros(3), np.zeros(3)
        return (
            a0 + half * (1 - math.cos(w * tau)),
            half * w * math.sin(w * tau),
            half * w * w * math.cos(w * tau),
        )

    def body(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Desired attitude (4,), body rate (3,) [rad/s] and its derivative (3,) at ``t_s``."""
        ang, rate, acc = self.euler(t_s)
        omega, omega_dot = body_rate_from_euler(ang, rate, acc)
        return quat_from_euler321(ang), omega, omega_dot

    def sample(self, t_s: np.ndarray) -> dict[str, np.ndarray]:
        """Euler angles, quaternion, body rate and acceleration at every ``t_s`` (k, ...)."""
        rows = [self.euler(float(t)) for t in np.asarray(t_s, float)]
        ang, rate, acc = (np.array(x) for x in zip(*rows))
        omega, omega_dot = body_rate_from_euler(ang, rate, acc)
        return {
            "euler": ang,
            "euler_rate": rate,
            "q": quat_from_euler321(ang),
            "omega": omega,
            "omega_dot": omega_dot,
        }
