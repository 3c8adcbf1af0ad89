"""Sensors, valve timing and jet faults of a campaign: the spec's ``[dispersions.sensor]``,
``[dispersions.timing]`` and ``[dispersions.fault]`` tables, and each chunk's draws of them.

The specs and the per-run draws are :mod:`spacecraft.effect_draws`' (``SensorSpec``,
``TimingSpec``, ``FaultSpec``, ``draw_*``); this module reads them from a campaign spec, records
them in its resolved form (what the manifest keeps, so that ``--resume`` and ``replay`` rebuild
the same effects) and turns a chunk's draws into ``fly_batch`` keywords and ``runs.parquet``
columns (:data:`analysis.engine.runs_table.EFFECT_COLUMNS`).

A table that is absent, or present with every value zero (``is_none``), is *not* recorded:
such a spec resolves exactly as one written before these tables existed (same digest), so
existing campaigns resume and replay as before.  Every draw comes from children of the run's
noise stream, never the Table 5 dispersion stream: adding an effect leaves every run's vehicle
bit for bit the same.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from analysis.engine.runs_table import effect_frame_of
from models.errors import InputError
from spacecraft.effect_draws import (
    FaultSpec, SensorSpec, TimingSpec, draw_faults, draw_sensors, draw_timing, effect_frame,
)
from spacecraft.propulsion import PropulsionParams

#: Spec table name -> spec class.
TABLES = {"sensor": SensorSpec, "timing": TimingSpec, "fault": FaultSpec}
#: How many one-sigmas of the delay draws must stay inside the control cycle: beyond about
#: 5 sigma a normal draw is rarer than 3e-7 per run, so no campaign of practical size meets
#: one; a run that still did would be recorded failed with the simulator's refusal as reason.
DELAY_SIGMAS = 5.0


@dataclass(frozen=True)
class Effects:
    """A campaign's sensor, timing and fault specs (each ``is_none()`` when absent)."""

    sensor: SensorSpec = field(default_factory=SensorSpec)
    timing: TimingSpec = field(default_factory=TimingSpec)
    fault: FaultSpec = field(default_factory=FaultSpec)

    @property
    def groups(self) -> tuple[str, ...]:
        """Names of the effects present, in :data:`TABLES` order (the runs.parquet groups)."""
        return tuple(name for name in TABLES if not getattr(self, name).is_none())

    def records(self) -> dict:
        """The optional per-cycle records the flights keep
        (:func:`spacecraft.guards.history_bytes` keywords): the measured errors of
        imperfect sensors, the delivered on-times under valve timing or faults."""
        return {"measured": not self.sensor.is_none(),
                "delivered": not (self.timing.is_none() and self.fault.is_none())}


def parse_effects(dispersions: dict, *, source: str) -> tuple[Effects, dict]:
    """Read the ``sensor``, ``timing`` and ``fault`` sub-tables (popped from ``dispersions``).

    Returns
    -------
    effects : Effects
    resolved : dict
        The tables to record in the resolved spec's ``dispersions`` (only those not
        ``is_none``), as the user gave them: re-reading them gives the same specs bit for bit.

    Raises
    ------
    InputError
        Naming the file, table and key: what ``from_mapping`` refuses, a table that is not a
        table, delays that do not fit in the control cycle.
    """
    specs, resolved = {}, {}
    for name, cls in TABLES.items():
        raw = dispersions.pop(name, {})
        where = f"{source}: [dispersions.{name}]"
        if not isinstance(raw, dict):
            raise InputError(f"{where}: expected a table, got {raw!r}")
        spec = cls.from_mapping(raw, where=where)
        specs[name] = spec
        if not spec.is_none():
            # TOML values of these keys (numbers, lists, strings) are JSON as they are.
            resolved[name] = dict(sorted(raw.items()))
    effects = Effects(**specs)
    _check_timing(effects.timing, f"{source}: [dispersions.timing]")
    return effects, resolved


def _check_timing(t: TimingSpec, where: str) -> None:
    """Refuse delays whose draws would leave the control cycle (the simulator requires
    ``command + open < cycle`` and ``command + close < cycle``)."""
    cycle = PropulsionParams().cycle_s
    for valve in ("open", "close"):
        mean = t.command_delay_s + getattr(t, f"{valve}_delay_s")
        sigma = t.command_delay_sigma_s + getattr(t, f"{valve}_delay_sigma_s")
        if mean + DELAY_SIGMAS * sigma >= cycle:
            raise InputError(
                f"{where}: command_delay_s + {valve}_delay_s + {DELAY_SIGMAS:g} x their sigmas "
                f"is {mean + DELAY_SIGMAS * sigma:.4g} s; it must stay under the "
                f"{cycle:g} s control cycle (a valve command must act within its cycle)")


def adapt_options(effects: Effects) -> dict:
    """``make_controller(..., adapt_options=...)`` for the adaptive controller: the rate
    sensor's white noise (the largest axis's one-sigma), which its confidence rule needs."""
    return {"rate_noise_rad_s": float(np.max(effects.sensor.rate_noise_rad_s))}


def draw_effects(effects: Effects, seed: int, run_ids) -> tuple[dict, pd.DataFrame]:
    """The ``fly_batch`` keywords and the runs.parquet effect columns of runs ``run_ids``.

    Returns
    -------
    kwargs : dict
        ``sensors`` and ``sensor_streams``, ``timing``, ``faults`` (only the effects present).
    columns : DataFrame
        One row per run, the columns of the groups present
        (:data:`analysis.engine.runs_table.EFFECT_COLUMNS`); no columns when none is.
    """
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    kwargs: dict = {}
    values: dict = {}
    sensors = timing = None
    if not effects.sensor.is_none():
        sensors, streams = draw_sensors(effects.sensor, seed, run_ids)
        kwargs.update(sensors=sensors, sensor_streams=streams)
    if not effects.timing.is_none():
        timing = draw_timing(effects.timing, seed, run_ids)
        kwargs["timing"] = timing
    values.update({k: v.to_numpy() for k, v in effect_frame(sensors, timing).items()})
    if not effects.fault.is_none():
        faults, drawn = draw_faults(effects.fault, seed, run_ids)
        kwargs["faults"] = faults
        values.update({k: v.to_numpy() for k, v in drawn.items()})
        # Thrust factor 1 (not NaN) where the thrust is whole: a number the driver analysis
        # can take as an input, and physically what the jet delivers.
        values["fault_thrust_factor"] = np.where(
            np.isnan(values["fault_thrust_factor"]), 1.0, values["fault_thrust_factor"])
    frame = effect_frame_of(values, effects.groups)
    frame.index = pd.RangeIndex(run_ids.size)
    return kwargs, frame


def describe(effects: Effects) -> str:
    """One line for the campaign's console summary ("" when no effect is present)."""
    parts = []
    s = effects.sensor
    if not s.is_none():
        parts.append(f"sensor noise (rate {math.degrees(float(np.max(s.rate_noise_rad_s))):g} "
                     f"deg/s, attitude {math.degrees(float(np.max(s.att_noise_rad))):g} deg 1-sigma)")
    t = effects.timing
    if not t.is_none():
        parts.append(f"delays (command {t.command_delay_s * 1e3:g} ms, valve open "
                     f"{t.open_delay_s * 1e3:g} / close {t.close_delay_s * 1e3:g} ms)")
    f = effects.fault
    if not f.is_none():
        parts.append(f"jet fault {f.mode} (p = {f.probability:g}, jets "
                     f"{','.join(str(j) for j in f.jets)})")
    return "; ".join(parts)
