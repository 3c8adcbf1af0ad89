"""Monte Carlo dispersions (paper Table 5): :func:`load_dispersions`."""

from __future__ import annotations

import pandas as pd

from rcsim.models.tables.schema import (
    SI_UNIT,
    UNITS,
    PathLike,
    cell_error,
    check_columns,
    number,
    read_raw,
    unit_factor,
)

# Dispersions the vehicle model knows; other names are allowed (a campaign may add its own) but
# these must carry a unit of the right dimension.
_DISPERSION_DIMENSIONS = {
    "mass": "mass",
    "cg_x": "length",
    "ixx": "inertia",
    "iyy": "inertia",
    "izz": "inertia",
    "thrust": "force",
    "thruster_angle": "angle",
    # Beyond Table 5 (rcsim.spacecraft.dispersions): CG y and z, products of inertia.
    "cg_y": "length",
    "cg_z": "length",
    "ixy": "inertia",
    "ixz": "inertia",
    "iyz": "inertia",
}
# Paper section III: "The three-sigma values used to generate normal Monte Carlo inputs".
_DISTRIBUTIONS = ("normal",)


def load_dispersions(path: PathLike | None = None) -> pd.DataFrame:
    """Load Monte Carlo dispersions (paper Table 5).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A CSV with columns ``name, distribution, three_sigma, unit, source``.  Default: the
        packaged ``table5_dispersions.csv`` (names mass, cg_x, ixx, iyy, izz, thrust,
        thruster_angle; all ``normal``).

    Returns
    -------
    pandas.DataFrame
        One row per dispersion, in file order, columns:
        ``name`` (str), ``distribution`` (str), ``three_sigma`` (float, SI: kg, m, kg*m^2, N,
        rad), ``si_unit`` (str), ``unit`` (str, the file's unit, for display),
        ``three_sigma_in_unit`` (float, the file's value), ``source`` (str).

    Raises
    ------
    rcsim.models.errors.InputError
        Missing/unknown column, empty name, duplicate name, unknown distribution, unknown
        unit or wrong dimension for a known name, bad or negative three_sigma.
    """
    raw = read_raw(path, "table5_dispersions.csv")
    check_columns(raw, ("name", "distribution", "three_sigma", "unit", "source"))
    records = []
    first_row: dict[str, int] = {}
    for i in range(len(raw.rows)):
        name = raw.cell(i, "name")
        if not name.isidentifier():
            raise cell_error(
                raw.file, "name must be an identifier", row=i + 1, column="name", value=name
            )
        if name in first_row:
            raise cell_error(
                raw.file,
                f"duplicate name (first on row {first_row[name]})",
                row=i + 1,
                column="name",
                value=name,
            )
        first_row[name] = i + 1
        dist = raw.cell(i, "distribution")
        if dist not in _DISTRIBUTIONS:
            raise cell_error(
                raw.file,
                f"unknown distribution; expected one of {_DISTRIBUTIONS}",
                row=i + 1,
                column="distribution",
                value=dist,
            )
        factor = unit_factor(raw, i, "unit", _DISPERSION_DIMENSIONS.get(name))
        sigma = number(raw, i, "three_sigma", minimum=0.0)
        unit = raw.cell(i, "unit")
        records.append(
            dict(
                name=name,
                distribution=dist,
                three_sigma=sigma * factor,
                si_unit=SI_UNIT[UNITS[unit][0]],
                unit=unit,
                three_sigma_in_unit=sigma,
                source=raw.cell(i, "source"),
            )
        )
    return pd.DataFrame.from_records(records)
