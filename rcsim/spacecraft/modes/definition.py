"""The modes of a vehicle file: slosh masses and hinged panels, their springs and dampers, and
the hub's mass properties once their masses are taken out of the whole vehicle's.

Conventions (B frame, SI; ``docs/vehicles.md``, "Slosh and appendages"):

* A **spring** slosh mode (``model = "spring"``) is a point mass ``m`` at rest at
  ``position_m``, free to slide along one unit ``direction`` (or two orthogonal
  ``directions``, two lateral modes of one tank) on a spring and a damper:
  ``k = m (2 pi f)^2``, ``c = 2 zeta sqrt(k m)``, ``f`` its frequency with the tank held still
  (clamped).
* A **pendulum** slosh mode (``model = "pendulum"``) is a point mass ``m`` on a massless rod of
  ``length_m`` from ``pivot_m``, at rest along ``direction``; it swings about the two axes
  normal to the rod (two hinges at the pivot), each with the damper ``damping_n_m_s``
  [N m s/rad] and no spring: its restoring moment is the vehicle's acceleration, so coasting it
  has none (``f = sqrt(a / L) / (2 pi)`` under an acceleration ``a`` along the rod).
* An **appendage** is a rigid panel of ``mass_kg`` and ``inertia_kg_m2`` *about its own CG*
  (B axes, at rest), hinged at ``hinge_m`` about the unit ``axis``, its CG at ``hinge_m +
  cg_offset_m``.  Its inertia about the hinge line is ``I_h = a' I a + m |r_perp|^2`` (``r_perp``
  the CG offset's part normal to the axis) and its hinge spring and damper are
  ``k = I_h (2 pi f)^2``, ``c = 2 zeta sqrt(k I_h)``, ``f`` the panel's clamped (fixed-hub)
  frequency.
* The file's ``[mass]`` is the **whole** wet vehicle with every mode at rest (mass, CG, inertia
  about that CG).  The hub (the MuJoCo vehicle body) is what remains with the modes' masses
  taken out (:func:`hub_mass_properties`): the total mass and CG stay the file's, and so does
  the total inertia about the CG.  A point mass is given a tiny own inertia
  (:data:`POINT_GYRATION_M`) because MuJoCo needs one; it is taken out of the hub too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Radius of gyration given to a slosh point mass's own inertia [m] (MuJoCo refuses a moving
#: body without inertia); the hub's inertia is reduced by the same amount, so the whole
#: vehicle's is unchanged.  1 mm: negligible against any tank (a pendulum of length L swings
#: with m (L^2 + 1e-6)).
POINT_GYRATION_M = 1e-3

SLOSH_MODELS = ("spring", "pendulum")


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def point_tensor(r) -> np.ndarray:
    """Inertia of a unit point mass at ``r`` (3,) about the origin: ``|r|^2 E - r r'`` (3, 3)."""
    r = np.asarray(r, float)
    return float(r @ r) * np.eye(3) - np.outer(r, r)


def normal_axes(direction) -> tuple[np.ndarray, np.ndarray]:
    """Two unit axes normal to ``direction`` and to each other (right-handed with it): a
    pendulum's swing axes.  The first is ``direction`` x the basis vector least along it."""
    d = _unit(direction)
    e = np.eye(3)[int(np.argmin(np.abs(d)))]
    a1 = _unit(np.cross(d, e))
    return a1, np.cross(d, a1)


@dataclass(frozen=True)
class SloshMode:
    """One ``[[slosh]]`` block (module docstring); B frame, SI.

    Attributes
    ----------
    name : str
        Its label; its MuJoCo body and joints are named from it.
    model : str
        ``spring`` or ``pendulum``.
    mass_kg : float
    position_m : tuple of 3 floats
        The mass at rest (a pendulum's: ``pivot_m + length_m * direction``).
    directions : tuple of unit 3-tuples
        Spring: the one or two slide directions.  Pendulum: one, the rod at rest (pivot to mass).
    frequency_hz, damping_ratio : float
        Spring: the clamped frequency and damping ratio (0 for a pendulum).
    pivot_m : tuple of 3 floats or None
        Pendulum: the pivot.
    length_m : float
        Pendulum: the rod (0 for a spring).
    damping_n_m_s : float
        Pendulum: each swing hinge's damper [N m s/rad].
    """

    name: str
    model: str
    mass_kg: float
    position_m: tuple
    directions: tuple
    frequency_hz: float = 0.0
    damping_ratio: float = 0.0
    pivot_m: tuple | None = None
    length_m: float = 0.0
    damping_n_m_s: float = 0.0

    @property
    def stiffness(self) -> float:
        """Spring: ``k = m (2 pi f)^2`` [N/m]; pendulum: 0 (no spring at the pivot)."""
        if self.model != "spring":
            return 0.0
        return self.mass_kg * (2 * math.pi * self.frequency_hz) ** 2

    @property
    def damping(self) -> float:
        """Spring: ``c = 2 zeta sqrt(k m)`` [N s/m]; pendulum: ``damping_n_m_s`` [N m s/rad]."""
        if self.model != "spring":
            return self.damping_n_m_s
        return 2 * self.damping_ratio * math.sqrt(self.stiffness * self.mass_kg)

    def own_inertia(self) -> np.ndarray:
        """The point mass's own inertia about its CG, (3, 3) [kg m^2] (:data:`POINT_GYRATION_M`)."""
        return self.mass_kg * POINT_GYRATION_M**2 * np.eye(3)

    def coordinates(self) -> tuple[tuple[str, str], ...]:
        """Its joints, in MuJoCo order: ``(joint name, 'slide' | 'angle')``."""
        if self.model == "spring":
            return tuple((f"{self.name}_{k + 1}", "slide") for k in range(len(self.directions)))
        return ((f"{self.name}_swing_1", "angle"), (f"{self.name}_swing_2", "angle"))


@dataclass(frozen=True)
class Appendage:
    """One ``[[appendage]]`` block, a hinged rigid panel (module docstring); B frame, SI.

    Attributes
    ----------
    name : str
    mass_kg : float
    inertia_kg_m2 : tuple of 3 tuples
        About the panel's own CG, B axes at rest [kg m^2].
    hinge_m : tuple of 3 floats
    axis : unit 3-tuple
    cg_offset_m : tuple of 3 floats
        From the hinge point to the panel's CG.
    frequency_hz, damping_ratio : float
        Clamped (fixed-hub) frequency and damping ratio of the panel on its hinge.
    """

    name: str
    mass_kg: float
    inertia_kg_m2: tuple
    hinge_m: tuple
    axis: tuple
    cg_offset_m: tuple
    frequency_hz: float
    damping_ratio: float

    @property
    def position_m(self) -> tuple:
        """The panel's CG at rest in B [m]."""
        return tuple(np.add(self.hinge_m, self.cg_offset_m).tolist())

    @property
    def hinge_inertia(self) -> float:
        """Inertia about the hinge line [kg m^2]: ``a' I_cg a + m |r_perp|^2``."""
        a = np.asarray(self.axis, float)
        r = np.asarray(self.cg_offset_m, float)
        r_perp = r - (r @ a) * a
        return float(a @ np.asarray(self.inertia_kg_m2) @ a + self.mass_kg * (r_perp @ r_perp))

    @property
    def stiffness(self) -> float:
        """``k = I_h (2 pi f)^2`` [N m/rad]."""
        return self.hinge_inertia * (2 * math.pi * self.frequency_hz) ** 2

    @property
    def damping(self) -> float:
        """``c = 2 zeta sqrt(k I_h)`` [N m s/rad]."""
        return 2 * self.damping_ratio * math.sqrt(self.stiffness * self.hinge_inertia)

    def own_inertia(self) -> np.ndarray:
        return np.asarray(self.inertia_kg_m2, float)

    def coordinates(self) -> tuple[tuple[str, str], ...]:
        return ((f"{self.name}_hinge", "angle"),)


@dataclass(frozen=True)
class ModeSigmas:
    """One mode's dispersions, one-sigma and absolute in the unit of each (0: not dispersed):
    a ``[[slosh]]`` or ``[[appendage]]`` block's ``mass_kg_3sigma``, ``frequency_hz_3sigma``,
    ``damping_ratio_3sigma`` over 3 (``docs/vehicles.md``, "Dispersions of the modes").

    Attributes
    ----------
    mass_kg : float
        A slosh mass [kg] (a panel's mass is not dispersed: 0).
    frequency_hz : float
        The clamped frequency [Hz] (a spring slosh mode or a panel; a pendulum has none).
    damping_ratio : float
        The damping ratio (a spring slosh mode or a panel).
    """

    mass_kg: float = 0.0
    frequency_hz: float = 0.0
    damping_ratio: float = 0.0

    def disperses(self) -> bool:
        return bool(self.mass_kg or self.frequency_hz or self.damping_ratio)


def hub_mass_properties(
    mass_kg: float, cg_m, inertia_kg_m2, modes
) -> tuple[float, np.ndarray, np.ndarray]:
    """The hub: the whole vehicle (``mass_kg``, ``cg_m`` (3,), ``inertia_kg_m2`` (3, 3) about
    ``cg_m``) less each mode's mass at rest (``modes``: :class:`SloshMode` and
    :class:`Appendage`).

    With ``d_i = r_i - c`` the modes' CGs from the whole CG ``c``::

        m_h = M - sum m_i
        c_h = (M c - sum m_i r_i) / m_h
        I_h = I - sum (I_i + m_i (|d_i|^2 E - d_i d_i')) - m_h (|e|^2 E - e e')   (e = c_h - c)

    (parallel-axis theorem), so the hub with the modes at rest has the file's mass, CG and
    inertia about the CG.

    Returns
    -------
    mass : float, cg : ndarray (3,), inertia : ndarray (3, 3)
        The hub's; not checked (:func:`hub_problem` says what is wrong).
    """
    c = np.asarray(cg_m, float)
    m_h = float(mass_kg)
    moment = float(mass_kg) * c
    inertia = np.array(inertia_kg_m2, float)
    for mode in modes:
        r = np.asarray(mode.position_m, float)
        m_h -= mode.mass_kg
        moment = moment - mode.mass_kg * r
        inertia = inertia - mode.own_inertia() - mode.mass_kg * point_tensor(r - c)
    cg_h = moment / m_h if m_h > 0 else c
    inertia = inertia - m_h * point_tensor(cg_h - c)
    return m_h, cg_h, inertia


def hub_problem(mass_kg: float, inertia_kg_m2: np.ndarray) -> str:
    """Why a hub (:func:`hub_mass_properties`) is no rigid body, or ''."""
    if mass_kg <= 0:
        return f"the modes' masses leave the hub {mass_kg:g} kg"
    moments = np.linalg.eigvalsh(inertia_kg_m2)
    if moments.min() <= 0:
        return (
            "the modes' inertia exceeds the whole vehicle's: the hub's principal moments "
            f"would be {np.round(moments, 6).tolist()} kg m^2"
        )
    a, b, c = moments
    if a + b < c * (1 - 1e-12):
        return (
            f"the hub left by the modes breaks the triangle inequality ({a:g} + {b:g} < {c:g}): "
            "no rigid body has it"
        )
    return ""


def mode_coordinates(modes) -> tuple[tuple[str, str], ...]:
    """Every mode joint of ``modes`` in MuJoCo order (qpos 7.., qvel 6..)."""
    return tuple(c for mode in modes for c in mode.coordinates())
