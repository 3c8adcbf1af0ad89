"""Sensors, valve timing and jet faults of a campaign: the spec's ``[dispersions.sensor]``,
``[dispersions.timing]`` and ``[dispersions.fault]`` tables, and each chunk's draws of them.

The physics' SI specs and the per-run draws are :mod:`rcsim.spacecraft.effect_draws`'
(``SensorSpec``, ``TimingSpec``, ``FaultSpec``, ``draw_*``).  This module is their input edge: it
reads them from a campaign spec's TOML (keys with units in their names, degrees converted here,
ranges and one-line errors naming the file, table and key), records them in their resolved form
(what the manifest keeps, so that ``--resume`` and ``replay`` rebuild the same effects) and turns a
chunk's draws into ``fly_batch`` keywords and ``runs.parquet`` columns
(:data:`rcsim.analysis.engine.runs_table.EFFECT_COLUMNS`).

A table that is absent, or present with every value zero (``is_none``), is *not* recorded:
such a spec resolves exactly as one written before these tables existed (same digest), so
existing campaigns resume and replay as before.  Every draw comes from children of the run's
noise stream, never the Table 5 dispersion stream: adding an effect leaves every run's vehicle
bit for bit the same.

A vehicle file's own valve timing (``[timing] command_delay_s``, per-jet ``open_delay_s`` and
``close_delay_s``: :mod:`rcsim.spacecraft.vehicle.file_schema`) is the vehicle's *nominal*: every
run flies it.  ``[dispersions.timing]`` then disperses about it: its sigmas are applied to the
vehicle's nominal delays, jet by jet, clipped at 0.  A delay the vehicle file gives (even as 0)
cannot also get a mean in the spec -- whether the spec's value should replace the file's or
add to it is the analyst's to say, so both are refused naming the key; a delay the file does
not give takes the spec's mean as before.  Without a ``[dispersions.timing]`` table every run
flies the vehicle's delays exactly, and ``runs.parquet`` has no delay columns (the delays are a
property of the vehicle, recorded in the manifest's ``vehicle_timing``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from rcsim.analysis.engine.runs_table import effect_frame_of, mode_columns
from rcsim.models.errors import InputError
from rcsim.spacecraft.blowdown import Blowdown
from rcsim.spacecraft.effect_draws import (
    FAULT_MODES,
    FaultSpec,
    SensorSpec,
    TimingSpec,
    draw_faults,
    draw_sensors,
    draw_timing,
    effect_frame,
)
from rcsim.spacecraft.modes.draws import draw_modes, flown_values, mode_kind
from rcsim.spacecraft.modes.reader import Modes
from rcsim.spacecraft.pulse_draws import PulseSigmas, draw_pulses
from rcsim.spacecraft.pulse_shape import PulseShape
from rcsim.spacecraft.valves import ValveTiming

#: ``[dispersions.sensor]`` keys (one number for all axes or [roll, pitch, yaw], one-sigma, in
#: the unit of the name) -> (SensorSpec field, largest value accepted).  The largest values lie
#: well past any star tracker or gyro an RCS analyst would fly (arc-seconds and mdeg/s), short
#: of values that only break the navigation (a 10 deg attitude sigma is already a lost vehicle
#: next to the 0.6 deg maneuver limit; 1 deg/s of rate noise is 3x the 0.3 deg/s commands).
SENSOR_KEYS = {
    "att_noise_deg": ("att_noise_rad", 10.0),
    "rate_noise_deg_s": ("rate_noise_rad_s", 1.0),
    "att_bias_sigma_deg": ("att_bias_sigma_rad", 10.0),
    "rate_bias_sigma_deg_s": ("rate_bias_sigma_rad_s", 1.0),
    "rate_walk_deg_s_per_sqrt_s": ("rate_walk_rad_s_per_sqrt_s", 0.1),
}
#: ``[dispersions.timing]`` keys: the TimingSpec fields, in seconds.
TIMING_KEYS = (
    "command_delay_s",
    "command_delay_sigma_s",
    "open_delay_s",
    "open_delay_sigma_s",
    "close_delay_s",
    "close_delay_sigma_s",
)
#: ``[dispersions.fault]`` windows -> (the modes they belong to, default, lowest, highest or
#: None for the run's duration).
FAULT_WINDOWS = {
    "time_s": (("off", "stuck"), 0.0, 0.0, None),
    "stuck_for_s": (("stuck",), 0.0, 0.0, None),
    "thrust_factor": (("degraded",), 1.0, 0.0, 1.0),
}
FAULT_KEYS = ("mode", "jets", "probability", *FAULT_WINDOWS)
#: How many one-sigmas of the delay draws must stay inside the control cycle: beyond about
#: 5 sigma a normal draw is rarer than 3e-7 per run, so no campaign of practical size meets
#: one; a run that still did would be recorded failed with the simulator's refusal as reason.
DELAY_SIGMAS = 5.0


@dataclass(frozen=True)
class Effects:
    """A campaign's sensor, timing and fault specs (each ``is_none()`` when absent), and the
    vehicle file's nominal valve timing (``vehicle_timing``, one run; None when it has no
    non-zero delay), which the spec's timing disperses about (module docstring)."""

    sensor: SensorSpec = field(default_factory=SensorSpec)
    timing: TimingSpec = field(default_factory=TimingSpec)
    fault: FaultSpec = field(default_factory=FaultSpec)
    vehicle_timing: ValveTiming | None = None
    # The vehicle file's real pulses and blowdown (one run; None without them) and its
    # dispersions of them (rcsim.spacecraft.pulse_draws).
    vehicle_pulse: PulseShape | None = None
    vehicle_blowdown: Blowdown | None = None
    pulse_sigmas: PulseSigmas = field(default_factory=PulseSigmas)
    # The vehicle file's modes when some of them are dispersed (each block's *_3sigma keys,
    # rcsim.spacecraft.modes.draws); None otherwise: the modes fly as compiled.
    vehicle_modes: Modes | None = None

    @property
    def groups(self) -> tuple[str, ...]:
        """Names of the effects present, in :data:`TABLES` order (the runs.parquet groups),
        then ``pulse`` and ``blowdown`` when the vehicle file disperses them."""
        own = tuple(name for name in TABLES if not getattr(self, name).is_none())
        if self.vehicle_pulse is not None and self.pulse_sigmas.disperses_pulse():
            own += ("pulse",)
        if self.vehicle_blowdown is not None and self.pulse_sigmas.disperses_blowdown():
            own += ("blowdown",)
        return own

    def records(self) -> dict:
        """The optional per-cycle records the flights keep
        (:func:`rcsim.spacecraft.guards.history_bytes` keywords): the measured errors of
        imperfect sensors, the delivered on-times under valve timing or faults."""
        return {
            "measured": not self.sensor.is_none(),
            "delivered": not (
                self.timing.is_none()
                and self.fault.is_none()
                and self.vehicle_timing is None
                and self.vehicle_pulse is None
            ),
        }


def _unknown(table: dict, known, where: str) -> None:
    extra = sorted(set(table) - set(known))
    if extra:
        raise InputError(
            f"{where}: unknown key(s) {', '.join(map(str, extra))}; known: {', '.join(known)}"
        )


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _axes_deg(table: dict, key: str, where: str, maximum: float) -> np.ndarray:
    """A one-sigma per axis from ``table[key]`` (one number or three, in the key's unit, each
    in [0, maximum]), in radians."""
    raw = table.get(key, 0.0)
    values = raw if isinstance(raw, list) else [raw]
    if len(values) not in (1, 3) or not all(_is_number(v) for v in values):
        raise InputError(
            f"{where}: {key} must be a number or 3 numbers (roll, pitch, yaw), got {raw!r}"
        )
    v = np.broadcast_to(np.asarray(values, float), (3,)).copy()
    if (v < 0).any():
        raise InputError(f"{where}: {key} must be finite and >= 0, got {raw!r}")
    if (v > maximum).any():
        raise InputError(f"{where}: {key} must be at most {maximum:g}, got {raw!r}")
    return np.radians(v)


def sensor_spec(table: dict, where: str) -> SensorSpec:
    """``[dispersions.sensor]`` (:data:`SENSOR_KEYS`) as the physics' SI spec."""
    _unknown(table, tuple(SENSOR_KEYS), where)
    return SensorSpec(
        **{
            field_: _axes_deg(table, key, where, maximum)
            for key, (field_, maximum) in SENSOR_KEYS.items()
        }
    )


def timing_spec(table: dict, where: str) -> TimingSpec:
    """``[dispersions.timing]`` (:data:`TIMING_KEYS`, seconds, default 0) as the SI spec."""
    _unknown(table, TIMING_KEYS, where)
    out = {}
    for key in TIMING_KEYS:
        v = table.get(key, 0.0)
        if not _is_number(v) or v < 0:
            raise InputError(f"{where}: {key} must be a number >= 0 [s], got {v!r}")
        out[key] = float(v)
    return TimingSpec(**out)


def fault_spec(
    table: dict, where: str, longest_s: float, n_jets: int, vehicle: str = "the vehicle"
) -> FaultSpec:
    """``[dispersions.fault]`` as the SI spec: ``mode``, ``jets`` (numbers 1..``n_jets``, the
    jets of the campaign's vehicle, named ``vehicle`` in messages; default all of them),
    ``probability`` and the windows ``[lo, hi]`` of :data:`FAULT_WINDOWS` (a number means
    [x, x]); times within the longest run, ``longest_s`` [s] (a fault after the end never
    happens)."""
    _unknown(table, FAULT_KEYS, where)
    mode = table.get("mode", "none")
    if not isinstance(mode, str) or mode not in FAULT_MODES:
        raise InputError(f"{where}: mode must be one of {', '.join(FAULT_MODES)}, got {mode!r}")
    jets = table.get("jets", list(range(1, n_jets + 1)))
    if (
        not isinstance(jets, list)
        or not jets
        or not all(isinstance(j, int) and not isinstance(j, bool) for j in jets)
        or len(set(jets)) != len(jets)
    ):
        raise InputError(
            f"{where}: jets must be a list of distinct jet numbers 1..{n_jets}, got {jets!r}"
        )
    outside = [j for j in jets if not 1 <= j <= n_jets]
    if outside:
        raise InputError(
            f"{where}: jets: no jet {outside[0]}: {vehicle} has {n_jets} jets, numbered "
            f"1..{n_jets} (got {jets!r})"
        )
    p = table.get("probability", 1.0)
    if not _is_number(p) or not 0 <= p <= 1:
        raise InputError(f"{where}: probability must be in [0, 1], got {p!r}")
    windows = {}
    for key, (owner, default, lo_ok, hi_ok) in FAULT_WINDOWS.items():
        # Each window belongs to its modes: a key the mode ignores is a mistake, not a default.
        if key in table and mode not in owner:
            why = " (a degraded jet is degraded for the whole flight)" if key == "time_s" else ""
            raise InputError(
                f"{where}: {key} applies to mode {' or '.join(owner)}, not {mode!r}{why}"
            )
        hi = longest_s if hi_ok is None else hi_ok
        raw = table.get(key, default)
        values = raw if isinstance(raw, list) else [raw]
        if (
            len(values) not in (1, 2)
            or not all(_is_number(v) for v in values)
            or not lo_ok <= values[0] <= values[-1] <= hi
        ):
            unit = " s, the longest run" if hi_ok is None else ""
            raise InputError(
                f"{where}: {key} must be [lo, hi] with {lo_ok:g} <= lo <= hi "
                f"<= {hi:g}{unit}, got {raw!r}"
            )
        windows[key] = (float(values[0]), float(values[-1]))
    return FaultSpec(mode=mode, jets=tuple(jets), probability=float(p), **windows)


#: Spec table name -> its reader.
TABLES: dict[str, Callable[..., Any]] = {
    "sensor": sensor_spec,
    "timing": timing_spec,
    "fault": fault_spec,
}


def parse_effects(
    dispersions: dict,
    *,
    source: str,
    cycle_s: float,
    longest_s: float,
    n_jets: int,
    vehicle: str = "the vehicle",
    definition=None,
) -> tuple[Effects, dict]:
    """Read the ``sensor``, ``timing`` and ``fault`` sub-tables (popped from ``dispersions``).

    ``cycle_s``: the campaign's control cycle [s] (delays must act within it); ``longest_s``:
    its longest run [s] (fault windows must start within it); ``n_jets``: the jets of the
    campaign's vehicle (a fault's jets are among them), ``vehicle`` its name in messages;
    ``definition``: its :class:`~rcsim.spacecraft.vehicle.VehicleDef` (None: the packaged
    vehicle), whose valve timing is the nominal the spec's timing disperses about.

    Returns
    -------
    effects : Effects
    resolved : dict
        The tables to record in the resolved spec's ``dispersions`` (only those not
        ``is_none``), as the user gave them: re-reading them gives the same specs bit for bit.

    Raises
    ------
    InputError
        Naming the file, table and key: a bad value, a table that is not a
        table, delays that do not fit in the control cycle, the mean of a delay the vehicle
        file gives.
    """
    specs, resolved = {}, {}
    for name, read in TABLES.items():
        raw = dispersions.pop(name, {})
        where = f"{source}: [dispersions.{name}]"
        if not isinstance(raw, dict):
            raise InputError(f"{where}: expected a table, got {raw!r}")
        spec = read(raw, where, longest_s, n_jets, vehicle) if name == "fault" else read(raw, where)
        specs[name] = spec
        if not spec.is_none():
            # TOML values of these keys (numbers, lists, strings) are JSON as they are.
            resolved[name] = dict(sorted(raw.items()))
        if name == "timing" and definition is not None:
            _check_vehicle_timing(raw, where, definition)
    nominal = None
    if definition is not None and definition.has_delays:
        nominal = definition.valve_timing(1)
    pulse = blowdown = None
    sigmas = PulseSigmas()
    if definition is not None:
        if definition.pulse is not None:
            pulse = definition.pulse.shape(1, definition.isp_s)
        if definition.blowdown is not None:
            blowdown = definition.blowdown.blowdown(1)
        sigmas = PulseSigmas.from_three_sigma(definition.pulse_three_sigma)
    modes = None
    if definition is not None and definition.modes is not None and definition.modes.dispersed:
        modes = definition.modes
    effects = Effects(
        **specs,
        vehicle_timing=nominal,
        vehicle_pulse=pulse,
        vehicle_blowdown=blowdown,
        pulse_sigmas=sigmas,
        vehicle_modes=modes,
    )
    _check_timing(effects.timing, f"{source}: [dispersions.timing]", cycle_s, nominal)
    return effects, resolved


def _check_vehicle_timing(table: dict, where: str, definition) -> None:
    """Refuse a spec mean of a delay the vehicle file gives (module docstring): replace or
    add would both be a guess."""
    for key in definition.delay_keys:
        if key in table:
            per_jet = "" if key == "command_delay_s" else " (per jet)"
            sigma = key.replace("_delay_s", "_delay_sigma_s")
            raise InputError(
                f"{where}: {key}: the vehicle file {definition.source} gives its nominal "
                f"{key}{per_jet}; the spec may disperse it ({sigma}, about the vehicle's) but "
                f"not set it again: remove {key} from the spec, or from the vehicle file to "
                f"fly the spec's (got {table[key]!r})"
            )


def _check_timing(
    t: TimingSpec, where: str, cycle: float, nominal: ValveTiming | None = None
) -> None:
    """Refuse delays whose draws would leave the control cycle ``cycle`` [s] (the simulator
    requires ``command + open < cycle`` and ``command + close < cycle``), about the vehicle's
    ``nominal`` delays (one run; its slowest jet) when it has them."""
    for valve in ("open", "close"):
        mean = t.command_delay_s + getattr(t, f"{valve}_delay_s")
        what = f"command_delay_s + {valve}_delay_s"
        if nominal is not None:
            own = float(nominal.command_delay_s[0] + getattr(nominal, f"{valve}_delay_s").max())
            mean = own + mean
            what += f" (with the vehicle's nominal, {own:.4g} s at its slowest jet)"
        sigma = t.command_delay_sigma_s + getattr(t, f"{valve}_delay_sigma_s")
        if mean + DELAY_SIGMAS * sigma >= cycle:
            raise InputError(
                f"{where}: {what} + {DELAY_SIGMAS:g} x their sigmas "
                f"is {mean + DELAY_SIGMAS * sigma:.4g} s; it must stay under the "
                f"{cycle:g} s control cycle (a valve command must act within its cycle)"
            )


def adapt_options(effects: Effects) -> dict:
    """``make_controller(..., adapt_options=...)`` for the adaptive controller: the rate
    sensor's white noise (the largest axis's one-sigma), which its confidence rule needs."""
    return {"rate_noise_rad_s": float(np.max(effects.sensor.rate_noise_rad_s))}


def draw_effects(effects: Effects, seed: int, run_ids, n_jets: int) -> tuple[dict, pd.DataFrame]:
    """The ``fly_batch`` keywords and the runs.parquet effect columns of runs ``run_ids`` of a
    vehicle of ``n_jets`` jets.

    Returns
    -------
    kwargs : dict
        ``sensors`` and ``sensor_streams``, ``timing``, ``faults`` (only the effects present).
    columns : DataFrame
        One row per run, the columns of the groups present
        (:data:`rcsim.analysis.engine.runs_table.EFFECT_COLUMNS`); no columns when none is.
    """
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    kwargs: dict = {}
    values: dict = {}
    sensors = timing = None
    if not effects.sensor.is_none():
        sensors, streams = draw_sensors(effects.sensor, seed, run_ids)
        kwargs.update(sensors=sensors, sensor_streams=streams)
    if not effects.timing.is_none():
        timing = draw_timing(effects.timing, seed, run_ids, n_jets, effects.vehicle_timing)
        kwargs["timing"] = timing
    elif effects.vehicle_timing is not None:  # the vehicle's own delays, the same every run
        kwargs["timing"] = effects.vehicle_timing.for_jets(n_jets).take(np.zeros(run_ids.size))
    values.update({k: v.to_numpy() for k, v in effect_frame(sensors, timing).items()})
    if not effects.fault.is_none():
        faults, drawn = draw_faults(effects.fault, seed, run_ids, n_jets)
        kwargs["faults"] = faults
        values.update({k: v.to_numpy() for k, v in drawn.items()})
        # Thrust factor 1 (not NaN) where the thrust is whole: a number the driver analysis
        # can take as an input, and physically what the jet delivers.
        values["fault_thrust_factor"] = np.where(
            np.isnan(values["fault_thrust_factor"]), 1.0, values["fault_thrust_factor"]
        )
    if "pulse" in effects.groups or "blowdown" in effects.groups:
        shape, blowdown, drawn = draw_pulses(
            effects.vehicle_pulse,
            effects.vehicle_blowdown,
            effects.pulse_sigmas,
            seed,
            run_ids,
            n_jets,
        )
        if "pulse" in effects.groups:
            kwargs["pulse"] = shape
        if "blowdown" in effects.groups:
            kwargs["blowdown"] = blowdown
        values.update(drawn)
    if effects.vehicle_modes is not None:
        kwargs["modes"] = draw_modes(effects.vehicle_modes, seed, run_ids)
    frame = effect_frame_of(values, effects.groups)
    frame.index = pd.RangeIndex(run_ids.size)
    return kwargs, frame


def mode_pairs(effects: Effects) -> tuple[tuple[str, str], ...]:
    """``(name, kind)`` of each mode whose runs.parquet columns a campaign of ``effects``
    records (:func:`rcsim.analysis.engine.runs_table.mode_columns`): every mode of a vehicle
    that disperses some; none otherwise."""
    modes = effects.vehicle_modes
    return () if modes is None else tuple((m.name, mode_kind(m)) for m in modes.all)


def mode_frame(effects: Effects, flight, hub, seed: int, run_ids) -> pd.DataFrame:
    """The per-mode runs.parquet inputs of runs ``run_ids`` (their draws, a function of
    ``(seed, run id)``: the ones :func:`draw_effects` gave the flight) flown on hubs ``hub``
    (:class:`~rcsim.spacecraft.vehicle.RunParameters` as flown) with the vehicle's flight
    model ``flight`` (:func:`rcsim.spacecraft.modes.draws.flown_values`); no columns when the
    vehicle disperses no mode."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    pairs = mode_pairs(effects)
    if effects.vehicle_modes is None:
        return pd.DataFrame(index=pd.RangeIndex(run_ids.size))
    runs = draw_modes(effects.vehicle_modes, seed, run_ids)
    values = flown_values(flight, hub, runs)
    return pd.DataFrame({c.name: values[c.name] for c in mode_columns(pairs)})


def describe(effects: Effects) -> str:
    """One line for the campaign's console summary ("" when no effect is present)."""
    parts = []
    s = effects.sensor
    if not s.is_none():
        parts.append(
            f"sensor noise (rate {math.degrees(float(np.max(s.rate_noise_rad_s))):g} "
            f"deg/s, attitude {math.degrees(float(np.max(s.att_noise_rad))):g} deg 1-sigma)"
        )
    t, own = effects.timing, effects.vehicle_timing
    if own is not None:
        text = (
            f"the vehicle's delays (command {own.command_delay_s[0] * 1e3:g} ms, valve open "
            f"up to {own.open_delay_s.max() * 1e3:g} / close up to "
            f"{own.close_delay_s.max() * 1e3:g} ms)"
        )
        if not t.is_none():
            ms = lambda *v: " / ".join(f"{x * 1e3:g}" for x in v)  # noqa: E731
            text += (
                " + [dispersions.timing] (command / open / close: means "
                f"{ms(t.command_delay_s, t.open_delay_s, t.close_delay_s)} ms, 1-sigma "
                f"{ms(t.command_delay_sigma_s, t.open_delay_sigma_s, t.close_delay_sigma_s)} ms)"
            )
        parts.append(text)
    elif not t.is_none():
        parts.append(
            f"delays (command {t.command_delay_s * 1e3:g} ms, valve open "
            f"{t.open_delay_s * 1e3:g} / close {t.close_delay_s * 1e3:g} ms)"
        )
    f = effects.fault
    if not f.is_none():
        jets = ",".join(str(j) for j in f.jets) if f.jets else "all"
        parts.append(f"jet fault {f.mode} (p = {f.probability:g}, jets {jets})")
    return "; ".join(parts)
