"""What ``rcsim vehicle check`` says of a vehicle's modes: each mode coordinate's clamped and
coupled frequency and its mass (or inertia) clamped and effective
(:mod:`rcsim.spacecraft.modes.linear`), and the hub left by the modes."""

from __future__ import annotations

import mujoco
import numpy as np

from rcsim.spacecraft.modes.linear import mode_table


def modes_text(modes, model: mujoco.MjModel) -> str:
    """The modes section of ``rcsim vehicle check`` ('' for a rigid vehicle).

    Parameters
    ----------
    modes : rcsim.spacecraft.modes.reader.Modes or None
        The vehicle file's modes.
    model : mujoco.MjModel
        The vehicle's compiled model (its mass matrix at rest gives the coupled values).
    """
    if modes is None:
        return ""
    table = mode_table(model)
    lines = [
        "",
        "Modes (linearised about rest; coupled: the hub free, clamped: the hub held still)",
        f"  hub (the rigid part): {modes.hub_mass_kg:.6g} kg, CG "
        f"[{', '.join(f'{c:.4g}' for c in modes.hub_cg_m)}] m, inertia diagonal "
        f"[{', '.join(f'{i:.6g}' for i in np.diag(modes.hub_inertia_kg_m2))}] kg m^2 "
        "(the file's [mass] less the modes)",
        f"  {'coordinate':<24} {'unit':<5} {'clamped Hz':>10} {'mass clamped':>14} "
        f"{'effective':>12}",
    ]
    for name, kind, f, m, me in zip(
        table.names, table.kinds, table.clamped_hz, table.mass, table.effective_mass
    ):
        unit, munit = ("m", "kg") if kind == "slide" else ("rad", "kg m^2")
        clamped = f"{f:10.4g}" if f > 0 else f"{'no spring':>10}"
        lines.append(f"  {name:<24} {unit:<5} {clamped} {m:10.5g} {munit:<6}{me:9.5g} {munit}")
    coupled = [
        f"{f:.4g} Hz ({owner})" for f, owner in zip(table.coupled_hz, table.coupled_owner) if f > 0
    ]
    lines.append("  coupled frequencies: " + (", ".join(coupled) if coupled else "none"))
    for mode, sigma in zip(modes.all, modes.sigmas):
        spread = [
            f"{label} {3 * value:g}{unit}"
            for label, value, unit in (
                ("mass", sigma.mass_kg, " kg"),
                ("clamped frequency", sigma.frequency_hz, " Hz"),
                ("damping ratio", sigma.damping_ratio, ""),
            )
            if value
        ]
        if spread:
            lines.append(
                f"  {mode.name} dispersed (3-sigma, each run its own): {', '.join(spread)}"
            )
    if any(m.model == "pendulum" for m in modes.slosh):
        lines.append(
            "  a pendulum has no spring: it swings at sqrt(a / L) / (2 pi) under an "
            "acceleration a along its rod, not at all coasting"
        )
    return "\n".join(lines) + "\n"
