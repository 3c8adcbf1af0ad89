"""``runs.parquet`` and the campaign directory: the one owner of the data contract between the
engine that writes campaigns and everything that reads them.

It owns

* every column's name, dtype, unit and meaning (:func:`run_columns`, :data:`EFFECT_COLUMNS`),
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
:func:`rcsim.spacecraft.vehicle_file.authority.torque_signs`, otherwise).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.engine.run_margin import MARGIN_MEANING
from rcsim.spacecraft.dispersions import DispersedRuns, pointing
from rcsim.spacecraft.propellant import inertia_tensor_B, principal
from rcsim.spacecraft.vehicle import AXES, VehicleParams, jet_name

# The campaign directory (rcsim.analysis.engine.campaign.results writes it):
MANIFEST = "manifest.json"  # spec (resolved), code version, control cycle, times, status
RUNS = "runs.parquet"  # one row per run, these columns, sorted by run_id
ENVELOPES = "envelopes.parquet"  # per case and cycle: min / max / sum over runs
CASES = "cases.csv"  # per-case summary
CHUNKS = "chunks"  # finished chunks while the campaign runs
HISTORIES = "histories"  # kept per-run histories, run-NNNNNNN.parquet
PLOTS = "plots"  # Fig 9-14-like plots


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


def _per_jet(pattern: str, dtype: str, unit: str, meaning: str, n_jets: int) -> list[Column]:
    """One column per jet of a vehicle of ``n_jets`` jets, ``{jet}`` -> ``01``, ``02`` ..."""
    return [
        Column(pattern.format(jet=jet_name(j + 1)[4:]), dtype, unit, meaning) for j in range(n_jets)
    ]


#: Identity of a run.
ID_COLUMNS: tuple[Column, ...] = (
    Column("run_id", "int64", "-", "run number: case_index * runs_per_case + k"),
    Column("case", "str", "-", "case name (rate-NN, damp-NN, or the maneuver / hold name)"),
    Column("case_index", "int64", "-", "position of the case in the spec"),
    Column(
        "seed",
        "int64",
        "-",
        "the spec's root seed; run i draws from SeedSequence(seed, spawn_key=(i,)).spawn(2)[0]",
    ),
)


def input_columns(n_jets: int) -> tuple[Column, ...]:
    """The dispersed vehicle the run flew (:func:`input_frame`), read back from the simulation's
    per-run MuJoCo model where MuJoCo holds the value; per-jet columns for ``n_jets`` jets."""
    return _VEHICLE_INPUTS + tuple(
        c for pattern in _JET_INPUTS for c in _per_jet(*pattern, n_jets=n_jets)
    )


_VEHICLE_INPUTS: tuple[Column, ...] = (
    Column("mass_kg", "float64", "kg", "vehicle mass (read back from MuJoCo)"),
    *[
        Column(f"cg_{a}_m", "float64", "m", "centre of gravity, body x, y, z (read back)")
        for a in "xyz"
    ],
    *[
        Column(
            f"i{a}{a}_kg_m2",
            "float64",
            "kg m^2",
            "moments of inertia about body x, y, z through the CG: the inertia tensor's "
            "diagonal entries in B, rebuilt from the principal moments and frame read back "
            "from MuJoCo (for a vehicle whose principal axes are B, as the paper's, its "
            "principal moments)",
        )
        for a in "xyz"
    ],
)
# Per jet, in this order (each for every jet before the next): (pattern, dtype, unit, meaning).
_JET_INPUTS = (
    ("jet_{jet}_thrust_n", "float64", "N", "thrust of the jet (read back)"),
    (
        "jet_{jet}_tilt_deg",
        "float64",
        "deg",
        "signed tilt of the jet's thrust direction (the draw); misalignment = |tilt|",
    ),
    ("jet_{jet}_azimuth_deg", "float64", "deg", "azimuth of the tilt, [0, 360) (the draw)"),
)

#: Products of inertia, present when the runs' principal axes are not B (:func:`records_products`:
#: the vehicle file has products of inertia, or the campaign disperses them with ``ixy_kg_m2``,
#: ``ixz_kg_m2`` or ``iyz_kg_m2`` in the spec's ``[dispersions.three_sigma]`` or the vehicle
#: file's ``[dispersions]``), after the vehicle inputs; with the inertia columns they are the
#: whole tensor flown, about the CG in B.  A campaign of a vehicle whose principal axes are B
#: without dispersed products (the paper's) keeps its columns.
PRODUCT_COLUMNS: tuple[Column, ...] = tuple(
    Column(
        f"i{a}_kg_m2",
        "float64",
        "kg m^2",
        f"product of inertia I_{a}, the tensor entry in B (-sum m {a[0]} {a[1]}; MuJoCo's "
        "fullinertia convention), read back from the run's principal moments and frame",
    )
    for a in ("xy", "xz", "yz")
)
PRODUCT_NAMES: tuple[str, ...] = tuple(c.name for c in PRODUCT_COLUMNS)


def outcome_columns(n_jets: int) -> tuple[Column, ...]:
    """What the run did, with per-jet columns for ``n_jets`` jets.  Runs whose simulation
    failed (``sim_failed``) have NaN in every numeric outcome: their state is not a flight."""
    return _OUTCOMES_BEFORE_JETS + tuple(_per_jet(*_JET_OUTCOME, n_jets=n_jets)) + _OUTCOMES_AFTER


_OUTCOMES_BEFORE_JETS: tuple[Column, ...] = (
    *_per_axis(
        "final_rate_err_{axis}_deg_s",
        "float64",
        "deg/s",
        "rate error about {axis} at the end of the run",
    ),
    *_per_axis(
        "final_att_err_{axis}_deg",
        "float64",
        "deg",
        "attitude error about {axis} (rotation-vector component) at the end",
    ),
    Column("final_att_err_deg", "float64", "deg", "total attitude error at the end (norm)"),
    *_per_axis(
        "firings_to_rate_{axis}",
        "float64",
        "-",
        "firing events on {axis}'s jets (cycles where one of them starts a firing; a "
        "pair is one event) before the commanded rate is first reached on {axis}: the "
        "first sample with |rate error| < thr not taken in the middle of a firing on "
        "{axis}; all of the run's events if never reached",
    ),
    *_per_axis(
        "time_to_rate_{axis}_s", "float64", "s", "time of that first sample; NaN if never reached"
    ),
    *_per_axis(
        "firings_{axis}",
        "float64",
        "-",
        "firing events on {axis}'s jets, whole run (none commanded after the propellant ran "
        "out: those jets deliver nothing)",
    ),
    Column(
        "firings_total",
        "float64",
        "-",
        "jet firings, whole run (a pair counts 2; none commanded after the propellant ran out)",
    ),
)
_JET_OUTCOME = (
    "jet_{jet}_on_time_s",
    "float64",
    "s",
    "total on-time of the jet: what it delivered (with valve timing -- the vehicle file's or "
    "[dispersions.timing] -- or [dispersions.fault], the commands moved by the delays, plus "
    "stuck-on time, minus failed time)",
)
_OUTCOMES_AFTER: tuple[Column, ...] = (
    Column(
        "propellant_kg",
        "float64",
        "kg",
        "propellant used, F t / (Isp g0) at the vehicle's Isp (280 s unless its vehicle file "
        "says); its exhaustion is a failure reason",
    ),
    Column(
        "rate_settled_time_s",
        "float64",
        "s",
        "start of the final stretch in which every axis stays under thr through the end of "
        "the run (NaN if the run does not end under thr); rates only, unlike the "
        "att_rate_settled_time_s of `rcsim scenario compare` (attitude and rate)",
    ),
    Column(
        "sim_failed",
        "bool",
        "-",
        "the simulation failed (invalid parameters, divergence, or the run's flight raised)",
    ),
    Column(
        "failed",
        "bool",
        "-",
        "sim_failed, or some axis ends with |rate error| >= thr, "
        "or (if failure.attitude_error_deg is set) final_att_err_deg exceeds it, or the "
        "propellant ran out (a vehicle file's [propellant] mass_kg)",
    ),
    Column("reason", "str", "-", "why the run failed; empty if it did not"),
    Column("margin", "float64", "-", MARGIN_MEANING),
)

#: Optional inputs, present only in campaigns whose spec has the matching table
#: (``[dispersions.sensor]``, ``[dispersions.timing]``, ``[dispersions.fault]``; draws of
#: :mod:`rcsim.spacecraft.effect_draws`), after the vehicle inputs in this order.  A campaign
#: without them keeps exactly the columns it always had (it resumes and replays as before).
EFFECT_COLUMNS: dict[str, tuple[Column, ...]] = {
    "sensor": (
        *_per_axis(
            "att_bias_{axis}_deg",
            "float64",
            "deg",
            "attitude sensor bias about {axis} (drawn per run; the measured attitude is "
            "the true one rotated by bias and white noise)",
        ),
        *_per_axis(
            "rate_bias_{axis}_deg_s",
            "float64",
            "deg/s",
            "rate gyro bias about {axis} at the start (drawn per run; a random walk "
            "and white noise add to it in flight)",
        ),
    ),
    "timing": (
        Column(
            "command_delay_s",
            "float64",
            "s",
            "sensor-to-actuator delay: valve commands start this late in each cycle",
        ),
        Column(
            "open_delay_max_s",
            "float64",
            "s",
            "largest valve opening latency of the run's jets (drawn per jet)",
        ),
        Column(
            "close_delay_max_s",
            "float64",
            "s",
            "largest valve closing latency of the run's jets (drawn per jet)",
        ),
    ),
    "fault": (
        Column(
            "fault_jet",
            "int64",
            "-",
            "the faulty jet, 1..n_jets of the vehicle; 0 if the run has no fault",
        ),
        Column(
            "fault_time_s",
            "float64",
            "s",
            "failure time (mode off) or start of the stuck window (mode stuck); NaN if "
            "no fault or mode degraded (degraded for the whole run)",
        ),
        Column(
            "fault_stuck_for_s",
            "float64",
            "s",
            "length of the stuck-on window (mode stuck); NaN otherwise",
        ),
        Column(
            "fault_thrust_factor",
            "float64",
            "-",
            "thrust of the faulty jet as a fraction of its own (mode degraded); 1 for the "
            "other modes and for runs without a fault",
        ),
    ),
}
EFFECT_GROUPS: tuple[str, ...] = tuple(EFFECT_COLUMNS)
#: Effect columns that are NaN where the effect does not apply, and what that NaN means as an
#: input of the driver analysis: (the run's place on the column's scale, why).  Rank-based
#: analyses need a number; these put "no such event" beyond every run that had one.
EFFECT_NOT_APPLICABLE: dict[str, tuple[str, str]] = {
    "fault_time_s": (
        "after",
        "a run without a fault (or with a jet degraded all along) counts "
        "as failing after the latest fault time",
    ),
    "fault_stuck_for_s": ("zero", "a run without a stuck window counts as stuck for 0 s"),
}

_NUMERIC_OUTCOMES = tuple(
    c.name for c in _OUTCOMES_BEFORE_JETS + _OUTCOMES_AFTER if c.dtype == "float64"
)


def input_names(n_jets: int) -> tuple[str, ...]:
    """Names of :func:`input_columns` ``(n_jets)``."""
    return tuple(c.name for c in input_columns(n_jets))


def outcome_names(n_jets: int) -> tuple[str, ...]:
    """Names of :func:`outcome_columns` ``(n_jets)``."""
    return tuple(c.name for c in outcome_columns(n_jets))


def all_columns(n_jets: int) -> tuple[Column, ...]:
    """Every column a runs.parquet of a vehicle of ``n_jets`` jets may have (products and all
    effect groups), in order."""
    return run_columns(EFFECT_GROUPS, True, n_jets=n_jets)


def recorded_jets(columns) -> int:
    """How many jets a runs table records: its ``jet_01_thrust_n``, ``jet_02_thrust_n`` ...
    columns, counted up to the first missing (0 when it has none)."""
    names = set(columns)
    k = 0
    while f"{jet_name(k + 1)}_thrust_n" in names:
        k += 1
    return k


def column_named(name: str) -> Column | None:
    """The schema's column ``name`` (a per-jet column of any jet number included), or None."""
    schema_name = name
    if name.startswith("jet_"):
        number, _, kind = name[4:].partition("_")
        if number.isdigit() and int(number) >= 1 and name == f"{jet_name(int(number))}_{kind}":
            schema_name = f"jet_01_{kind}"  # every jet's column: the same dtype, unit, meaning
    for c in all_columns(1):
        if c.name == schema_name:
            return replace(c, name=name)
    return None


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
    numeric = _NUMERIC_OUTCOMES + tuple(c.name for c in _per_jet(*_JET_OUTCOME, n_jets=n_jets))
    values: dict = {name: np.full(n, np.nan) for name in numeric}
    values.update(sim_failed=np.ones(n, bool), failed=np.ones(n, bool), reason=[reason] * n)
    return outcome_frame(values, n_jets)


def run_columns(effects=(), products: bool = False, *, n_jets: int) -> tuple[Column, ...]:
    """The columns of a campaign whose spec has the effect groups ``effects`` (names of
    :data:`EFFECT_COLUMNS`), with ``products`` records products of inertia
    (:func:`records_products`), and whose vehicle has ``n_jets`` jets, in order."""
    unknown = [g for g in effects if g not in EFFECT_COLUMNS]
    if unknown:
        raise KeyError(f"unknown effect group(s) {unknown}; known: {list(EFFECT_GROUPS)}")
    extra = tuple(c for g in EFFECT_GROUPS if g in effects for c in EFFECT_COLUMNS[g])
    inputs = input_columns(n_jets) + (PRODUCT_COLUMNS if products else ())
    return ID_COLUMNS + inputs + extra + outcome_columns(n_jets)


def effect_frame_of(values: dict, effects) -> pd.DataFrame:
    """The effect-input columns of ``effects`` from ``values`` (name -> (n,) array), in schema
    order and dtypes; a KeyError when a column is missing (a bug)."""
    cols = [c for g in EFFECT_GROUPS if g in effects for c in EFFECT_COLUMNS[g]]
    missing = [c.name for c in cols if c.name not in values]
    if missing:
        raise KeyError(f"effect inputs lack {missing} (rcsim.analysis.engine.runs_table)")
    return pd.DataFrame({c.name: _cast(values[c.name], c.dtype) for c in cols})


def check_run_frame(
    frame: pd.DataFrame, effects=(), products: bool = False, *, n_jets: int
) -> pd.DataFrame:
    """``frame`` if its columns are exactly :func:`run_columns` of ``effects``, ``products``
    and ``n_jets``, in order; else a KeyError."""
    names = tuple(c.name for c in run_columns(effects, products, n_jets=n_jets))
    if tuple(frame.columns) != names:
        diff = sorted(set(frame.columns) ^ set(names)) or "(order)"
        raise KeyError(f"runs frame differs from rcsim.analysis.engine.runs_table: {diff}")
    return frame


def _cast(value, dtype: str):
    if dtype == "str":
        return list(value)  # pandas' own string inference, as for any list of str
    return np.asarray(value, dtype=dtype)


def markdown_table() -> str:
    """The schema as a Markdown table (every column, the optional effect inputs included),
    per-axis and per-jet columns folded into one row."""
    rows, seen = [], set()
    group_of = {c.name: g for g in EFFECT_GROUPS for c in EFFECT_COLUMNS[g]}
    for c in all_columns(1):  # per-jet columns are folded into one row: one jet shows them
        name, meaning = c.name, c.meaning
        if name in group_of:
            meaning = f"{meaning} (only with [dispersions.{group_of[name]}])"
        if name in PRODUCT_NAMES:
            meaning = f"{meaning} (only when the vehicle has or the campaign disperses them)"
        for axis in AXES:
            if f"_{axis}_" in name or name.endswith(f"_{axis}"):
                name = name.replace(axis, "<axis>", 1)
                meaning = meaning.replace(f"{axis}'s", "the axis's").replace(axis, "the axis")
                break
        if name.startswith("jet_") and name[4:6].isdigit():
            name = "jet_NN" + name[6:]
        if name.startswith("cg_") and name.endswith("_m"):
            name = "cg_{x,y,z}_m"
        if name in _INERTIA:
            name = "i{xx,yy,zz}_kg_m2"
        if name in PRODUCT_NAMES:
            name = "i{xy,xz,yz}_kg_m2"
            meaning = meaning.replace("I_xy", "I_ab").replace("-sum m x y", "-sum m a b")
        if name in seen:
            continue
        seen.add(name)
        meaning = meaning.replace("|", "\\|")  # a literal | inside a Markdown table cell
        rows.append(f"| `{name}` | {c.dtype} | {c.unit} | {meaning} |")
    return "\n".join(["| column | type | unit | meaning |", "|---|---|---|---|", *rows])


# ----------------------------------------------------------------------- vehicles <-> rows --
def _jet_columns(kind: str, n_jets: int) -> list[str]:
    """``jet_NN_<kind>`` of each of ``n_jets`` jets, in jet order (``thrust_n``, ...)."""
    return [f"{jet_name(j + 1)}_{kind}" for j in range(n_jets)]


_CG = [f"cg_{a}_m" for a in "xyz"]
_INERTIA = [f"i{a}{a}_kg_m2" for a in "xyz"]


_PRODUCT_ENTRIES = ((0, 1), (0, 2), (1, 2))


def records_products(params: VehicleParams) -> bool:
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
    runs: pd.DataFrame, nominal: VehicleParams
) -> tuple[VehicleParams, VehicleParams]:
    """Rebuild each run's vehicle from its recorded :func:`input_columns`.

    Parameters
    ----------
    runs : DataFrame
        Rows of ``runs.parquet`` (or any table with the input columns of ``nominal``'s jets).
    nominal : VehicleParams
        The nominal vehicle (one run) whose jets the tilts are measured from.

    Returns
    -------
    dispersed : VehicleParams
        As flown (thrust, pointing, CG, inertia), one entry per row.
    nominal_pointing : VehicleParams
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
    straight = VehicleParams(
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
    rate_error_deg_s: float, attitude_error_deg: float | None = None, *, vehicle_file: bool = False
) -> str:
    """What the ``failed`` column means, in words, as the campaign's outcomes apply it
    (:func:`rcsim.analysis.engine.campaign.outcomes.outcomes`: a run fails when ``not |rate error| <
    threshold``, i.e. at the threshold too): the one wording every report uses.
    ``vehicle_file``: the campaign flew a vehicle file, whose propellant may run out (a
    failure too)."""
    parts = [f"|final rate error| >= {rate_error_deg_s:g} deg/s on any axis"]
    if attitude_error_deg is not None:
        parts.append(f"final attitude error > {attitude_error_deg:g} deg")
    if vehicle_file:
        parts.append("propellant exhausted (a vehicle file's [propellant] mass_kg)")
    return " or ".join(parts + ["simulation failure"])


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
