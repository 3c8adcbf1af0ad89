"""Vehicle mass properties (paper Table 1): :class:`MassProperties` and its loader."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcsim.models.tables.schema import PathLike, cell_error, frozen_array, long_table

# parameter -> (dimension, must be strictly positive)
_MASS_PARAMETERS = {
    "mass": ("mass", True),
    "cg_x": ("length", False),  # a position: either sign is physical
    "ixx": ("inertia", True),
    "iyy": ("inertia", True),
    "izz": ("inertia", True),
    "thrust": ("force", True),
}


@dataclass(frozen=True, eq=False)
class MassProperties:
    """Vehicle mass properties (paper Table 1), SI.

    Attributes
    ----------
    mass_kg : float
        Vehicle mass, kg.
    cg_x_m : float
        Centre-of-gravity x position, m.
    inertia_kgm2 : numpy.ndarray, shape (3,)
        Principal moments of inertia [Ixx, Iyy, Izz], kg*m^2 (read-only).
    thrust_n : float
        Thrust of one jet, N.
    """

    mass_kg: float
    cg_x_m: float
    inertia_kgm2: np.ndarray
    thrust_n: float

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "inertia_kgm2", frozen_array(self.inertia_kgm2, float, (3,), "inertia_kgm2")
        )


def load_mass_properties(path: PathLike | None = None) -> MassProperties:
    """Load vehicle mass properties (paper Table 1).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A ``parameter, unit, value`` CSV with parameters ``mass, cg_x, ixx, iyy, izz, thrust``
        (units e.g. kg, m, kg*m^2, N; other known units are converted).  Default: the packaged
        ``table1_mass_properties.csv``.

    Returns
    -------
    MassProperties
        SI values; ``inertia_kgm2`` has shape (3,).

    Raises
    ------
    rcsim.models.errors.InputError
        Missing/unknown column or parameter, empty or non-numeric value, non-positive mass,
        inertia or thrust, wrong unit dimension, or principal moments that violate the
        triangle inequality (no rigid body has them).
    """
    raw, v = long_table(path, "table1_mass_properties.csv", "value", _MASS_PARAMETERS)
    inertia = np.array([v["ixx"], v["iyy"], v["izz"]])
    # Principal moments of a rigid body satisfy I_a <= I_b + I_c; a violation is a typo.
    for a, name in enumerate(("ixx", "iyy", "izz")):
        if inertia[a] > inertia.sum() - inertia[a]:
            row = 1 + [r[raw.header.index("parameter")] for r in raw.rows].index(name)
            raise cell_error(
                raw.file,
                f"{name} exceeds the sum of the other two principal moments (not a rigid body)",
                row=row,
                column="value",
                value=raw.cell(row - 1, "value"),
            )
    return MassProperties(
        mass_kg=v["mass"], cg_x_m=v["cg_x"], inertia_kgm2=inertia, thrust_n=v["thrust"]
    )
