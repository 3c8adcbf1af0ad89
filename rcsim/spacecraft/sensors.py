"""Attitude and rate sensors: what the controller sees instead of the true state.

Measurement model, per run, sampled at each control cycle's start ``t_k`` (the instant the
controller reads its sensors):

* attitude: ``q_meas = q_true * exp((b_att + sigma_att z_att) / 2)``: a small body-frame
  rotation, white per axis with a constant bias;
* rate: ``omega_meas = omega_true + b_rate + w_k + sigma_rate z_rate``: white per axis, a
  constant bias, and a rate random walk ``w_{k+1} = w_k + sigma_walk sqrt(T) z_walk``
  (``w_0 = 0``; ``sigma_walk`` in rad/s per sqrt(s), so ``w`` has standard deviation
  ``sigma_walk sqrt(t)``).

The standard normals ``z`` come from one generator per run on that run's sensor-noise stream
(:func:`rcsim.spacecraft.effect_draws.effect_streams`), nine per cycle in a fixed order (attitude
x y z, rate x y z, walk x y z) whatever the sigmas: a zero sigma never shifts another draw, and a
run's noise does not depend on the batch it flies in.  The draws are made in blocks of cycles
(one Python loop over runs per block, not per cycle).

Imports ``models`` and ``rcsim.spacecraft.navigation`` only.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from rcsim.models.errors import InputError
from rcsim.spacecraft.navigation import quat_from_rotvec, quat_mul

#: Standard normals per run per cycle: attitude (3), rate (3), rate walk (3).
N_SENSOR_NORMALS = 9
_BLOCK_CYCLES = 256  # cycles of noise drawn at once per run


@dataclass(frozen=True)
class SensorParams:
    """Sensor errors, per run and body axis (all ``(n_runs, 3)``, SI).

    Attributes
    ----------
    att_noise_rad : white attitude noise, one sigma per sample [rad].
    rate_noise_rad_s : white rate noise, one sigma per sample [rad/s].
    att_bias_rad : constant attitude bias [rad].
    rate_bias_rad_s : constant rate bias [rad/s].
    rate_walk_rad_s_per_sqrt_s : rate random walk intensity [rad/s/sqrt(s)].
    """

    att_noise_rad: np.ndarray
    rate_noise_rad_s: np.ndarray
    att_bias_rad: np.ndarray
    rate_bias_rad_s: np.ndarray
    rate_walk_rad_s_per_sqrt_s: np.ndarray

    @classmethod
    def of(cls, n_runs: int, **values) -> SensorParams:
        """Parameters broadcast to ``n_runs`` runs (scalars, per-axis rows or full arrays);
        omitted ones are zero."""
        names = [f.name for f in fields(cls)]
        unknown = set(values) - set(names)
        if unknown:
            raise InputError(f"unknown sensor parameter(s) {sorted(unknown)}; known: {names}")
        out = {}
        for name in names:
            try:
                out[name] = np.array(
                    np.broadcast_to(np.asarray(values.get(name, 0.0), float), (n_runs, 3))
                )
            except ValueError:
                raise InputError(
                    f"cannot be shaped as ({n_runs}, 3): shape {np.shape(values[name])}",
                    parameter=name,
                    value=None,
                ) from None
        return cls(**out)

    @property
    def n_runs(self) -> int:
        return int(self.att_noise_rad.shape[0])

    def is_perfect(self) -> bool:
        """No error at all: the controller sees the true state."""
        return not any(getattr(self, f.name).any() for f in fields(self))

    def is_random(self) -> bool:
        """Any noise or walk to draw (biases alone need no random numbers in flight)."""
        return bool(
            self.att_noise_rad.any()
            or self.rate_noise_rad_s.any()
            or self.rate_walk_rad_s_per_sqrt_s.any()
        )

    def check(self, n_runs: int) -> None:
        """Raise InputError on a wrong run count, non-finite values or a negative sigma."""
        if self.n_runs != n_runs:
            raise InputError(
                f"has {self.n_runs} runs, the simulation {n_runs}", parameter="sensors", value=None
            )
        for f in fields(self):
            v = getattr(self, f.name)
            bad = ~np.isfinite(v)
            if "bias" not in f.name:
                bad |= v < 0
            if bad.any():
                raise InputError(
                    f"must be finite{'' if 'bias' in f.name else ' and >= 0'}, got {v[bad][0]!r}",
                    parameter=f.name,
                    value=float(v[bad][0]),
                )


class SensorNoise:
    """Per-run standard normals for the sensors, cycle by cycle, from per-run streams.

    Parameters
    ----------
    streams : sequence of numpy.random.SeedSequence
        One per run (its sensor-noise stream).
    """

    def __init__(self, streams):
        self._rngs = [np.random.default_rng(s) for s in streams]
        self._block = np.empty((len(self._rngs), 0, N_SENSOR_NORMALS))
        self._first = 0  # cycle index of self._block[:, 0]

    @property
    def n_runs(self) -> int:
        return len(self._rngs)

    def draw(self, k: int) -> np.ndarray:
        """The normals of cycle ``k`` (cycles asked for in order), shape (n_runs, 9)."""
        if k >= self._first + self._block.shape[1]:
            self._first = k
            # Consecutive blocks continue each run's stream: the sequence does not depend on
            # the block length (tests/spacecraft/test_sensors.py).
            self._block = np.stack(
                [rng.standard_normal((_BLOCK_CYCLES, N_SENSOR_NORMALS)) for rng in self._rngs]
            )
        return self._block[:, k - self._first]


@dataclass
class SensorState:
    """The rate random walk of every run [rad/s], shape (n_runs, 3)."""

    walk_rad_s: np.ndarray


def measure(
    q_BN: np.ndarray,
    omega_B: np.ndarray,
    z: np.ndarray | None,
    params: SensorParams,
    state: SensorState,
    cycle_s: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Measured attitude and rate at a cycle's start; advances the random walk.

    Parameters
    ----------
    q_BN : ndarray, (n_runs, 4)
    omega_B : ndarray, (n_runs, 3)  [rad/s]
    z : ndarray, (n_runs, 9) or None
        This cycle's standard normals (None: no random part).
    params : SensorParams
    state : SensorState
        Updated in place.
    cycle_s : float
        Control cycle [s] (the walk's step).

    Returns
    -------
    q_meas : ndarray, (n_runs, 4)
    omega_meas : ndarray, (n_runs, 3)  [rad/s]
    """
    d_att = params.att_bias_rad
    omega = omega_B + params.rate_bias_rad_s + state.walk_rad_s
    if z is not None:
        d_att = d_att + params.att_noise_rad * z[:, 0:3]
        omega = omega + params.rate_noise_rad_s * z[:, 3:6]
        state.walk_rad_s = state.walk_rad_s + (
            params.rate_walk_rad_s_per_sqrt_s * np.sqrt(cycle_s) * z[:, 6:9]
        )
    q = quat_mul(q_BN, quat_from_rotvec(d_att)) if d_att.any() else q_BN
    return q, omega
