"""``runs.parquet`` and the campaign directory: the one owner of the data contract between the
engine that writes campaigns and everything that reads them.

It owns

* every column's name, dtype, unit and meaning (:func:`run_columns`, :data:`EFFECT_COLUMNS`;
  described in its column catalogue, :mod:`rcsim.analysis.engine.runs_catalogue`, re-exported here),
  with one set of per-jet columns (``jet_01_...`` to ``jet_NN_...``) per jet of the vehicle
  flown, whatever its count (``n_jets``: 16 for the paper's vehicle; :func:`recorded_jets`
  reads it back from a table);
* the file names of a campaign directory (:data:`MANIFEST`, :data:`RUNS`, ...) and how a
  directory is recognised as a campaign (:func:`is_campaign`);
* the mapping between a run's vehicle and its row, both ways: :func:`input_frame` writes the
  dispersed vehicle's columns, :func:`vehicles_from_runs` rebuilds the vehicles from them with
  the simulator's own pointing rule (:func:`rcsim.spacecraft.dispersions.pointing`).

Every producer and consumer of a run's row uses it:
:func:`~rcsim.analysis.engine.campaign.outcomes.outcomes` builds its frame through
:func:`outcome_frame`, the rows of runs that raised come from :func:`missing_outcomes`, the
campaign's assembly reads the per-case statistics' columns from here, the failure drivers read
inputs and vehicles through it, and ``docs/campaigns.md`` carries the table
:func:`markdown_table` prints (a test keeps them equal).

Definitions used below: ``thr`` is the spec's ``failure.rate_error_deg_s``; rate errors
(``omega - omega_cmd``, body axes) are sampled at the start of every 40 ms control cycle and at
the end of the run; an axis's jets are those whose torque has a component on it (Table 2 for
the paper's vehicle; a vehicle file's own jet matrix,
:func:`rcsim.spacecraft.vehicle.authority.torque_signs`, otherwise).
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.engine.runs_catalogue import (  # noqa: F401 - re-exported
    EFFECT_COLUMNS,
    EFFECT_GROUPS,
    EFFECT_NOT_APPLICABLE,
    ID_COLUMNS,
    INERTIA_NAMES,
    PRODUCT_COLUMNS,
    PRODUCT_NAMES,
    Column,
    all_columns,
    column_named,
    input_columns,
    input_names,
    is_propellant_motion,
    markdown_table,
    mode_column_suffix,
    mode_columns,
    outcome_columns,
    outcome_names,
    run_columns,
)
from rcsim.spacecraft.dispersions import DispersedRuns, pointing
from rcsim.spacecraft.propellant import inertia_tensor_B, principal
from rcsim.spacecraft.vehicle.model import jet_name
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

# The campaign directory (rcsim.analysis.engine.campaign.results writes it):
MANIFEST = "manifest.json"  # spec (resolved), code version, control cycle, times, status
RUNS = "runs.parquet"  # one row per run, these columns, sorted by run_id
ENVELOPES = "envelopes.parquet"  # per case and cycle: min / max / sum over runs
CASES = "cases.csv"  # per-case summary
CHUNKS = "chunks"  # finished chunks while the campaign runs
HISTORIES = "histories"  # kept per-run histories, run-NNNNNNN.parquet
PLOTS = "plots"  # Fig 9-14-like plots


def recorded_jets(columns) -> int:
    """How many jets a runs table records: its ``jet_01_thrust_n``, ``jet_02_thrust_n`` ...
    columns, counted up to the first missing (0 when it has none)."""
    names = set(columns)
    k = 0
    while f"{jet_name(k + 1)}_thrust_n" in names:
        k += 1
    return k


def outcome_frame(values: dict, n_jets: int) -> pd.DataFrame:
    """The outcome frame from ``values`` (column name -> (n,) array or list), in schema order,
    for a vehicle of ``n_jets`` jets.

    Raises
    ------
    KeyError
        ``values`` lacks a schema column or has one the schema does not define (a bug: the
        schema is the one list of outcomes).
    """
    columns = outcome_columns(n_jets)
    names = [c.name for c in columns]
    missing = [n for n in names if n not in values]
    extra = [n for n in values if n not in names]
    if missing or extra:
        raise KeyError(
            f"outcomes differ from rcsim.analysis.engine.runs_table: missing {missing}, "
            f"undefined {extra}"
        )
    return pd.DataFrame({c.name: _cast(values[c.name], c.dtype) for c in columns})


def missing_outcomes(n: int, reason: str, n_jets: int) -> pd.DataFrame:
    """Outcomes of ``n`` runs that have none (their flight raised): NaN, failed, ``reason``."""
    numeric = [c.name for c in outcome_columns(n_jets) if c.dtype == "float64"]
    values: dict = {name: np.full(n, np.nan) for name in numeric}
    values.update(sim_failed=np.ones(n, bool), failed=np.ones(n, bool), reason=[reason] * n)
    values["failed_by"] = ["simulation"] * n
    return outcome_frame(values, n_jets)


def effect_frame_of(values: dict, effects) -> pd.DataFrame:
    """The effect-input columns of ``effects`` from ``values`` (name -> (n,) array), in schema
    order and dtypes; a KeyError when a column is missing (a bug)."""
    cols = [c for g in EFFECT_GROUPS if g in effects for c in EFFECT_COLUMNS[g]]
    missing = [c.name for c in cols if c.name not in values]
    if missing:
        raise KeyError(f"effect inputs lack {missing} (rcsim.analysis.engine.runs_table)")
    return pd.DataFrame({c.name: _cast(values[c.name], c.dtype) for c in cols})


def check_run_frame(
    frame: pd.DataFrame, effects=(), products: bool = False, *, n_jets: int, modes=()
) -> pd.DataFrame:
    """``frame`` if its columns are exactly :func:`run_columns` of ``effects``, ``products``,
    ``n_jets`` and ``modes``, in order; else a KeyError."""
    names = tuple(c.name for c in run_columns(effects, products, n_jets=n_jets, modes=modes))
    if tuple(frame.columns) != names:
        diff = sorted(set(frame.columns) ^ set(names)) or "(order)"
        raise KeyError(f"runs frame differs from rcsim.analysis.engine.runs_table: {diff}")
    return frame


def _cast(value, dtype: str):
    if dtype == "str":
        return list(value)  # pandas' own string inference, as for any list of str
    return np.asarray(value, dtype=dtype)


# ----------------------------------------------------------------------- vehicles <-> rows --
def _jet_columns(kind: str, n_jets: int) -> list[str]:
    """``jet_NN_<kind>`` of each of ``n_jets`` jets, in jet order (``thrust_n``, ...)."""
    return [f"{jet_name(j + 1)}_{kind}" for j in range(n_jets)]


_CG = [f"cg_{a}_m" for a in "xyz"]
_INERTIA = list(INERTIA_NAMES)


_PRODUCT_ENTRIES = ((0, 1), (0, 2), (1, 2))


def records_products(params: RunParameters) -> bool:
    """Whether the rows of runs flown with ``params`` record :data:`PRODUCT_COLUMNS`: whenever
    their principal axes are not B (``params.iquat`` set: the vehicle file has products of
    inertia, or the campaign disperses them; fixed for a campaign), so that the flown tensor
    is in the table; never for the paper's vehicle with undispersed products."""
    return params.iquat is not None


def input_frame(runs: DispersedRuns) -> pd.DataFrame:
    """The :func:`input_columns` of dispersed runs (SI; angles in degrees at this boundary),
    one set of per-jet columns per jet of their vehicle, and the :data:`PRODUCT_COLUMNS` when
    :func:`records_products`.

    Jet tilt and azimuth are the draws (MuJoCo holds only the direction they make);
    :func:`vehicles_from_runs` is the inverse.  The inertia columns are the tensor in B
    rebuilt from each run's principal moments and frame
    (:func:`rcsim.spacecraft.propellant.inertia_tensor_B`; for runs without a frame, principal axes
    along B, the moments themselves, bit for bit).
    """
    p = runs.params
    products = records_products(p)
    if products:
        tensor = inertia_tensor_B(p)
        inertia = np.diagonal(tensor, axis1=1, axis2=2)
        extra = {c: tensor[:, a, b] for c, (a, b) in zip(PRODUCT_NAMES, _PRODUCT_ENTRIES)}
    else:
        inertia, extra = p.inertia_B, {}
    jets = p.n_jets
    cols = {
        "mass_kg": p.mass_kg,
        **{c: p.cg_B[:, a] for a, c in enumerate(_CG)},
        **{c: inertia[:, a] for a, c in enumerate(_INERTIA)},
        **dict(zip(_jet_columns("thrust_n", jets), p.thrust_n.T)),
        **dict(zip(_jet_columns("tilt_deg", jets), np.degrees(runs.tilt_rad).T)),
        **dict(zip(_jet_columns("azimuth_deg", jets), np.degrees(runs.azimuth_rad).T)),
        **extra,
    }
    names = list(input_names(jets)) + (list(PRODUCT_NAMES) if products else [])
    return pd.DataFrame(cols)[names]  # a KeyError if the two ever disagree


def axis_inertia(runs: pd.DataFrame) -> np.ndarray:
    """Moment of inertia about each body axis of every row, (n, 3) [kg m^2]: the recorded
    ``ixx_kg_m2``, ``iyy_kg_m2``, ``izz_kg_m2``, the tensor's diagonal in B."""
    return runs[_INERTIA].to_numpy(float)


def vehicles_from_runs(
    runs: pd.DataFrame, nominal: RunParameters
) -> tuple[RunParameters, RunParameters]:
    """Rebuild each run's vehicle from its recorded :func:`input_columns`.

    Parameters
    ----------
    runs : DataFrame
        Rows of ``runs.parquet`` (or any table with the input columns of ``nominal``'s jets).
    nominal : RunParameters
        The nominal vehicle (one run) whose jets the tilts are measured from.

    Returns
    -------
    dispersed : RunParameters
        As flown (thrust, pointing, CG, inertia), one entry per row.
    nominal_pointing : RunParameters
        The same with every jet pointing nominally.
    """
    n, jets = len(runs), nominal.n_jets
    tilt = np.radians(runs[_jet_columns("tilt_deg", jets)].to_numpy(float))
    azimuth = np.radians(runs[_jet_columns("azimuth_deg", jets)].to_numpy(float))
    inertia, iquat = runs[_INERTIA].to_numpy(float), None
    if all(c in runs.columns for c in PRODUCT_NAMES):  # the whole tensor in B
        tensor = np.zeros((n, 3, 3))
        tensor[:, [0, 1, 2], [0, 1, 2]] = inertia
        for c, (a, b) in zip(PRODUCT_NAMES, _PRODUCT_ENTRIES):
            tensor[:, a, b] = tensor[:, b, a] = runs[c].to_numpy(float)
        inertia, iquat = principal(tensor)
    straight = RunParameters(
        mass_kg=runs["mass_kg"].to_numpy(float),
        cg_B=runs[_CG].to_numpy(float),
        inertia_B=inertia,
        thrust_n=runs[_jet_columns("thrust_n", jets)].to_numpy(float),
        jet_dir_S=np.repeat(nominal.jet_dir_S, n, axis=0),
        isp_s=nominal.isp_s,
        iquat=iquat,
    )
    dispersed = replace(straight, jet_dir_S=pointing(nominal.jet_dir_S, tilt, azimuth))
    return dispersed, straight


# ------------------------------------------------------------------------- the directory --
def is_campaign(path: str | os.PathLike) -> bool:
    """``path`` is a campaign directory: it holds a :data:`MANIFEST` (its runs may still be
    running: :data:`RUNS` appears when the campaign completes)."""
    return (Path(path) / MANIFEST).is_file()


def criterion_text(
    rate_error_deg_s: float,
    attitude_error_deg: float | None = None,
    *,
    vehicle_file: bool = False,
    budgets: dict | None = None,
) -> str:
    """What the ``failed`` column means, in words, as the campaign's outcomes apply it
    (:func:`rcsim.analysis.engine.campaign.outcomes.outcomes`: a run fails when ``not |rate error| <
    threshold``, i.e. at the threshold too): the one wording every report uses.
    ``vehicle_file``: the campaign flew a vehicle file, whose propellant may run out (a
    failure too).  ``budgets``: the spec's ``[failure]`` ``max_propellant_kg`` /
    ``max_delta_v_m_s`` (a manifest's ``thresholds``; absent keys and None are not set)."""
    parts = [f"|final rate error| >= {rate_error_deg_s:g} deg/s on any axis"]
    if attitude_error_deg is not None:
        parts.append(f"final attitude error > {attitude_error_deg:g} deg")
    if vehicle_file:
        parts.append("propellant exhausted (a vehicle file's [propellant] mass_kg)")
    parts += _budget_parts(budgets or {})
    return " or ".join(parts + ["simulation failure"])


def _budget_parts(budgets: dict) -> list[str]:
    """The criterion's words for the propellant and delta-v budgets that are set."""
    parts = []
    if budgets.get("max_propellant_kg") is not None:
        parts.append(f"propellant used > {float(budgets['max_propellant_kg']):g} kg")
    if budgets.get("max_delta_v_m_s") is not None:
        parts.append(f"net delta-v (inertial) > {float(budgets['max_delta_v_m_s']):g} m/s")
    return parts


def dispersions_source(resolved: dict) -> str:
    """Which dispersion table a resolved spec (:attr:`CampaignSpec.resolved`, or a manifest's
    ``spec``) flies, in words: with ``table = "default"`` it is the vehicle file's
    ``[dispersions]`` when the spec names a ``vehicle``, else Gambone Table 5 (packaged)."""
    table = (resolved.get("dispersions") or {}).get("table", "default")
    if table != "default":
        return f"the table file {table}"
    if resolved.get("vehicle"):
        return "the vehicle file's [dispersions]"
    return "Gambone Table 5 (packaged)"
