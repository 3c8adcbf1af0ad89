"""Dispersions of real pulses and blowdown: rise and tail-off times, the impulse bit and the
initial tank pressure, drawn run by run.

Model (a vehicle file's ``[dispersions]`` keys ``pulse_rise_s``, ``pulse_tail_s``,
``impulse_bit``, ``tank_pressure_pa``: 3-sigma, normal, ``docs/vehicles.md``):

* each jet's rise and tail-off (time constants or ramps, :mod:`rcsim.spacecraft.pulse_shape`)
  ``nominal + sigma z``, independently per jet, at least 0;
* each jet's impulse bit (an impulse-bit table's, every point alike; a first-order or linear
  pulse's scatter is its rise and tail-off's) times ``1 + sigma z``, independently per jet, at
  least 0; a steady firing's share above the table follows
  (:func:`rcsim.spacecraft.pulse_shape.table_intervals`);
* the tank's initial pressure ``P0 + sigma z`` (the reference pressure stays the nominal's, so
  a run with more pressure thrusts more from the start: :mod:`rcsim.spacecraft.blowdown`).

The readers keep 3-sigma below each nominal (a 3-sigma draw stays physical) and within the
slot limit of tails.

Seeding: child :data:`PULSE` of run ``i``'s noise stream
(:func:`rcsim.spacecraft.effect_draws.effect_stream`), ``3 n_jets + 1`` standard normals
always (rise, tail, impulse per jet, then the pressure) whatever the sigmas, so no sigma
shifts another draw and a vehicle without these dispersions draws nothing: every run flies as
before.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rcsim.spacecraft.blowdown import Blowdown
from rcsim.spacecraft.effect_draws import effect_stream
from rcsim.spacecraft.pulse_shape import PulseShape

#: Child of a run's noise stream the pulse dispersions draw from (after
#: :mod:`rcsim.spacecraft.effect_draws`' 0-3).
PULSE = 4
#: The vehicle file's ``[dispersions]`` keys of this module, and their SI names here.
PULSE_SIGMA_KEYS = ("pulse_rise_s", "pulse_tail_s", "impulse_bit", "tank_pressure_pa")


@dataclass(frozen=True)
class PulseSigmas:
    """One-sigma dispersions (zero: not dispersed): ``rise_s``, ``tail_s`` [s],
    ``impulse_bit`` (relative), ``pressure_pa`` [Pa]."""

    rise_s: float = 0.0
    tail_s: float = 0.0
    impulse_bit: float = 0.0
    pressure_pa: float = 0.0

    @classmethod
    def from_three_sigma(cls, three_sigma: dict) -> PulseSigmas:
        """From a vehicle file's ``[dispersions]`` keys (:data:`PULSE_SIGMA_KEYS`, 3-sigma)."""
        get = lambda key: float(three_sigma.get(key, 0.0)) / 3.0  # noqa: E731
        return cls(
            get("pulse_rise_s"),
            get("pulse_tail_s"),
            get("impulse_bit"),
            get("tank_pressure_pa"),
        )

    def disperses_pulse(self) -> bool:
        return bool(self.rise_s or self.tail_s or self.impulse_bit)

    def disperses_blowdown(self) -> bool:
        return bool(self.pressure_pa)


def pulse_normals(seed: int, run_ids, n_jets: int) -> np.ndarray:
    """The standard normals of runs ``run_ids``, ``(n, 3 n_jets + 1)``."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    z = np.empty((run_ids.size, 3 * n_jets + 1))
    for k, i in enumerate(run_ids):  # a few variates a run; the flight dominates
        z[k] = np.random.default_rng(effect_stream(seed, int(i), PULSE)).standard_normal(z.shape[1])
    return z


def draw_pulses(
    shape: PulseShape | None,
    blowdown: Blowdown | None,
    sigmas: PulseSigmas,
    seed: int,
    run_ids,
    n_jets: int,
) -> tuple[PulseShape | None, Blowdown | None, dict]:
    """The runs' dispersed pulse shape and blowdown (of the nominal ``shape`` and
    ``blowdown`` for one run, None when the vehicle has none; a vehicle of ``n_jets`` jets),
    and the values each run flew:
    ``pulse_rise_mean_s``, ``pulse_tail_mean_s``, ``impulse_bit_scale_mean`` (means over the
    jets) when the pulse is dispersed, ``tank_pressure_pa`` when the pressure is."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    n = run_ids.size
    values: dict = {}
    z = pulse_normals(seed, run_ids, n_jets)
    if shape is not None:
        shape = shape.take(np.zeros(n, int))
        if sigmas.disperses_pulse():
            j = n_jets
            rise = np.maximum(shape.rise_s + sigmas.rise_s * z[:, :j], 0.0)
            tail = np.maximum(shape.tail_s + sigmas.tail_s * z[:, j : 2 * j], 0.0)
            scale = np.maximum(1.0 + sigmas.impulse_bit * z[:, 2 * j : 3 * j], 0.0)
            if shape.model == "table":
                rise, tail = shape.rise_s, shape.tail_s
            shape = replace(
                shape,
                rise_s=rise,
                tail_s=tail,
                impulse_scale=scale if shape.model == "table" else None,
            )
            values.update(
                pulse_rise_mean_s=rise.mean(axis=1),
                pulse_tail_mean_s=tail.mean(axis=1),
                impulse_bit_scale_mean=(
                    scale.mean(axis=1) if shape.model == "table" else np.ones(n)
                ),
            )
    if blowdown is not None:
        blowdown = blowdown.take(np.zeros(n, int))
        if sigmas.disperses_blowdown():
            p0 = np.maximum(blowdown.pressure_pa + sigmas.pressure_pa * z[:, -1], 1.0)
            blowdown = replace(blowdown, pressure_pa=p0)
            values["tank_pressure_pa"] = p0
    return shape, blowdown, values
