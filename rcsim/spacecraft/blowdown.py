"""Blowdown propellant feed: tank pressure, thrust and Isp falling as the propellant is used.

Law (stated; ``docs/vehicles.md``, "Blowdown")
----------------------------------------------
The pressurant gas (volume ``V0`` [m^3] and pressure ``P0`` [Pa] at t = 0) expands into the
volume the propellant leaves, polytropically with exponent ``n`` (1: isothermal, the default;
1.4 for adiabatic nitrogen or helium-ish 1.67)::

    V(u) = V0 + u / rho                  u propellant used [kg], rho its density [kg/m^3]
    P(u) = P0 (V0 / V(u))^n              (P V^n constant)

and the jets follow the pressure::

    F(u)   = F_nominal (P(u) / P_ref)^a      a = thrust_exponent, default 1
    Isp(u) = Isp_nominal (P(u) / P_ref)^b    b = isp_exponent, default 0 (Isp constant)

``P_ref`` is the pressure at which the jets' ``thrust_n`` and the ``isp_s`` are specified
(``reference_pressure_pa``, default ``P0``).  ``F`` proportional to ``P`` (a = 1) is the
chamber-pressure scaling of a fixed-throat jet fed at a pressure proportional to the tank's;
the Isp of a hydrazine jet falls only a few percent over a 4:1 blowdown, hence b small.

Updated once per control cycle, as the mass properties (:mod:`rcsim.spacecraft.propellant`):
the thrust and Isp of a cycle are those at the propellant used at its start.  Over one cycle
the pressure falls by ``n dV / V``, the propellant volume the cycle used over the gas volume, so
a cycle's thrust is high by about half that (``docs/vehicles.md`` gives figures against the
continuous law).  The error does not accumulate: the pressure is always the exact one of the
propellant used, and each cycle's propellant is exact for the thrust flown.  Exact within the
cycle, each piece's thrust would depend on the propellant that piece itself burns (an implicit
equation per piece and run, and a wrench per piece instead of one gain per cycle).

Imports nothing of rcsim.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Blowdown:
    """A blowdown tank for ``n_runs`` runs (module docstring).

    Attributes
    ----------
    gas_volume_m3 : float
        Pressurant volume at t = 0, ``V0`` [m^3].
    pressure_pa : ndarray, (n_runs,)
        Pressure at t = 0, ``P0`` [Pa] (dispersed per run).
    density_kg_m3 : float
        Propellant density ``rho`` [kg/m^3].
    polytropic_n : float
        Gas exponent ``n`` (1 isothermal).
    thrust_exponent, isp_exponent : float
        ``a`` and ``b``.
    reference_pa : float
        ``P_ref`` [Pa] (the file's, or its nominal ``P0``: a dispersed initial pressure then
        changes the thrust from the start).
    """

    gas_volume_m3: float
    pressure_pa: np.ndarray
    density_kg_m3: float
    polytropic_n: float = 1.0
    thrust_exponent: float = 1.0
    isp_exponent: float = 0.0
    reference_pa: float = 1.0

    def take(self, rows) -> Blowdown:
        """The tank of runs ``rows`` (indices into the runs, repeats allowed)."""
        return replace(self, pressure_pa=self.pressure_pa[np.asarray(rows, int)])

    def pressure(self, used_kg: np.ndarray) -> np.ndarray:
        """``P(u)`` [Pa] after ``used_kg`` (n_runs,) of propellant."""
        v0 = self.gas_volume_m3
        return self.pressure_pa * (v0 / (v0 + np.asarray(used_kg, float) / self.density_kg_m3)) ** (
            self.polytropic_n
        )

    def thrust_factor(self, used_kg: np.ndarray) -> np.ndarray:
        """``F(u) / F_nominal``, (n_runs,)."""
        return (self.pressure(used_kg) / self.reference_pa) ** self.thrust_exponent

    def isp_factor(self, used_kg: np.ndarray) -> np.ndarray:
        """``Isp(u) / Isp_nominal``, (n_runs,)."""
        if self.isp_exponent == 0.0:
            return np.ones(np.shape(used_kg))
        return (self.pressure(used_kg) / self.reference_pa) ** self.isp_exponent
