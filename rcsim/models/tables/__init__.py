"""The paper's reference tables as validated data (Gambone, *Pattern Recognition Control Design*).

Owns the loaders of ``rcsim/models/data/*.csv`` (Tables 1-7 and ``corrections.csv``; provenance and
every correction in ``rcsim/models/data/SOURCES.md``) and the paper's design constants, such
as ``PAPER_CYCLE_S``, the paper's 40 ms control cycle (a flight's cycle is its vehicle's
profile's, ``rcsim.spacecraft.control_profile``).  It is the
bottom layer: only ``rcsim.models.errors`` and ``rcsim.models.atomic`` besides numpy/pandas.

Must not import: rcsim.spacecraft, rcsim.lookup, rcsim.analysis, rcsim.models.dai.

Each loader reads a packaged table -- or a user file in the same format -- checks its
*structure* and its *physical range*, and returns SI quantities:

========================  =======================================  =========================
loader                    file                                     returns
========================  =======================================  =========================
load_mass_properties      table1_mass_properties.csv               MassProperties
load_jet_map              table2_jet_map.csv                       int array (16, 3)
load_rate_cases           table3_rate_cases.csv                    RateCases
load_lookup_inputs        table4_lookup_inputs.csv                 LookupInputs
load_dispersions          table5_dispersions.csv                   pandas.DataFrame
load_lookup_table         table6_lookup_original.csv / table7_...  LookupTable
paper_corrections         corrections.csv                          list[Correction]
========================  =======================================  =========================

Modules: ``constants`` (paper constants, tolerances, physical ranges), ``schema`` (the shared
CSV reading / cell parsing / unit core), one module per table family (``mass_properties``,
``jet_map``, ``rate_cases``, ``lookup_inputs``, ``lookup_tables``, ``dispersions``,
``corrections``), ``channels`` (a channel table's six axis channels and their recipe file, for
vehicles whose jets torque several axes) and ``consistency`` (the cross-table check of a lookup
table against Tables 2 and 3).  Import the public names from here, not from the modules.

Design rules
------------
* No table value appears in the loaders' logic.  The checks are structural: the set of rate
  cases is every sign pattern of (roll, pitch, yaw) except all-zero, in roll-major order; every
  case has the same total rate; the jets that fire are exactly those the jet map points along
  the commanded rate; paired jets fire equally long; firing times are whole control cycles.
  The only numbers are constants the paper states in its *text* (16 thrusters, 40 ms control
  cycle, 0.3 deg/s total rate command) and ranges derived from them, each with its reason in
  ``constants``.
* Physical ranges catch a well-formed table in the wrong unit: rates in rad/s under a deg/s
  header, firing times in ms under an s header (see ``RATE_TOTAL_MIN_DEG_S``,
  ``MAX_FIRING_TIME_S``).
* Every failure is a :class:`rcsim.models.errors.InputError` whose one-line message names the
  file, the row (1-based data row, plus the case or jet number when known), the column and the
  bad value, so an analyst can go straight to the cell.
"""

from __future__ import annotations

from rcsim.models.tables.channels import (
    CHANNEL_COLUMNS,
    CHANNEL_MAP,
    CHANNELS,
    ChannelRecipe,
    channel_name,
    is_channel_table,
    load_recipe,
    recipe_path,
)
from rcsim.models.tables.consistency import check_consistency
from rcsim.models.tables.constants import (
    AXES,
    JET_COLUMNS,
    MAX_FIRING_TIME_S,
    N_CASES,
    N_JETS,
    PAPER_CYCLE_S,
    PAPER_TOTAL_RATE_DEG_S,
    RATE_COLUMNS,
    RATE_RTOL,
    RATE_TOTAL_MAX_DEG_S,
    RATE_TOTAL_MIN_DEG_S,
    SIGN_COLUMNS,
    TIME_ATOL_S,
)
from rcsim.models.tables.corrections import Correction, paper_corrections
from rcsim.models.tables.dispersions import load_dispersions
from rcsim.models.tables.jet_map import load_jet_map
from rcsim.models.tables.lookup_inputs import LookupInputs, load_lookup_inputs
from rcsim.models.tables.lookup_tables import (
    PAPER_LOOKUP_TABLES,
    LookupTable,
    load_lookup_table,
    lookup_table_source,
)
from rcsim.models.tables.mass_properties import MassProperties, load_mass_properties
from rcsim.models.tables.rate_cases import RateCases, load_rate_cases, rate_cases_at, sign_patterns

__all__ = [
    "AXES",
    "CHANNELS",
    "CHANNEL_COLUMNS",
    "CHANNEL_MAP",
    "ChannelRecipe",
    "channel_name",
    "is_channel_table",
    "load_recipe",
    "recipe_path",
    "PAPER_CYCLE_S",
    "JET_COLUMNS",
    "MAX_FIRING_TIME_S",
    "N_CASES",
    "N_JETS",
    "PAPER_LOOKUP_TABLES",
    "PAPER_TOTAL_RATE_DEG_S",
    "RATE_COLUMNS",
    "RATE_RTOL",
    "RATE_TOTAL_MAX_DEG_S",
    "RATE_TOTAL_MIN_DEG_S",
    "SIGN_COLUMNS",
    "TIME_ATOL_S",
    "Correction",
    "LookupInputs",
    "LookupTable",
    "MassProperties",
    "RateCases",
    "check_consistency",
    "load_dispersions",
    "load_jet_map",
    "load_lookup_inputs",
    "load_lookup_table",
    "load_mass_properties",
    "load_rate_cases",
    "rate_cases_at",
    "lookup_table_source",
    "paper_corrections",
    "sign_patterns",
]
