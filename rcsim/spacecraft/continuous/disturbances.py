"""Gravity-gradient and aerodynamic-drag torques at 150 km (Wilt & Sands 2022, App. C), batched.

Orbit.  A circular orbit of radius ``R = Re + h`` at rate ``w0 = sqrt(mu / R^3)``; the inertial
frame N is the local-vertical local-horizontal frame at t = 0 (x along the velocity, z to
nadir).  At time t the position unit vector is ``r_N = (sin w0 t, 0, -cos w0 t)`` and the
velocity unit vector ``v_N = (cos w0 t, 0, sin w0 t)``.  Orbital motion of the *reference* is
off (002 Sec. 3: "orbital motion off"): the commanded attitude is inertial.

Atmosphere (001 App. C).  Temperature from the thermosphere profile App. C gives ("From 1977
NASA", the U.S. Standard Atmosphere 1976 form above 120 km)::

    T = T_inf - (T_inf - T_10) exp(-lambda xi),  lambda = L_K10 / (T_inf - T_10),
    xi = (h - Z_10) (Re + Z_10) / (Re + h)

which gives 634.4 K at 150 km, the standard atmosphere's 634.39 K.  Density is the ideal gas
``rho = p M / (R_u T)``.  App. C's pressure line evaluates the tropospheric barometric formula
with h in km against a lapse rate in K/m and is not usable (rcsim/models/dai/SOURCES.md); the
pressure and mean molar mass at 150 km come from the 1976 standard atmosphere instead
(``parameters.csv``), giving 2.08e-9 kg/m^3.  Only h = 150 km is supported.

Torques, body axes:

* gravity gradient ``T_gg = 3 mu / R^3  r_B x (J r_B)``;
* drag ``F_B = -1/2 rho V^2 Cd A_p v_B`` with the projected area ``A_p = sum_i A_i |v_B,i|``
  of the box (App. C's ``Area``), applied at the centre of pressure: ``T_d = d_cp x F_B``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rcsim.models.dai import Environment
from rcsim.models.errors import InputError
from rcsim.spacecraft.continuous.kinematics import dcm_NB

_SUPPORTED_ALTITUDE_M = 150e3


def thermosphere_temperature_k(env: Environment, altitude_m: float) -> float:
    """001 App. C temperature [K] at ``altitude_m`` (>= Z_10)."""
    lam = env.lapse_k10_k_m / (env.t_inf_k - env.t_10_k)
    xi = (
        (altitude_m - env.z_10_m)
        * (env.earth_radius_m + env.z_10_m)
        / (env.earth_radius_m + altitude_m)
    )
    return env.t_inf_k - (env.t_inf_k - env.t_10_k) * math.exp(-lam * xi)


def density_kg_m3(env: Environment) -> float:
    """Air density at the orbit altitude [kg/m^3] (module docstring)."""
    if abs(env.altitude_m - _SUPPORTED_ALTITUDE_M) > 1e-6:
        raise InputError(
            f"must be 150 km (the pressure and molar mass in parameters.csv are "
            f"the 150 km values), got {env.altitude_m / 1e3} km",
            parameter="altitude",
            value=env.altitude_m,
        )
    temp = thermosphere_temperature_k(env, env.altitude_m)
    return env.pressure_pa * env.molar_mass_kg_mol / (env.gas_constant * temp)


def orbit_directions_N(env: Environment, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity unit vectors in N at ``t_s`` (module docstring), (3,) each."""
    a = env.mean_motion_rad_s * t_s
    return (np.array([math.sin(a), 0.0, -math.cos(a)]), np.array([math.cos(a), 0.0, math.sin(a)]))


@dataclass(frozen=True)
class Disturbances:
    """Switchable environment torques (001 App. B's ``gravity_gradient_Switch`` and
    ``aero_torque_Switch``).

    Parameters
    ----------
    env : Environment
    gravity_gradient, aero_drag : bool
    """

    env: Environment
    gravity_gradient: bool = True
    aero_drag: bool = True

    @property
    def enabled(self) -> bool:
        return self.gravity_gradient or self.aero_drag

    def torque_B(self, t_s: float, q_BN: np.ndarray, inertia_B: np.ndarray) -> np.ndarray:
        """Disturbance torque on every run [N m], (n_runs, 3).

        Parameters
        ----------
        t_s : float
        q_BN : ndarray, (n_runs, 4)
            Attitude (scalar-first).
        inertia_B : ndarray, (n_runs, 3, 3)
            True inertia of each run [kg m^2].
        """
        n = q_BN.shape[0]
        out = np.zeros((n, 3))
        if not self.enabled:
            return out
        r_N, v_N = orbit_directions_N(self.env, t_s)
        r_BN = np.swapaxes(dcm_NB(q_BN), -1, -2)
        if self.gravity_gradient:
            r_B = r_BN @ r_N
            out += (
                3.0
                * self.env.mean_motion_rad_s**2
                * np.cross(r_B, np.einsum("nij,nj->ni", inertia_B, r_B))
            )
        if self.aero_drag:
            v_B = r_BN @ v_N
            q_dyn = 0.5 * density_kg_m3(self.env) * self.env.speed_m_s**2
            area = np.abs(v_B) @ self.env.area_B_m2
            force = -(q_dyn * self.env.cd * area)[:, None] * v_B
            out += np.cross(self.env.cp_cg_B, force)
        return out
