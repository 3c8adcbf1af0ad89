"""Translation coupling of a vehicle's pure rate changes, per allocation mode
(``rcsim vehicle check``).

For each of the six pure rate changes (+/- roll, pitch, yaw) of :data:`COMMAND_DEG_S` deg/s,
and each allocation mode of the profile (:data:`rcsim.spacecraft.control_profile.ALLOCATION_MODES`),
the plan the allocator flies (:func:`rcsim.lookup.allocator_controller.allocator_controller`:
nominal jet model, minimum on-time honoured) and what it costs: propellant [kg] and the CG
velocity change it leaves, body frame [m/s], each divided by the command (per deg/s).  With
no minimum on-time both are linear in the command (the LP is homogeneous), so the figures are
those of any command; with one, a command of 1 deg/s is far above a minimum pulse's rate
change on every packaged vehicle, and the figures are those of large commands.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rcsim.lookup.allocator_controller import allocator_controller, jet_model
from rcsim.spacecraft.control_profile import ALLOCATION_MODES

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle

#: The pure rate change the figures are computed for [deg/s].
COMMAND_DEG_S = 1.0
#: A velocity change below this [m/s per deg/s] is the round-off of a cancelled force.
DV_FLOOR_M_S = 1e-12
#: The six directions, in the order of the rows.
DIRECTIONS = ("+roll", "-roll", "+pitch", "-pitch", "+yaw", "-yaw")


@dataclass(frozen=True)
class Coupling:
    """Per allocation mode (keys of :data:`ALLOCATION_MODES`), arrays over :data:`DIRECTIONS`.

    ``propellant_kg_per_deg_s`` (6,): propellant per deg/s; ``dv_B_m_s_per_deg_s`` (6, 3):
    CG velocity change per deg/s, body frame; ``residual_deg_s`` (6,): rate change not
    reached (an unreachable direction), deg/s per deg/s commanded."""

    propellant_kg_per_deg_s: dict[str, np.ndarray]
    dv_B_m_s_per_deg_s: dict[str, np.ndarray]
    residual_deg_s: dict[str, np.ndarray]


def translation_coupling(vehicle: Vehicle) -> Coupling:
    """The figures of the module docstring for ``vehicle``."""
    D, G, mdot, _ = jet_model(vehicle.model, vehicle.isp_s)
    command = np.radians(COMMAND_DEG_S) * np.repeat(np.eye(3), 2, axis=0)
    command[1::2] *= -1.0
    prop, dv, resid = {}, {}, {}
    for mode in ALLOCATION_MODES:
        t, residual = allocator_controller(vehicle, allocation=mode).allocator.allocate(command)
        prop[mode] = t @ mdot / COMMAND_DEG_S
        # Round-off of a cancelled force (1e-18 m/s) is no translation: shown as 0.
        moved = t @ G.T / COMMAND_DEG_S
        dv[mode] = np.where(np.abs(moved) < DV_FLOOR_M_S, 0.0, moved)
        resid[mode] = np.degrees(np.linalg.norm(residual, axis=1)) / COMMAND_DEG_S
    return Coupling(prop, dv, resid)


def coupling_text(vehicle: Vehicle, coupling: Coupling | None = None) -> str:
    """The section ``rcsim vehicle check`` prints."""
    c = coupling if coupling is not None else translation_coupling(vehicle)
    lines = [
        f"Translation coupling per allocation mode (the allocator's plan for a pure rate change "
        f"of {COMMAND_DEG_S:g} deg/s, minimum on-time honoured; per deg/s; profile's mode: "
        f"{vehicle.control.allocation}):",
        f"  {'direction':<9} {'mode':<23} {'propellant kg':>14} {'|dv| m/s':>10} "
        f"{'dv_B x, y, z m/s':>32}",
    ]
    for i, direction in enumerate(DIRECTIONS):
        for mode in ALLOCATION_MODES:
            dv = c.dv_B_m_s_per_deg_s[mode][i]
            note = ""
            if c.residual_deg_s[mode][i] > 1e-6:
                note = f"  (unreachable: {c.residual_deg_s[mode][i]:.3g} deg/s left)"
            lines.append(
                f"  {direction:<9} {mode:<23} {c.propellant_kg_per_deg_s[mode][i]:>14.4g} "
                f"{np.linalg.norm(dv):>10.3g} "
                f"{dv[0]:>10.3g} {dv[1]:>10.3g} {dv[2]:>10.3g}{note}"
            )
    lines.append(
        "  (propellant: least propellant; propellant+translation: translation priced at the "
        "propellant that nulls it, m/(Isp g0) per m/s; translation-first: 1000 times that)"
    )
    return "\n".join(lines) + "\n"
