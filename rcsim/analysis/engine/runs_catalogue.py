"""The column catalogue of ``runs.parquet``: every column's name, dtype, unit and meaning.

:mod:`rcsim.analysis.engine.runs_table` owns the data contract (frames, the campaign directory,
vehicles <-> rows) and re-exports these names; this module only describes the columns
(:func:`run_columns`, :data:`EFFECT_COLUMNS`, :func:`markdown_table`, the table
``docs/campaigns.md`` carries).  Definitions used in the meanings are in the docstring of
:mod:`rcsim.analysis.engine.runs_table` (``thr``, an axis's jets).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from rcsim.analysis.engine.run_margin import MARGIN_MEANING
from rcsim.spacecraft.vehicle.model import AXES, jet_name


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
#: The moments-of-inertia columns (the tensor's diagonal in B).
INERTIA_NAMES: tuple[str, ...] = tuple(f"i{a}{a}_kg_m2" for a in "xyz")


def outcome_columns(n_jets: int) -> tuple[Column, ...]:
    """What the run did, with per-jet columns for ``n_jets`` jets.  Runs whose simulation
    failed (``sim_failed``) have NaN in every numeric outcome: their state is not a flight."""
    return (
        _OUTCOMES_BEFORE_JETS
        + tuple(_per_jet(*_JET_OUTCOME, n_jets=n_jets))
        + _OUTCOMES_AFTER
        + propellant_motion_columns(n_jets)
        + (Column("margin", "float64", "-", MARGIN_MEANING),)
    )


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
    "stuck-on time, minus failed time; with a `[pulse]`, the time its valve is open and it "
    "thrusts: its tail-off after the valve closes is in its impulse, not its on-time)",
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
        "propellant ran out (a vehicle file's [propellant] mass_kg), or (if set) "
        "propellant_kg exceeds failure.max_propellant_kg or delta_v_N_m_s exceeds "
        "failure.max_delta_v_m_s; failed_by says which",
    ),
    Column("reason", "str", "-", "why the run failed; empty if it did not"),
)


def _per_component(frame: str, meaning: str) -> list[Column]:
    """``delta_v_<x|y|z>_<frame>_m_s``: one column per axis of ``frame`` (``N`` or ``B``)."""
    return [
        Column(f"delta_v_{a}_{frame}_m_s", "float64", "m/s", meaning.format(a=a)) for a in "xyz"
    ]


#: Propellant, translation and limit-cycle measures of a run, after the other outcomes
#: (:func:`rcsim.analysis.engine.campaign.motion.motion_outcomes` computes them).  Per-jet ones
#: follow the jets; the names ``propellant_kg``, ``delta_v_N_m_s``, ``delta_v_B_m_s``,
#: ``pulses`` and ``min_pulses`` are read by name downstream (reports, plots, analyze).
_MOTION_BEFORE_JETS: tuple[Column, ...] = (
    *_per_component(
        "N",
        "net delta-v of the CG along inertial {a} over the run: MuJoCo's CG velocity at the end "
        "minus at the start (translation every firing leaves; docking and formation budgets)",
    ),
    Column("delta_v_N_m_s", "float64", "m/s", "norm of the net inertial delta-v of the CG"),
    *_per_component(
        "B",
        "net delta-v along body {a} over the run: each jet's delivered impulse along its "
        "flown direction in B, summed, over the run's wet mass at the start (integral of the "
        "thrust acceleration in body axes)",
    ),
    Column("delta_v_B_m_s", "float64", "m/s", "norm of the net body-axes delta-v"),
    Column(
        "pulses",
        "float64",
        "-",
        "jet pulses (firings started), whole run: firings_total by the limit-cycle name",
    ),
    Column(
        "min_pulses",
        "float64",
        "-",
        "pulses fired at the jets' minimum on-time (the profile's min_pulse_s, to 1e-9 of a "
        "cycle; 0 when it has none): the limit cycle's pulses",
    ),
    Column("pulses_per_min", "float64", "1/min", "pulses per minute of the run's flown duration"),
)
_MOTION_JETS = (
    (
        "jet_{jet}_propellant_kg",
        "float64",
        "kg",
        "propellant the jet used: its delivered impulse / (Isp g0)",
    ),
    (
        "jet_{jet}_duty",
        "float64",
        "-",
        "duty cycle of the jet: its on-time over the run's flown duration",
    ),
)


_FAILED_BY = Column(
    "failed_by",
    "str",
    "-",
    "the failure criteria the run met, joined by +: simulation, rate, attitude, "
    "propellant_exhausted, max_propellant_kg, max_delta_v_m_s (the [failure] budgets); "
    "empty if it did not fail",
)


def is_propellant_motion(name: str) -> bool:
    """``name`` is ``propellant_kg`` or one of :func:`propellant_motion_columns` (of any jet
    number): an outcome, never an input of a driver analysis."""
    if name.startswith("jet_"):
        number, _, kind = name[4:].partition("_")
        if number.isdigit() and int(number) >= 1:
            name = f"jet_01_{kind}"
    return name == "propellant_kg" or name in {c.name for c in propellant_motion_columns(1)}


def propellant_motion_columns(n_jets: int) -> tuple[Column, ...]:
    """The propellant, delta-v and pulse outcomes (:data:`_MOTION_BEFORE_JETS`), the per-jet
    propellant and duty columns of ``n_jets`` jets, then ``failed_by``."""
    per_jet = tuple(c for pattern in _MOTION_JETS for c in _per_jet(*pattern, n_jets=n_jets))
    return _MOTION_BEFORE_JETS + per_jet + (_FAILED_BY,)


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
    "pulse": (
        Column(
            "pulse_rise_mean_s",
            "float64",
            "s",
            "rise time (constant or ramp) flown, mean over the run's jets (drawn per jet; "
            "0 for an impulse-bit table)",
        ),
        Column(
            "pulse_tail_mean_s",
            "float64",
            "s",
            "tail-off time (constant or ramp) flown, mean over the run's jets (drawn per "
            "jet; 0 for an impulse-bit table)",
        ),
        Column(
            "impulse_bit_scale_mean",
            "float64",
            "-",
            "factor on the impulse-bit table's impulses, mean over the run's jets (drawn "
            "per jet; 1 without a table)",
        ),
    ),
    "blowdown": (
        Column(
            "tank_pressure_pa",
            "float64",
            "Pa",
            "initial tank pressure of the blowdown flown (drawn per run)",
        ),
    ),
}
EFFECT_GROUPS: tuple[str, ...] = tuple(EFFECT_COLUMNS)
#: Where each effect group comes from, as the schema's table says it.
EFFECT_SOURCES = {
    "pulse": "the vehicle file's [dispersions] pulse_rise_s, pulse_tail_s or impulse_bit",
    "blowdown": "the vehicle file's [dispersions] tank_pressure_pa",
}
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


#: Per-mode inputs of a vehicle whose file disperses its modes (``*_3sigma`` keys of a
#: ``[[slosh]]`` or ``[[appendage]]`` block; :func:`rcsim.spacecraft.modes.draws.flown_values`),
#: after the effect inputs, in the file's mode order: the unit and meaning of the columns
#: ``mode_<name>_<suffix>`` each kind of mode has (suffix -> unit, meaning).
MODE_SUFFIXES: dict[str, tuple[str, str]] = {
    "freq_hz": ("Hz", "clamped (hub held still) frequency of the mode flown (drawn per run)"),
    "coupled_freq_hz": (
        "Hz",
        "lowest coupled frequency of the mode on the run's hub as flown, the other modes held "
        "at rest on it (linearised about rest: rcsim/spacecraft/modes/linear.py)",
    ),
    "damping": ("-", "damping ratio of the mode flown (drawn per run)"),
    "mass_kg": ("kg", "slosh mass flown (drawn per run; the hub's mass is mass_kg)"),
    "inertia_kg_m2": ("kg m^2", "the panel's inertia about its hinge (not dispersed)"),
}
MODE_KIND_SUFFIXES: dict[str, tuple[str, ...]] = {
    "spring": ("freq_hz", "coupled_freq_hz", "damping", "mass_kg"),
    "pendulum": ("mass_kg",),
    "panel": ("freq_hz", "coupled_freq_hz", "damping", "inertia_kg_m2"),
}
#: The modes whose columns :func:`all_columns` shows (the schema's table): one of each kind.
_SCHEMA_MODES = (("<name>", "spring"), ("<name>", "panel"), ("<name>", "pendulum"))


def mode_columns(modes=()) -> tuple[Column, ...]:
    """The columns of ``modes``: ``(name, kind)`` pairs (kind ``spring``, ``pendulum`` or
    ``panel``: :func:`rcsim.spacecraft.modes.draws.mode_kind`), in order."""
    return tuple(
        Column(f"mode_{name}_{suffix}", "float64", *MODE_SUFFIXES[suffix])
        for name, kind in modes
        for suffix in MODE_KIND_SUFFIXES[kind]
    )


def mode_column_suffix(name: str) -> str | None:
    """The :data:`MODE_SUFFIXES` key of a per-mode column ``mode_<name>_<suffix>``, or None."""
    if not name.startswith("mode_"):
        return None
    # the longest suffix first: coupled_freq_hz before freq_hz
    for suffix in sorted(MODE_SUFFIXES, key=len, reverse=True):
        if name.endswith(f"_{suffix}") and len(name) > len(f"mode__{suffix}"):
            return suffix
    return None


def input_names(n_jets: int) -> tuple[str, ...]:
    """Names of :func:`input_columns` ``(n_jets)``."""
    return tuple(c.name for c in input_columns(n_jets))


def outcome_names(n_jets: int) -> tuple[str, ...]:
    """Names of :func:`outcome_columns` ``(n_jets)``."""
    return tuple(c.name for c in outcome_columns(n_jets))


def all_columns(n_jets: int) -> tuple[Column, ...]:
    """Every column a runs.parquet of a vehicle of ``n_jets`` jets may have (products and all
    effect groups), in order."""
    return run_columns(EFFECT_GROUPS, True, n_jets=n_jets, modes=_SCHEMA_MODES)


def column_named(name: str) -> Column | None:
    """The schema's column ``name`` (a per-jet or per-mode column of any jet number or mode
    name included), or None."""
    suffix = mode_column_suffix(name)
    if suffix is not None:
        return Column(name, "float64", *MODE_SUFFIXES[suffix])
    schema_name = name
    if name.startswith("jet_"):
        number, _, kind = name[4:].partition("_")
        if number.isdigit() and int(number) >= 1 and name == f"{jet_name(int(number))}_{kind}":
            schema_name = f"jet_01_{kind}"  # every jet's column: the same dtype, unit, meaning
    for c in all_columns(1):
        if c.name == schema_name:
            return replace(c, name=name)
    return None


def run_columns(effects=(), products: bool = False, *, n_jets: int, modes=()) -> tuple[Column, ...]:
    """The columns of a campaign whose spec has the effect groups ``effects`` (names of
    :data:`EFFECT_COLUMNS`), with ``products`` records products of inertia
    (:func:`records_products`), whose vehicle has ``n_jets`` jets and disperses ``modes``
    (``(name, kind)`` pairs, :func:`mode_columns`), in order."""
    unknown = [g for g in effects if g not in EFFECT_COLUMNS]
    if unknown:
        raise KeyError(f"unknown effect group(s) {unknown}; known: {list(EFFECT_GROUPS)}")
    extra = tuple(c for g in EFFECT_GROUPS if g in effects for c in EFFECT_COLUMNS[g])
    inputs = input_columns(n_jets) + (PRODUCT_COLUMNS if products else ())
    return ID_COLUMNS + inputs + extra + mode_columns(modes) + outcome_columns(n_jets)


def markdown_table() -> str:
    """The schema as a Markdown table (every column, the optional effect inputs included),
    per-axis and per-jet columns folded into one row."""
    rows, seen = [], set()
    group_of = {c.name: g for g in EFFECT_GROUPS for c in EFFECT_COLUMNS[g]}
    for c in all_columns(1):  # per-jet columns are folded into one row: one jet shows them
        name, meaning = c.name, c.meaning
        if name in group_of:
            group = group_of[name]
            where = EFFECT_SOURCES.get(group, f"[dispersions.{group}]")
            meaning = f"{meaning} (only with {where})"
        if name in PRODUCT_NAMES:
            meaning = f"{meaning} (only when the vehicle has or the campaign disperses them)"
        suffix = mode_column_suffix(name)
        if suffix is not None:
            kinds = [k for k, s in MODE_KIND_SUFFIXES.items() if suffix in s]
            meaning = (
                f"{meaning} (only when the vehicle file disperses a mode, one per mode "
                f"<name>; {', '.join(kinds)} modes)"
            )
        for axis in AXES:
            if f"_{axis}_" in name or name.endswith(f"_{axis}"):
                name = name.replace(axis, "<axis>", 1)
                meaning = meaning.replace(f"{axis}'s", "the axis's").replace(axis, "the axis")
                break
        if name.startswith("jet_") and name[4:6].isdigit():
            name = "jet_NN" + name[6:]
        if name.startswith("delta_v_") and name[8:9] in ("x", "y", "z") and name[9] == "_":
            name = "delta_v_{x,y,z}" + name[9:]
            meaning = meaning.replace(" x ", " x, y, z ")
        if name.startswith("cg_") and name.endswith("_m"):
            name = "cg_{x,y,z}_m"
        if name in INERTIA_NAMES:
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
