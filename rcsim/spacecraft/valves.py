"""When each jet actually thrusts: command timing, valve latencies and jet faults.

A controller commands, each control cycle ``[t_k, t_k + T]``, an on-time ``u`` per jet from the
cycle's start (:mod:`rcsim.spacecraft.propulsion`).  The valve command is that signal shifted by the
sensor-to-actuator delay ``d``: on over ``[t_k + d, t_k + d + u]``, a full-cycle command
continuing into the next cycle without a new opening.  The valve opens ``open_delay`` after a
rising edge of its command and closes ``close_delay`` after a falling edge, so a pulse of
commanded length ``u`` thrusts over ``[t_k + d + d_o, t_k + d + u + d_c]`` (nothing when that is
empty: a pulse shorter than ``d_o - d_c`` never opens the valve).  Thrust can therefore start
mid-cycle and spill into the next one; :func:`rcsim.spacecraft.pieces.cycle_pieces` integrates each
cycle exactly at these instants.  With all delays zero the intervals are ``[0, u]`` of every
cycle: today's firings exactly.

Faults (per run, per jet; :class:`JetFaults`):

* ``off_from_s``: the jet gives no thrust from this time on (0: failed from the start; inf:
  never).  A failed jet's valve still follows its commands, without effect;
* ``stuck_from_s``, ``stuck_for_s``: the jet thrusts, whatever its commands, over
  ``[stuck_from, stuck_from + stuck_for]`` (a valve stuck open);
* ``thrust_factor``: the jet delivers this fraction of its thrust, in ``[0, 1]``, the whole
  flight (degraded).  A failed-off jet gives no thrust even while stuck.

Propellant flow (optional, :class:`ThrustProfile`): thrust rises linearly over ``rise_s`` after
the valve opens and decays linearly over ``fall_s`` after it closes (the paper's "non-linear
thrust profile"); :func:`rcsim.spacecraft.pieces.profile_pieces` flies it with exact impulse.

Per-jet arrays are ``(n_runs, n_jets)``, ``n_jets`` the vehicle's own count
(:func:`rcsim.spacecraft.vehicle.model.jet_count`).  :meth:`ValveTiming.of` and
:meth:`JetFaults.of` built
from per-run values alone give one column, "the same for every jet"; the simulation widens
them to its vehicle (:meth:`ValveTiming.for_jets`, :meth:`JetFaults.for_jets`) and refuses
per-jet arrays of another width.

Each delay must be shorter than a control cycle once the command delay is added
(``d + d_o < T`` and ``d + d_c < T``): then at most one earlier firing is still pending when a
new one is commanded, and a cycle's command always acts before the next cycle's.

Imports ``models`` only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcsim.models.errors import InputError

# Pending on-intervals kept per jet: the firing in progress, the tail of the previous one
# (close latency), and a spare (a new firing after a zero-length command gap).
_SLOTS = 3


def _jet_width(n_runs: int, n_jets: int | None, values: dict) -> int:
    """Width of the per-jet arrays made of ``values`` (name -> scalar, per-jet row, per-run
    column or full array): ``n_jets`` when given, else the jets the values name (1 when none
    has a per-jet axis: the same for every jet)."""
    if n_jets is not None:
        return int(n_jets)
    try:
        shape = np.broadcast_shapes((n_runs, 1), *(np.shape(v) for v in values.values()))
    except ValueError:
        shapes = {name: np.shape(v) for name, v in values.items()}
        raise InputError(
            f"per-jet values of different shapes {shapes} for {n_runs} runs",
            parameter=next(iter(values)),
            value=None,
        ) from None
    if len(shape) != 2:
        raise InputError(
            f"cannot be shaped as (n_runs, n_jets): shape {shape}",
            parameter=next(iter(values)),
            value=None,
        )
    return int(shape[1])


def _widen(array: np.ndarray, n_jets: int, name: str) -> np.ndarray:
    """A ``(n_runs, 1)`` or ``(n_runs, n_jets)`` per-jet array as ``(n_runs, n_jets)``."""
    if array.shape[1] == n_jets:
        return array
    if array.shape[1] != 1:
        raise InputError(
            f"has per-jet values for {array.shape[1]} jets; the vehicle has {n_jets}",
            parameter=name,
            value=None,
        )
    return np.repeat(array, n_jets, axis=1)


def _per_run(value, n_runs: int, shape: tuple, name: str, dtype=float) -> np.ndarray:
    """``value`` broadcast to ``(n_runs, *shape)`` (a scalar, a per-jet row or a full array)."""
    try:
        return np.array(np.broadcast_to(np.asarray(value, dtype), (n_runs,) + shape))
    except ValueError:
        raise InputError(
            f"cannot be shaped as {(n_runs,) + shape}: shape {np.shape(value)}",
            parameter=name,
            value=None,
        ) from None


@dataclass(frozen=True)
class ValveTiming:
    """Command and valve delays, per run [s].

    Attributes
    ----------
    command_delay_s : ndarray, (n_runs,)
        Sensor-to-actuator delay: from the instant the sensors are read (a cycle's start) to
        the instant the valve command changes.
    open_delay_s, close_delay_s : ndarray, (n_runs, n_jets), or (n_runs, 1)
        Valve latency from a rising (falling) command edge to thrust on (off); one column:
        the same for every jet.
    """

    command_delay_s: np.ndarray
    open_delay_s: np.ndarray
    close_delay_s: np.ndarray

    @classmethod
    def of(
        cls,
        n_runs: int,
        *,
        n_jets: int | None = None,
        command_delay_s=0.0,
        open_delay_s=0.0,
        close_delay_s=0.0,
    ) -> ValveTiming:
        """Delays broadcast to ``n_runs`` runs (scalars, per-jet rows or full arrays) and
        ``n_jets`` jets (default: the jets the values name, one column when none does)."""
        jets = _jet_width(
            n_runs, n_jets, {"open_delay_s": open_delay_s, "close_delay_s": close_delay_s}
        )
        return cls(
            _per_run(command_delay_s, n_runs, (), "command_delay_s"),
            _per_run(open_delay_s, n_runs, (jets,), "open_delay_s"),
            _per_run(close_delay_s, n_runs, (jets,), "close_delay_s"),
        )

    def for_jets(self, n_jets: int) -> ValveTiming:
        """The same delays on a vehicle of ``n_jets`` jets (one column widened to all).

        Raises
        ------
        InputError
            Per-jet delays for another number of jets.
        """
        return ValveTiming(
            self.command_delay_s,
            _widen(self.open_delay_s, n_jets, "open_delay_s"),
            _widen(self.close_delay_s, n_jets, "close_delay_s"),
        )

    def take(self, rows) -> ValveTiming:
        """The delays of runs ``rows`` (indices into the runs, repeats allowed): e.g. one
        vehicle's nominal delays for ``n`` runs, ``take(np.zeros(n, int))``."""
        rows = np.asarray(rows, int)
        return ValveTiming(
            self.command_delay_s[rows], self.open_delay_s[rows], self.close_delay_s[rows]
        )

    @property
    def n_runs(self) -> int:
        return int(self.command_delay_s.shape[0])

    def is_zero(self) -> bool:
        return not (
            self.command_delay_s.any() or self.open_delay_s.any() or self.close_delay_s.any()
        )

    def check(self, cycle_s: float, n_runs: int) -> None:
        """Raise InputError unless every delay is finite, >= 0 and, with the command delay,
        shorter than the control cycle ``cycle_s`` [s]; or the run count differs."""
        if self.n_runs != n_runs:
            raise InputError(
                f"has {self.n_runs} runs, the simulation {n_runs}", parameter="timing", value=None
            )
        d = self.command_delay_s[:, None]
        for name in ("command_delay_s", "open_delay_s", "close_delay_s"):
            v = getattr(self, name)
            bad = ~(np.isfinite(v) & (v >= 0))
            if bad.any():
                raise InputError(
                    f"must be finite and >= 0 [s], got {v[bad][0]!r}",
                    parameter=name,
                    value=float(v[bad][0]),
                )
        for name in ("open_delay_s", "close_delay_s"):
            total = d + getattr(self, name)
            if (total >= cycle_s).any():
                worst = float(total.max())
                raise InputError(
                    f"plus command_delay_s is {worst:g} s, not shorter than the {cycle_s:g} s "
                    f"control cycle",
                    parameter=name,
                    value=worst,
                )


@dataclass(frozen=True)
class JetFaults:
    """Jet faults, per run and jet (see the module docstring).

    Attributes
    ----------
    off_from_s : ndarray, (n_runs, n_jets)
        No thrust from this time on [s] (inf: never).
    stuck_from_s, stuck_for_s : ndarray, (n_runs, n_jets)
        Stuck-on window start [s] (inf: never) and length [s].
    thrust_factor : ndarray, (n_runs, n_jets)
        Fraction of the jet's thrust delivered, in [0, 1].

    Every array may instead be ``(n_runs, 1)``: the same for every jet (:meth:`of` from
    per-run values); :meth:`for_jets` widens them.
    """

    off_from_s: np.ndarray
    stuck_from_s: np.ndarray
    stuck_for_s: np.ndarray
    thrust_factor: np.ndarray

    @classmethod
    def of(
        cls,
        n_runs: int,
        *,
        n_jets: int | None = None,
        off_from_s=np.inf,
        stuck_from_s=np.inf,
        stuck_for_s=0.0,
        thrust_factor=1.0,
    ) -> JetFaults:
        """Faults broadcast to ``n_runs`` runs (scalars, per-jet rows or full arrays) and
        ``n_jets`` jets (default: the jets the values name, one column when none does)."""
        values = {
            "off_from_s": off_from_s,
            "stuck_from_s": stuck_from_s,
            "stuck_for_s": stuck_for_s,
            "thrust_factor": thrust_factor,
        }
        jets = _jet_width(n_runs, n_jets, values)
        return cls(*(_per_run(v, n_runs, (jets,), name) for name, v in values.items()))

    def for_jets(self, n_jets: int) -> JetFaults:
        """The same faults on a vehicle of ``n_jets`` jets (one column widened to all).

        Raises
        ------
        InputError
            Per-jet faults for another number of jets.
        """
        return JetFaults(
            *(
                _widen(getattr(self, name), n_jets, name)
                for name in ("off_from_s", "stuck_from_s", "stuck_for_s", "thrust_factor")
            )
        )

    def take(self, rows) -> JetFaults:
        """The faults of runs ``rows`` (indices into the runs, repeats allowed)."""
        rows = np.asarray(rows, int)
        return JetFaults(
            *(
                getattr(self, name)[rows]
                for name in ("off_from_s", "stuck_from_s", "stuck_for_s", "thrust_factor")
            )
        )

    @property
    def n_runs(self) -> int:
        return int(self.off_from_s.shape[0])

    def is_none(self) -> bool:
        return bool(
            np.isinf(self.off_from_s).all()
            and np.isinf(self.stuck_from_s).all()
            and (self.thrust_factor == 1.0).all()
        )

    def check(self, n_runs: int) -> None:
        """Raise InputError on a wrong run count, NaN times, a negative stuck length or a
        thrust factor outside [0, 1]."""
        if self.n_runs != n_runs:
            raise InputError(
                f"has {self.n_runs} runs, the simulation {n_runs}", parameter="faults", value=None
            )
        checks = (
            ("off_from_s", lambda v: ~np.isnan(v)),
            ("stuck_from_s", lambda v: ~np.isnan(v)),
            ("stuck_for_s", lambda v: np.isfinite(v) & (v >= 0)),
            ("thrust_factor", lambda v: np.isfinite(v) & (v >= 0) & (v <= 1)),
        )
        for name, ok in checks:
            v = getattr(self, name)
            bad = ~ok(v)
            if bad.any():
                raise InputError(
                    f"NaN, negative or (thrust_factor) outside [0, 1]: {v[bad][0]!r}",
                    parameter=name,
                    value=float(v[bad][0]),
                )


@dataclass(frozen=True)
class ThrustProfile:
    """Thrust transients of every jet (the same for all runs).

    Attributes
    ----------
    rise_s : float
        Time from valve opening to full thrust, linear [s].
    fall_s : float
        Time from full thrust to zero after valve closing, linear [s] (a jet closed before
        full thrust decays from the level it reached, at the same slope).
    segments : int
        Pieces each ramp is integrated in (impulse exact for any; attitude error second order
        in ``ramp / segments``).
    """

    rise_s: float = 0.0
    fall_s: float = 0.0
    segments: int = 4

    def __post_init__(self):
        ok = all(np.isfinite(v) and 0 <= v for v in (self.rise_s, self.fall_s))
        if not ok or int(self.segments) != self.segments or self.segments < 1:
            raise InputError(
                f"rise_s and fall_s must be finite and >= 0 s and segments >= 1, got {self}",
                parameter="profile",
                value=None,
            )

    def is_none(self) -> bool:
        return self.rise_s == 0 and self.fall_s == 0


@dataclass
class ValveState:
    """Pending on-intervals of every jet, relative to the current cycle's start [s].

    ``start``/``end`` are ``(n_runs, n_jets, 3)``; a free slot is NaN; a firing whose close is
    not yet commanded ends at +inf.
    """

    start: np.ndarray
    end: np.ndarray
    was_on: np.ndarray  # (n_runs, n_jets): valve command on at the end of the last cycle

    @classmethod
    def closed(cls, n_runs: int, n_jets: int) -> ValveState:
        """Every valve closed, nothing pending, for ``n_runs`` vehicles of ``n_jets`` jets."""
        shape = (n_runs, n_jets, _SLOTS)
        return cls(np.full(shape, np.nan), np.full(shape, np.nan), np.zeros((n_runs, n_jets), bool))


def command_valves(
    state: ValveState, on_s: np.ndarray, timing: ValveTiming, cycle_s: float
) -> None:
    """Turn this cycle's delivered commands into valve on-intervals (``state`` in place).

    Parameters
    ----------
    state : ValveState
        Relative to this cycle's start.
    on_s : ndarray, (n_runs, n_jets)
        Commanded on-time from the cycle's start [s] (after the valve limits).
    timing : ValveTiming
    cycle_s : float
    """
    full = on_s >= cycle_s * (1.0 - 1e-12)  # the same rule as apply_valve_limits' on_at_end
    rising = (on_s > 0) & ~state.was_on
    falling = ~full & (state.was_on | (on_s > 0))
    d = timing.command_delay_s[:, None]
    if rising.any():
        free = np.isnan(state.start)
        if (rising & ~free.any(axis=-1)).any():  # pragma: no cover - excluded by check()
            raise AssertionError("no free valve slot: delays longer than a cycle")
        slot = np.argmax(free, axis=-1)[..., None]
        new_start = np.take_along_axis(state.start, slot, -1)[..., 0]
        new_end = np.take_along_axis(state.end, slot, -1)[..., 0]
        new_start = np.where(rising, d + timing.open_delay_s, new_start)
        new_end = np.where(rising, np.inf, new_end)
        np.put_along_axis(state.start, slot, new_start[..., None], -1)
        np.put_along_axis(state.end, slot, new_end[..., None], -1)
    if falling.any():
        close = d + on_s + timing.close_delay_s
        pending = np.isinf(state.end) & falling[..., None]
        state.end[pending] = np.broadcast_to(close[..., None], state.end.shape)[pending]
        with np.errstate(invalid="ignore"):
            never = state.end <= state.start  # closed before it opened: no thrust
        state.start[never] = np.nan
        state.end[never] = np.nan
    state.was_on = full


def cycle_intervals(
    state: ValveState, faults: JetFaults | None, t0_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """This cycle's thrust intervals, relative to its start ``t0_s``: the valve's plus the
    stuck-on window, ended at a failure.  Shapes ``(n_runs, n_jets, k)``."""
    start, end = state.start, state.end
    if faults is None:
        return start, end
    start = np.concatenate([start, (faults.stuck_from_s - t0_s)[..., None]], axis=-1)
    end = np.concatenate(
        [end, (faults.stuck_from_s + faults.stuck_for_s - t0_s)[..., None]], axis=-1
    )
    return start, np.minimum(end, (faults.off_from_s - t0_s)[..., None])


def end_cycle(state: ValveState, cycle_s: float, tail_s: float = 0.0) -> None:
    """Drop the intervals over by the cycle's end (thrust tails of ``tail_s`` after closing
    included) and shift the rest to the next cycle."""
    with np.errstate(invalid="ignore"):
        done = state.end + tail_s <= cycle_s
    state.start[done] = np.nan
    state.end[done] = np.nan
    state.start -= cycle_s
    state.end -= cycle_s
