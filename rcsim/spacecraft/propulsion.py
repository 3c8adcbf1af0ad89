"""On-time commands to exact per-step jet duty, and the bookkeeping of firings and propellant.

Every control cycle a controller commands, per jet, the time it is on during that cycle,
starting at the cycle's start (a longer firing is a run of whole-cycle commands ending in a
partial one).  The physics steps at ``dt`` with ``n_sub = cycle / dt`` steps per cycle; the jet's
actuator control in step ``k`` is the fraction of that step the jet is on,
``clip((t_on - k dt) / dt, 0, 1)``, so the impulse is ``thrust * t_on`` exactly whatever ``dt``
(docs/engine_facts.md, "Sub-cycle pulses": sampling the switch-off at steps instead is 4-16 % off).

The closed loop no longer spreads a pulse over a step: it cuts each cycle at the jets' switch
instants (:mod:`rcsim.spacecraft.pieces`), and a pulse may start anywhere in a cycle (a valve
opening late, :mod:`rcsim.spacecraft.valves`): any on-interval ``[start, end]`` of a cycle is flown
exactly.
:func:`duty_profile` remains the impulse-exact duty of a fixed-step integration (benchmarks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2


@dataclass(frozen=True)
class PropulsionParams:
    """Valve limits.

    Attributes
    ----------
    cycle_s : float
        Control cycle [s]: the flown vehicle's profile's
        (:meth:`rcsim.spacecraft.vehicle.Vehicle.propulsion`).
    min_pulse_s : float
        Shortest firing a valve can make [s].  A *new* firing commanded shorter than this is
        not made (the command is dropped and counted in ``dropped``); a firing continuing from
        the previous cycle is never cut.  0 disables the limit.
    """

    cycle_s: float
    min_pulse_s: float = 0.0

    def __post_init__(self):
        if not self.cycle_s > 0:
            raise ValueError(f"cycle_s must be > 0, got {self.cycle_s}")
        if not 0 <= self.min_pulse_s < self.cycle_s:
            raise ValueError(f"min_pulse_s must be in [0, cycle_s), got {self.min_pulse_s}")


@dataclass
class PropulsionState:
    """Per-run, per-jet accumulators (all arrays shaped ``(n_runs, n_jets)``).

    ``on_at_end``: the jet was on at the end of the last cycle (the next command continues
    that firing).  ``firings``: firings started.  ``on_time_s``: total on-time [s].
    ``impulse_ns``: total impulse [N s].  ``dropped``: commands below the minimum pulse.
    ``used_kg``: propellant used [kg], kept by a flight whose Isp is not one number (a
    pulse-mode Isp, a blowdown's; :mod:`rcsim.spacecraft.pulse_shape`); None: impulse / (Isp
    g0).
    """

    on_at_end: np.ndarray
    firings: np.ndarray
    on_time_s: np.ndarray
    impulse_ns: np.ndarray
    dropped: np.ndarray
    used_kg: np.ndarray | None = None

    @classmethod
    def zeros(cls, n_runs: int, n_jets: int) -> PropulsionState:
        """Nothing fired yet, for ``n_runs`` vehicles of ``n_jets`` jets."""
        z = lambda dtype: np.zeros((n_runs, n_jets), dtype)  # noqa: E731
        return cls(z(bool), z(np.int64), z(float), z(float), z(np.int64))

    def propellant_kg(self, isp_s: float) -> np.ndarray:
        """Propellant used per run [kg], shape (n_runs,): impulse / (Isp g0), or as kept
        (``used_kg``)."""
        if self.used_kg is not None:
            return self.used_kg.sum(axis=1)
        return self.impulse_ns.sum(axis=1) / (isp_s * G0_M_S2)

    def jet_propellant_kg(self, isp_s: float) -> np.ndarray:
        """Propellant each jet used [kg], (n_runs, n_jets): impulse / (Isp g0), or as kept."""
        if self.used_kg is not None:
            return self.used_kg.copy()
        return self.impulse_ns / (isp_s * G0_M_S2)


def apply_valve_limits(
    on_time_s: np.ndarray,
    state: PropulsionState,
    params: PropulsionParams,
    thrust_n: np.ndarray,
    *,
    account: bool = True,
) -> np.ndarray:
    """Clip commands to ``[0, cycle]``, drop too-short new firings, and update ``state``.

    ``account=False`` leaves ``state.on_time_s`` and ``state.impulse_ns`` alone: the closed loop
    adds what the jets actually delivered once valve delays and faults are applied
    (:mod:`rcsim.spacecraft.valves`); firings, drops and ``on_at_end`` are the commands' either way.

    Parameters
    ----------
    on_time_s : ndarray, (n_runs, n_jets)
        Commanded on-time this cycle [s].
    state : PropulsionState
        Updated in place.
    thrust_n : ndarray, (n_runs, n_jets)
        Thrust of each jet [N], for the impulse total.

    Returns
    -------
    ndarray, (n_runs, n_jets)
        The on-times the valves deliver this cycle [s].
    """
    # NaN commands (a broken controller) are not fired; clip keeps the rest in [0, cycle].
    # + 0.0 makes a -0.0 command +0.0 whichever zero numpy's clip keeps (1.26 and 2.x differ).
    on = np.clip(on_time_s, 0.0, params.cycle_s) + 0.0
    on[np.isnan(on)] = 0.0
    new = (on > 0) & ~state.on_at_end
    too_short = new & (on < params.min_pulse_s)
    on = np.where(too_short, 0.0, on)
    state.dropped += too_short
    state.firings += new & ~too_short
    if account:
        state.on_time_s += on
        state.impulse_ns += on * thrust_n
    # A firing continues into the next cycle only if it filled this one (up to rounding).
    state.on_at_end = on >= params.cycle_s * (1.0 - 1e-12)
    return on


def duty_profile(on_time_s: np.ndarray, dt_s: float, n_sub: int) -> np.ndarray:
    """Fraction of each physics step each jet is on.

    Parameters
    ----------
    on_time_s : ndarray, (n_runs, n_jets)
        On-time from the cycle's start [s], in ``[0, n_sub * dt_s]``.
    dt_s : float
        Physics step [s].
    n_sub : int
        Physics steps per control cycle.

    Returns
    -------
    ndarray, (n_runs, n_sub, n_jets)
        Duty in [0, 1]; ``duty.sum(axis=1) * dt_s == on_time_s`` to rounding.
    """
    if n_sub == 1:  # one physics step per cycle: the duty is the on-fraction of the cycle
        return np.clip(on_time_s / dt_s, 0.0, 1.0)[:, None, :]
    start = np.arange(n_sub)[None, :, None] * dt_s
    return np.clip((on_time_s[:, None, :] - start) / dt_s, 0.0, 1.0)
