"""Campaign dispersions of sensors, valve timing and jet faults: specs and per-run draws.

The vehicle dispersions of Table 5 live in :mod:`spacecraft.dispersions`; this module adds what
Gambone's Monte Carlo left out (sensor noise, the sensor-to-actuator and firing delays) and jet
faults, as campaign-level specs (:class:`SensorSpec`, :class:`TimingSpec`, :class:`FaultSpec`,
SI inside) and functions drawing each run's values.

Seeding
-------
Run ``i`` of a campaign with root ``seed`` has the ``(dispersion, noise)`` streams of
:func:`spacecraft.dispersions.run_streams`.  Everything here draws from *children* of the noise
stream ``N``, made explicitly as ``SeedSequence(N.entropy, spawn_key=N.spawn_key + (c,))``
(what ``N.spawn`` would give, without its counter):

====  ====================================================
c     purpose
====  ====================================================
0     sensor noise in flight (:class:`spacecraft.sensors.SensorNoise`)
1     sensor biases (6 normals)
2     valve timing (1 + 16 + 16 normals)
3     faults (4 uniforms)
====  ====================================================

Each child draws a fixed count of standard variates whatever the spec, so no spec change shifts
another draw, and none of them touches the dispersion stream or the noise stream's own draws:
adding these effects to a campaign leaves every existing run's vehicle bit for bit the same.

Spec keys (TOML, units in the names, degrees at this boundary only): see
:meth:`SensorSpec.from_mapping`, :meth:`TimingSpec.from_mapping`, :meth:`FaultSpec.from_mapping`
and ``docs/faults.md``.

Imports ``models`` and ``spacecraft`` only.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import ClassVar, Mapping

import numpy as np
import pandas as pd

from models.errors import InputError
from spacecraft.dispersions import run_streams
from spacecraft.sensors import SensorParams
from spacecraft.valves import JetFaults, ValveTiming
from spacecraft.vehicle import N_JETS

SENSOR_NOISE, SENSOR_BIAS, TIMING, FAULT = 0, 1, 2, 3
FAULT_MODES = ("none", "off", "stuck", "degraded")


def effect_stream(seed: int, run_id: int, purpose: int) -> np.random.SeedSequence:
    """Child ``purpose`` (module table) of run ``run_id``'s noise stream."""
    noise = run_streams(seed, run_id)[1]
    return np.random.SeedSequence(noise.entropy, spawn_key=tuple(noise.spawn_key) + (purpose,))


def _axes(table: Mapping, key: str, where: str, *, deg: bool, sigma: bool = True,
          maximum: float = np.inf) -> np.ndarray:
    """A 3-vector (or a scalar for all axes) from ``table[key]``, each at most ``maximum`` (in
    the key's own unit); radians if ``deg``."""
    raw = table.get(key, 0.0)
    if isinstance(raw, bool) or (isinstance(raw, (list, tuple))
                                 and any(isinstance(x, bool) for x in raw)):
        raise InputError(f"{where}: {key} must be a number or 3 numbers, got {raw!r}")
    try:
        v = np.broadcast_to(np.asarray(raw, float), (3,)).copy()
    except (ValueError, TypeError):
        raise InputError(f"{where}: {key} must be a number or 3 numbers (roll, pitch, yaw), "
                         f"got {raw!r}") from None
    if not np.isfinite(v).all() or (sigma and (v < 0).any()):
        raise InputError(f"{where}: {key} must be finite{' and >= 0' if sigma else ''}, "
                         f"got {raw!r}")
    if (np.abs(v) > maximum).any():
        raise InputError(f"{where}: {key} must be at most {maximum:g}, got {raw!r}")
    return np.radians(v) if deg else v


def _unknown(table: Mapping, known: tuple, where: str) -> None:
    extra = sorted(set(table) - set(known))
    if extra:
        raise InputError(f"{where}: unknown key(s) {', '.join(extra)}; known: "
                         f"{', '.join(known)}")


@dataclass(frozen=True)
class SensorSpec:
    """Sensor errors of a campaign (SI; each a 3-vector roll, pitch, yaw).

    White noise sigmas and the rate random walk are the same for every run; the biases are
    drawn per run, normal with the given sigmas.
    """

    att_noise_rad: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rate_noise_rad_s: np.ndarray = field(default_factory=lambda: np.zeros(3))
    att_bias_sigma_rad: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rate_bias_sigma_rad_s: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rate_walk_rad_s_per_sqrt_s: np.ndarray = field(default_factory=lambda: np.zeros(3))

    KEYS: ClassVar[tuple] = ("att_noise_deg", "rate_noise_deg_s", "att_bias_sigma_deg",
            "rate_bias_sigma_deg_s", "rate_walk_deg_s_per_sqrt_s")
    #: Largest one-sigma accepted per key (its unit): well past any star tracker or gyro an RCS
    #: analyst would fly (arc-seconds and mdeg/s), short of values that only break the
    #: navigation (a 10 deg attitude sigma is already a lost vehicle next to the 0.6 deg
    #: maneuver limit; 1 deg/s of rate noise is 3x the 0.3 deg/s commands).
    MAXIMA: ClassVar[tuple] = (10.0, 1.0, 10.0, 1.0, 0.1)

    @classmethod
    def from_mapping(cls, table: Mapping, where: str = "[dispersions.sensor]") -> "SensorSpec":
        """From spec keys ``att_noise_deg``, ``rate_noise_deg_s``, ``att_bias_sigma_deg``,
        ``rate_bias_sigma_deg_s``, ``rate_walk_deg_s_per_sqrt_s`` (one number or three; all
        one-sigma, default 0).  ``where`` names the file and table in errors."""
        _unknown(table, cls.KEYS, where)
        return cls(*(_axes(table, k, where, deg=True, maximum=m)
                     for k, m in zip(cls.KEYS, cls.MAXIMA)))

    def is_none(self) -> bool:
        return not any(np.any(getattr(self, f.name)) for f in fields(self))


@dataclass(frozen=True)
class TimingSpec:
    """Command and valve delays of a campaign [s]: a mean and a one-sigma each, normal per run
    (valve delays per jet), clipped at 0."""

    command_delay_s: float = 0.0
    command_delay_sigma_s: float = 0.0
    open_delay_s: float = 0.0
    open_delay_sigma_s: float = 0.0
    close_delay_s: float = 0.0
    close_delay_sigma_s: float = 0.0

    @classmethod
    def from_mapping(cls, table: Mapping, where: str = "[dispersions.timing]") -> "TimingSpec":
        """From the spec keys named as the fields (seconds, default 0)."""
        keys = tuple(f.name for f in fields(cls))
        _unknown(table, keys, where)
        out = {}
        for k in keys:
            v = table.get(k, 0.0)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) \
                    or v < 0:
                raise InputError(f"{where}: {k} must be a number >= 0 [s], got {v!r}")
            out[k] = float(v)
        return cls(**out)

    def is_none(self) -> bool:
        return not any(getattr(self, f.name) for f in fields(self))


@dataclass(frozen=True)
class FaultSpec:
    """One jet fault per run (with a probability): which jet, when, how.

    Attributes
    ----------
    mode : {"none", "off", "stuck", "degraded"}
    jets : tuple of int
        Candidate jets, numbered 1..16; one is chosen uniformly per faulty run.
    probability : float
        Chance that a run has the fault, in [0, 1].
    time_s : (float, float)
        Uniform window of the fault's start [s] ("off": failure time; "stuck": start of the
        stuck window; "degraded": ignored, the whole flight).
    stuck_for_s : (float, float)
        Uniform range of the stuck window's length [s].
    thrust_factor : (float, float)
        Uniform range of the degraded jet's thrust fraction, within [0, 1].
    """

    mode: str = "none"
    jets: tuple = tuple(range(1, N_JETS + 1))
    probability: float = 1.0
    time_s: tuple = (0.0, 0.0)
    stuck_for_s: tuple = (0.0, 0.0)
    thrust_factor: tuple = (1.0, 1.0)

    @classmethod
    def from_mapping(cls, table: Mapping, where: str = "[dispersions.fault]") -> "FaultSpec":
        """From spec keys ``mode``, ``jets``, ``probability``, ``time_s = [lo, hi]``,
        ``stuck_for_s = [lo, hi]``, ``thrust_factor = [lo, hi]`` (a number means [x, x])."""
        keys = tuple(f.name for f in fields(cls))
        _unknown(table, keys, where)
        mode = table.get("mode", "none")
        if mode not in FAULT_MODES:
            raise InputError(f"{where}: mode must be one of {', '.join(FAULT_MODES)}, "
                             f"got {mode!r}")
        jets = table.get("jets", list(range(1, N_JETS + 1)))
        if (not isinstance(jets, (list, tuple)) or not jets or len(set(jets)) != len(jets)
                or not all(isinstance(j, int) and not isinstance(j, bool) and 1 <= j <= N_JETS
                           for j in jets)):
            raise InputError(f"{where}: jets must be a list of distinct jet numbers "
                             f"1..{N_JETS}, got {jets!r}")
        # Each window belongs to one mode: a key the mode ignores is a mistake, not a default.
        for key, owner in (("time_s", ("off", "stuck")), ("stuck_for_s", ("stuck",)),
                           ("thrust_factor", ("degraded",))):
            if key in table and mode not in owner:
                raise InputError(f"{where}: {key} applies to mode {' or '.join(owner)}, not "
                                 f"{mode!r} (a degraded jet is degraded for the whole flight)"
                                 if key == "time_s" else
                                 f"{where}: {key} applies to mode {' or '.join(owner)}, "
                                 f"not {mode!r}")
        p = table.get("probability", 1.0)
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0 <= p <= 1:
            raise InputError(f"{where}: probability must be in [0, 1], got {p!r}")

        def window(key, default, lo_ok, hi_ok):
            raw = table.get(key, default)
            v = np.broadcast_to(np.asarray(raw, float), (2,)) if np.size(raw) in (1, 2) \
                else None
            if v is None or not np.isfinite(v).all() or v[0] > v[1] or v[0] < lo_ok \
                    or v[1] > hi_ok:
                raise InputError(f"{where}: {key} must be [lo, hi] with {lo_ok:g} <= lo <= hi"
                                 f"{f' <= {hi_ok:g}' if np.isfinite(hi_ok) else ''}, "
                                 f"got {raw!r}")
            return (float(v[0]), float(v[1]))

        return cls(mode=mode, jets=tuple(jets), probability=float(p),
                   time_s=window("time_s", 0.0, 0.0, np.inf),
                   stuck_for_s=window("stuck_for_s", 0.0, 0.0, np.inf),
                   thrust_factor=window("thrust_factor", 1.0, 0.0, 1.0))

    def is_none(self) -> bool:
        return self.mode == "none" or self.probability == 0


def draw_sensors(spec: SensorSpec, seed: int, run_ids) -> tuple[SensorParams, list]:
    """Per-run sensor parameters and sensor-noise streams of campaign runs ``run_ids``."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    z = np.array([np.random.default_rng(effect_stream(seed, i, SENSOR_BIAS)).standard_normal(6)
                  for i in run_ids]).reshape(-1, 6)
    params = SensorParams.of(
        run_ids.size, att_noise_rad=spec.att_noise_rad, rate_noise_rad_s=spec.rate_noise_rad_s,
        att_bias_rad=spec.att_bias_sigma_rad * z[:, :3],
        rate_bias_rad_s=spec.rate_bias_sigma_rad_s * z[:, 3:],
        rate_walk_rad_s_per_sqrt_s=spec.rate_walk_rad_s_per_sqrt_s)
    return params, [effect_stream(seed, i, SENSOR_NOISE) for i in run_ids]


def draw_timing(spec: TimingSpec, seed: int, run_ids) -> ValveTiming:
    """Per-run delays of campaign runs ``run_ids`` (normal about the means, clipped at 0)."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    z = np.array([np.random.default_rng(effect_stream(seed, i, TIMING)).standard_normal(33)
                  for i in run_ids]).reshape(-1, 33)
    pos = lambda v: np.maximum(v, 0.0)  # noqa: E731
    return ValveTiming(
        command_delay_s=pos(spec.command_delay_s + spec.command_delay_sigma_s * z[:, 0]),
        open_delay_s=pos(spec.open_delay_s + spec.open_delay_sigma_s * z[:, 1:17]),
        close_delay_s=pos(spec.close_delay_s + spec.close_delay_sigma_s * z[:, 17:33]))


def draw_faults(spec: FaultSpec, seed: int, run_ids) -> tuple[JetFaults, pd.DataFrame]:
    """Per-run jet faults of campaign runs ``run_ids`` and a frame of what was drawn.

    Returns
    -------
    faults : JetFaults
    drawn : DataFrame
        ``fault_jet`` (0: no fault), ``fault_time_s``, ``fault_stuck_for_s``,
        ``fault_thrust_factor`` per run (NaN where not applicable).
    """
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    n = run_ids.size
    u = np.array([np.random.default_rng(effect_stream(seed, i, FAULT)).random(4)
                  for i in run_ids]).reshape(-1, 4)
    faulty = (u[:, 0] < spec.probability) & (spec.mode != "none")
    jets = np.asarray(spec.jets)[np.minimum((u[:, 1] * len(spec.jets)).astype(int),
                                            len(spec.jets) - 1)]
    lerp = lambda lo_hi, x: lo_hi[0] + (lo_hi[1] - lo_hi[0]) * x  # noqa: E731
    when = lerp(spec.time_s, u[:, 2])
    faults = JetFaults.of(n)
    rows, cols = np.flatnonzero(faulty), jets[faulty] - 1
    nan = np.full(n, np.nan)
    stuck_for, factor = nan.copy(), nan.copy()
    if spec.mode == "off":
        faults.off_from_s[rows, cols] = when[rows]
    elif spec.mode == "stuck":
        stuck_for[rows] = lerp(spec.stuck_for_s, u[rows, 3])
        faults.stuck_from_s[rows, cols] = when[rows]
        faults.stuck_for_s[rows, cols] = stuck_for[rows]
    elif spec.mode == "degraded":
        factor[rows] = lerp(spec.thrust_factor, u[rows, 3])
        faults.thrust_factor[rows, cols] = factor[rows]
    drawn = pd.DataFrame({
        "fault_jet": np.where(faulty, jets, 0),
        "fault_time_s": np.where(faulty & (spec.mode != "degraded"), when, np.nan),
        "fault_stuck_for_s": stuck_for,
        "fault_thrust_factor": factor,
    })
    return faults, drawn


def effect_frame(sensors: SensorParams | None, timing: ValveTiming | None) -> pd.DataFrame:
    """Drawn sensor biases [deg, deg/s] and delays [s] per run, for a campaign's run table."""
    cols: dict[str, np.ndarray] = {}
    if sensors is not None:
        for a, axis in enumerate(("roll", "pitch", "yaw")):
            cols[f"att_bias_{axis}_deg"] = np.degrees(sensors.att_bias_rad[:, a])
            cols[f"rate_bias_{axis}_deg_s"] = np.degrees(sensors.rate_bias_rad_s[:, a])
    if timing is not None:
        cols["command_delay_s"] = timing.command_delay_s
        cols["open_delay_max_s"] = timing.open_delay_s.max(axis=1)
        cols["close_delay_max_s"] = timing.close_delay_s.max(axis=1)
    return pd.DataFrame(cols)
