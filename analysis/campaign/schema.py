"""The columns of ``runs.parquet``: one definition of every column's name, dtype, unit, meaning.

Every producer and consumer of a run's row uses it:
:func:`~rcsim.analysis.campaign.outcomes.outcomes` builds its frame through :func:`outcome_frame`, the rows of runs that raised come from
:func:`missing_outcomes`, the campaign's assembly reads the per-case statistics' columns from
here, and ``docs/campaigns.md`` carries the table :func:`markdown_table` prints (a test keeps
them equal).

Definitions used below: ``thr`` is the spec's ``failure.rate_error_deg_s``; rate errors
(``omega - omega_cmd``, body axes) are sampled at the start of every 40 ms control cycle and at
the end of the run; an axis's jets are those whose Table 2 torque has a component on it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from rcsim.spacecraft.vehicle import AXES, N_JETS


@dataclass(frozen=True)
class Column:
    """One column of ``runs.parquet``.

    Attributes
    ----------
    name : str
    dtype : str
        pandas dtype: ``int64``, ``float64``, ``bool`` or ``str`` (a column of strings).
    unit : str
        ``-`` for counts, flags and names.
    meaning : str
    """

    name: str
    dtype: str
    unit: str
    meaning: str


def _per_axis(pattern: str, dtype: str, unit: str, meaning: str) -> list[Column]:
    return [Column(pattern.format(axis=a), dtype, unit, meaning.format(axis=a)) for a in AXES]


def _per_jet(pattern: str, dtype: str, unit: str, meaning: str) -> list[Column]:
    return [Column(pattern.format(jet=f"{j + 1:02d}"), dtype, unit, meaning)
            for j in range(N_JETS)]


#: Identity of a run.
ID_COLUMNS: tuple[Column, ...] = (
    Column("run_id", "int64", "-", "run number: case_index * runs_per_case + k"),
    Column("case", "str", "-", "case name (rate-NN, damp-NN, or the maneuver / hold name)"),
    Column("case_index", "int64", "-", "position of the case in the spec"),
    Column("seed", "int64", "-", "the spec's root seed; run i draws from "
           "SeedSequence(seed, spawn_key=(i,)).spawn(2)[0]"),
)

#: The dispersed vehicle the run flew (rcsim.spacecraft.dispersions.dispersion_frame), read back
#: from the simulation's per-run MuJoCo model where MuJoCo holds the value.
INPUT_COLUMNS: tuple[Column, ...] = (
    Column("mass_kg", "float64", "kg", "vehicle mass (read back from MuJoCo)"),
    *[Column(f"cg_{a}_m", "float64", "m", "centre of gravity, body x, y, z (read back)")
      for a in "xyz"],
    *[Column(f"i{a}{a}_kg_m2", "float64", "kg m^2",
             f"principal moment of inertia about body {a} (read back)") for a in "xyz"],
    *_per_jet("jet_{jet}_thrust_n", "float64", "N", "thrust of the jet (read back)"),
    *_per_jet("jet_{jet}_tilt_deg", "float64", "deg",
              "signed tilt of the jet's thrust direction (the draw); misalignment = |tilt|"),
    *_per_jet("jet_{jet}_azimuth_deg", "float64", "deg", "azimuth of the tilt, [0, 360) (the draw)"),
)

#: What the run did.  Runs whose simulation failed (``sim_failed``) have NaN in every numeric
#: outcome: their state is not a flight.
OUTCOME_COLUMNS: tuple[Column, ...] = (
    *_per_axis("final_rate_err_{axis}_deg_s", "float64", "deg/s",
               "rate error about {axis} at the end of the run"),
    *_per_axis("final_att_err_{axis}_deg", "float64", "deg",
               "attitude error about {axis} (rotation-vector component) at the end"),
    Column("final_att_err_deg", "float64", "deg", "total attitude error at the end (norm)"),
    *_per_axis("firings_to_rate_{axis}", "float64", "-",
               "firing events on {axis}'s jets (cycles where one of them starts a firing; a "
               "pair is one event) before the commanded rate is first reached on {axis}: the "
               "first sample with |rate error| < thr not taken in the middle of a firing on "
               "{axis}; all of the run's events if never reached"),
    *_per_axis("time_to_rate_{axis}_s", "float64", "s",
               "time of that first sample; NaN if never reached"),
    *_per_axis("firings_{axis}", "float64", "-", "firing events on {axis}'s jets, whole run"),
    Column("firings_total", "float64", "-", "jet firings, whole run (a pair counts 2)"),
    *_per_jet("jet_{jet}_on_time_s", "float64", "s", "total on-time of the jet"),
    Column("propellant_kg", "float64", "kg", "propellant used, at the vehicle's Isp (280 s)"),
    Column("rate_settled_time_s", "float64", "s",
           "start of the final stretch in which every axis stays under thr through the end of "
           "the run (NaN if the run does not end under thr); rates only, unlike the "
           "att_rate_settled_time_s of `rcsim scenario compare` (attitude and rate)"),
    Column("sim_failed", "bool", "-", "the simulation failed (invalid parameters, divergence, "
           "or the run's flight raised)"),
    Column("failed", "bool", "-", "sim_failed, or some axis ends with |rate error| >= thr, "
           "or (if failure.attitude_error_deg is set) final_att_err_deg exceeds it"),
    Column("reason", "str", "-", "why the run failed; empty if it did not"),
)

RUN_COLUMNS: tuple[Column, ...] = ID_COLUMNS + INPUT_COLUMNS + OUTCOME_COLUMNS
OUTCOME_NAMES: tuple[str, ...] = tuple(c.name for c in OUTCOME_COLUMNS)
INPUT_NAMES: tuple[str, ...] = tuple(c.name for c in INPUT_COLUMNS)
RUN_NAMES: tuple[str, ...] = tuple(c.name for c in RUN_COLUMNS)
_NUMERIC_OUTCOMES = tuple(c.name for c in OUTCOME_COLUMNS if c.dtype == "float64")


def outcome_frame(values: dict) -> pd.DataFrame:
    """The outcome frame from ``values`` (column name -> (n,) array or list), in schema order.

    Raises
    ------
    KeyError
        ``values`` lacks a schema column or has one the schema does not define (a bug: the
        schema is the one list of outcomes).
    """
    missing = [n for n in OUTCOME_NAMES if n not in values]
    extra = [n for n in values if n not in OUTCOME_NAMES]
    if missing or extra:
        raise KeyError(f"outcomes differ from rcsim.analysis.campaign.schema: missing {missing}, "
                       f"undefined {extra}")
    return pd.DataFrame({c.name: _cast(values[c.name], c.dtype) for c in OUTCOME_COLUMNS})


def missing_outcomes(n: int, reason: str) -> pd.DataFrame:
    """Outcomes of ``n`` runs that have none (their flight raised): NaN, failed, ``reason``."""
    values: dict = {name: np.full(n, np.nan) for name in _NUMERIC_OUTCOMES}
    values.update(sim_failed=np.ones(n, bool), failed=np.ones(n, bool), reason=[reason] * n)
    return outcome_frame(values)


def check_run_frame(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` if its columns are exactly :data:`RUN_COLUMNS`, in order; else a KeyError."""
    if tuple(frame.columns) != RUN_NAMES:
        diff = sorted(set(frame.columns) ^ set(RUN_NAMES)) or "(order)"
        raise KeyError(f"runs frame differs from rcsim.analysis.campaign.schema: {diff}")
    return frame


def _cast(value, dtype: str):
    if dtype == "str":
        return list(value)  # pandas' own string inference, as for any list of str
    return np.asarray(value, dtype=dtype)


def markdown_table() -> str:
    """The schema as a Markdown table, per-axis and per-jet columns folded into one row."""
    rows, seen = [], set()
    for c in RUN_COLUMNS:
        name, meaning = c.name, c.meaning
        for axis in AXES:
            if f"_{axis}_" in name or name.endswith(f"_{axis}"):
                name = name.replace(axis, "<axis>", 1)
                meaning = meaning.replace(f"{axis}'s", "the axis's").replace(axis, "the axis")
                break
        if name.startswith("jet_") and name[4:6].isdigit():
            name = "jet_NN" + name[6:]
        if name.startswith("cg_") and name.endswith("_m"):
            name = "cg_{x,y,z}_m"
        if name in seen:
            continue
        seen.add(name)
        meaning = meaning.replace("|", "\\|")  # a literal | inside a Markdown table cell
        rows.append(f"| `{name}` | {c.dtype} | {c.unit} | {meaning} |")
    return "\n".join(["| column | type | unit | meaning |", "|---|---|---|---|", *rows])
