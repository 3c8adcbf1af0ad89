"""Campaign dispersions of sensors, valve timing and jet faults: specs and per-run draws.

The vehicle dispersions of Table 5 live in :mod:`rcsim.spacecraft.dispersions`; this module adds
what Gambone's Monte Carlo left out (sensor noise, the sensor-to-actuator and firing delays) and jet
faults, as campaign-level specs (:class:`SensorSpec`, :class:`TimingSpec`, :class:`FaultSpec`,
SI inside) and functions drawing each run's values.

Seeding
-------
Run ``i`` of a campaign with root ``seed`` has the ``(dispersion, noise)`` streams of
:func:`rcsim.spacecraft.dispersions.run_streams`.  Everything here draws from *children* of the
noise stream ``N``, made explicitly as ``SeedSequence(N.entropy, spawn_key=N.spawn_key + (c,))``
(what ``N.spawn`` would give, without its counter):

====  ====================================================
c     purpose
====  ====================================================
0     sensor noise in flight (:class:`rcsim.spacecraft.sensors.SensorNoise`)
1     sensor biases (6 normals)
2     valve timing (1 + n_jets + n_jets normals)
3     faults (4 uniforms)
4     real pulses and blowdown (:mod:`rcsim.spacecraft.pulse_draws`)
5     the modes' masses, frequencies and damping (:mod:`rcsim.spacecraft.modes.draws`)
====  ====================================================

Each child draws a fixed count of standard variates whatever the spec (a function of the
vehicle's jet count ``n_jets`` only; the paper's vehicle's 16 give 33 timing normals), so no
spec change shifts another draw, and none of them touches the dispersion stream or the noise
stream's own draws: adding these effects to a campaign leaves every existing run's vehicle bit
for bit the same.

The specs are SI dataclasses; reading them from a campaign's TOML (keys in degrees, ranges,
messages naming the file) is the campaign's job (:mod:`rcsim.analysis.engine.campaign.effects`), at
the input edge.  Imports ``models`` and ``spacecraft`` only.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np
import pandas as pd

from rcsim.models.errors import InputError
from rcsim.spacecraft.dispersions import run_stream
from rcsim.spacecraft.sensors import SensorParams
from rcsim.spacecraft.valves import JetFaults, ValveTiming

SENSOR_NOISE, SENSOR_BIAS, TIMING, FAULT = 0, 1, 2, 3
FAULT_MODES = ("none", "off", "stuck", "degraded")


def effect_stream(seed: int, run_id: int, purpose: int) -> np.random.SeedSequence:
    """Child ``purpose`` (module table) of run ``run_id``'s noise stream."""
    noise = run_stream(seed, run_id, 1)
    return np.random.SeedSequence(noise.entropy, spawn_key=tuple(noise.spawn_key) + (purpose,))


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

    def is_none(self) -> bool:
        return not any(getattr(self, f.name) for f in fields(self))


@dataclass(frozen=True)
class FaultSpec:
    """One jet fault per run (with a probability): which jet, when, how.

    Attributes
    ----------
    mode : {"none", "off", "stuck", "degraded"}
    jets : tuple of int
        Candidate jets, numbered 1..n_jets of the vehicle flown; one is chosen uniformly per
        faulty run.  Empty (the default): every jet of the vehicle.
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
    jets: tuple = ()
    probability: float = 1.0
    time_s: tuple = (0.0, 0.0)
    stuck_for_s: tuple = (0.0, 0.0)
    thrust_factor: tuple = (1.0, 1.0)

    def is_none(self) -> bool:
        return self.mode == "none" or self.probability == 0

    def candidates(self, n_jets: int) -> tuple:
        """The candidate jets on a vehicle of ``n_jets`` jets (``jets``, or all of them).

        Raises
        ------
        InputError
            A candidate that is not a jet of the vehicle.
        """
        if not self.jets:
            return tuple(range(1, int(n_jets) + 1))
        bad = [j for j in self.jets if not 1 <= j <= n_jets]
        if bad:
            raise InputError(
                f"no jet {bad[0]}: the vehicle has jets 1..{n_jets}",
                parameter="jets",
                value=list(self.jets),
            )
        return tuple(self.jets)


def draw_sensors(spec: SensorSpec, seed: int, run_ids) -> tuple[SensorParams, list]:
    """Per-run sensor parameters and sensor-noise streams of campaign runs ``run_ids``."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    z = np.array(
        [
            np.random.default_rng(effect_stream(seed, i, SENSOR_BIAS)).standard_normal(6)
            for i in run_ids
        ]
    ).reshape(-1, 6)
    params = SensorParams.of(
        run_ids.size,
        att_noise_rad=spec.att_noise_rad,
        rate_noise_rad_s=spec.rate_noise_rad_s,
        att_bias_rad=spec.att_bias_sigma_rad * z[:, :3],
        rate_bias_rad_s=spec.rate_bias_sigma_rad_s * z[:, 3:],
        rate_walk_rad_s_per_sqrt_s=spec.rate_walk_rad_s_per_sqrt_s,
    )
    return params, [effect_stream(seed, i, SENSOR_NOISE) for i in run_ids]


def draw_timing(
    spec: TimingSpec, seed: int, run_ids, n_jets: int, nominal: ValveTiming | None = None
) -> ValveTiming:
    """Per-run delays of campaign runs ``run_ids`` of a vehicle of ``n_jets`` jets (normal about
    the means, clipped at 0): the command delay, then an opening and a closing latency per
    jet, ``1 + 2 n_jets`` normals per run.

    ``nominal`` (one run: a vehicle file's own delays, per jet) is added to the spec's means:
    the spec's sigmas disperse about it.  (A campaign never gives both a mean and a vehicle's
    nominal of the same delay: :func:`rcsim.analysis.engine.campaign.effects.parse_effects`.)"""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    k = 1 + 2 * int(n_jets)
    z = np.array(
        [np.random.default_rng(effect_stream(seed, i, TIMING)).standard_normal(k) for i in run_ids]
    ).reshape(-1, k)
    command, opens, closes = spec.command_delay_s, spec.open_delay_s, spec.close_delay_s
    if nominal is not None:
        own = nominal.for_jets(n_jets)
        command = own.command_delay_s[0] + command
        opens = own.open_delay_s[0] + opens
        closes = own.close_delay_s[0] + closes
    pos = lambda v: np.maximum(v, 0.0)  # noqa: E731
    return ValveTiming(
        command_delay_s=pos(command + spec.command_delay_sigma_s * z[:, 0]),
        open_delay_s=pos(opens + spec.open_delay_sigma_s * z[:, 1 : 1 + n_jets]),
        close_delay_s=pos(closes + spec.close_delay_sigma_s * z[:, 1 + n_jets : k]),
    )


def draw_faults(spec: FaultSpec, seed: int, run_ids, n_jets: int) -> tuple[JetFaults, pd.DataFrame]:
    """Per-run jet faults of campaign runs ``run_ids`` of a vehicle of ``n_jets`` jets and a
    frame of what was drawn (4 uniforms per run whatever the vehicle: the faulty jet is the
    candidate :meth:`FaultSpec.candidates` at ``floor(u * count)``).

    Returns
    -------
    faults : JetFaults
    drawn : DataFrame
        ``fault_jet`` (0: no fault), ``fault_time_s``, ``fault_stuck_for_s``,
        ``fault_thrust_factor`` per run (NaN where not applicable).
    """
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    n = run_ids.size
    u = np.array(
        [np.random.default_rng(effect_stream(seed, i, FAULT)).random(4) for i in run_ids]
    ).reshape(-1, 4)
    faulty = (u[:, 0] < spec.probability) & (spec.mode != "none")
    candidates = spec.candidates(n_jets)
    jets = np.asarray(candidates)[
        np.minimum((u[:, 1] * len(candidates)).astype(int), len(candidates) - 1)
    ]
    lerp = lambda lo_hi, x: lo_hi[0] + (lo_hi[1] - lo_hi[0]) * x  # noqa: E731
    when = lerp(spec.time_s, u[:, 2])
    faults = JetFaults.of(n, n_jets=n_jets)
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
    drawn = pd.DataFrame(
        {
            "fault_jet": np.where(faulty, jets, 0),
            "fault_time_s": np.where(faulty & (spec.mode != "degraded"), when, np.nan),
            "fault_stuck_for_s": stuck_for,
            "fault_thrust_factor": factor,
        }
    )
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
