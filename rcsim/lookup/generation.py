"""A vehicle's lookup table, whatever its jet layout: the one path the API and the CLI take.

:func:`generate_table` generates the table the lookup controller flies on ``vehicle``: a jet
table (the paper's 16 columns, :func:`rcsim.lookup.table_generation.generate_jet_table`) when
its jets play Table 2's roles, else a channel table (six axis channels and the recipe that fires
the jets, :func:`rcsim.lookup.channel_generation.generate_channel_table`).
``rcsim lookup generate`` writes its result (:mod:`rcsim.analysis.engine.table_files`).
"""

from __future__ import annotations

from rcsim.lookup.channel_generation import generate_channel_table
from rcsim.lookup.row_tuning import DEFAULT_TARGET_FRACTION, check_target_fraction
from rcsim.lookup.table_generation import GeneratedTable, generate_jet_table
from rcsim.models.tables import load_jet_map
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.authority import jet_map_mismatch


def is_coupled(vehicle: Vehicle) -> bool:
    """Whether the vehicle's jets do *not* each turn one axis as Table 2's do: its lookup table
    is a channel table (:mod:`rcsim.lookup.channels`)."""
    return jet_map_mismatch(vehicle.definition, load_jet_map()) is not None


def generate_table(
    vehicle: Vehicle,
    *,
    jets_off=(),
    target_fraction: float = DEFAULT_TARGET_FRACTION,
) -> GeneratedTable:
    """Generate, tune, verify and damping-check the lookup table of ``vehicle`` (resolved at the
    public edge: :func:`rcsim.analysis.engine.table_files.generate_table`), without the jets
    ``jets_off`` (1-based): a jet table or a channel table (module docstring), at the vehicle
    profile's rate-case magnitude and cycle.

    Every row is tuned in closed loop until the nominal vehicle's case ends within
    ``target_fraction`` (in (0, 1]) of the campaigns' 0.04 deg/s failure threshold, or the case
    is named with the reason it cannot (:mod:`rcsim.lookup.row_tuning`; the result's
    ``nominal``).

    Raises
    ------
    InputError
        A bad jet set, rate cases the jets cannot reach (the profile's ``rate_case_deg_s`` named),
        or a target fraction outside (0, 1].
    """
    target_fraction = check_target_fraction(target_fraction)
    if is_coupled(vehicle):
        return generate_channel_table(vehicle, jets_off=jets_off, target_fraction=target_fraction)
    return generate_jet_table(vehicle, jets_off=jets_off, target_fraction=target_fraction)
