"""Real pulses: thrust rise and tail-off, or a data sheet's impulse-bit table, flown exactly.

A vehicle file's ``[pulse]`` (``docs/vehicles.md``, "Pulses") gives one of three models of what
a jet delivers when its valve is open over ``[s, e]`` (the valve's thrust interval,
:mod:`rcsim.spacecraft.valves`).  Each is a thrust fraction ``f(t)`` of the jet's steady thrust
``F`` (time from the valve's opening ``x = t - s``, from its closing ``y = t - e``):

* ``model = "exponential"`` (first order, time constants ``rise_s`` = tau_r, ``tail_s`` = tau_t)::

      f = 1 - exp(-x / tau_r)                      while open
      f = p exp(-y / tau_t),  p = f(e)             after closing, for y < TAIL_CUT tau_t

  the tail is cut (zero) after :data:`TAIL_CUT` time constants, where ``exp(-TAIL_CUT)``
  (2e-9) of the peak is left: the impulse ignored is ``p tau_t exp(-TAIL_CUT)``.
* ``model = "linear"`` (ramps, :class:`rcsim.spacecraft.valves.ThrustProfile`'s law)::

      f = min(x / rise_s, 1)                       while open
      f = max(p - y / tail_s, 0),  p = f(e)        after closing

* ``model = "table"``: a data sheet's impulse bit ``I(u)`` against commanded on-time ``u``
  (:class:`ImpulseTable`).  The jet flies the equivalent square pulse of that impulse: full
  thrust over ``[s, s + I(u) / F]``.

The closed-form integral of each shape (:func:`thrust_integral`) gives every piece of a cycle
its *mean* level, so the impulse and the propellant are exact whatever the pieces; the pieces
are cut at the shape's knots (:func:`shaped_pieces`) so the attitude follows the shape to the
piecewise-constant approximation of it.  Overlapping contributions of one jet (a new pulse in
the tail of the last) add, capped at full thrust in each piece.

Isp against on-time (pulse-mode Isp, optional, any model): ``isp_on_time_s``, ``isp_s``
columns; a pulse of on-time ``u`` burns ``impulse / (Isp(u) g0)``.  ``Isp(u)`` is
interpolated linearly between the table's points, the first point's value below it, and
the vehicle's steady ``[propellant] isp_s`` above its last point; a firing commanded over a
whole cycle (its on-time unknown when it starts) is steady.

Per-jet arrays are ``(n_runs, n_jets)``: the vehicle's values per jet (a ``[[jet]] pulse``
override), dispersed per run.

Imports nothing of rcsim but :mod:`rcsim.spacecraft.pieces`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from rcsim.spacecraft.pieces import Pieces, cycle_pieces

#: Time constants after which an exponential tail is cut (its thrust ``exp(-20)`` = 2.1e-9 of
#: the level at closing: below any thruster's data and any attitude effect).
TAIL_CUT = 20.0
#: Pulse models a vehicle file's ``[pulse] model`` names.
PULSE_MODELS = ("exponential", "linear", "table")
# Knots the rise and tail of an exponential are cut at, in time constants (the attitude
# follows the shape to the piecewise-constant approximation between them; the impulse is exact
# for any cut).
_EXP_RISE_KNOTS = np.array([0.0, 0.25, 0.5, 1.0, 2.0, 4.0])
_EXP_TAIL_KNOTS = np.array([0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, TAIL_CUT])
_LINEAR_KNOTS = np.linspace(0.0, 1.0, 5)


@dataclass(frozen=True)
class ImpulseTable:
    """Impulse bit against commanded on-time (a thruster data sheet's pulse-mode table).

    Attributes
    ----------
    on_time_s : ndarray, (m,)
        Commanded on-times [s], strictly increasing, > 0.
    thrust_time_s : ndarray, (m,)
        Delivered impulse over the steady thrust, ``I / F`` [s], non-decreasing (the table's
        ``impulse_ns`` over the thrust it was given for).

    Interpolation: linear in ``u`` between the points, from ``(0, 0)`` to the first; above the
    last point the jet is at steady state, ``I(u) = I_m + F (u - u_m)``.
    """

    on_time_s: np.ndarray
    thrust_time_s: np.ndarray

    def equivalent_s(self, on_s: np.ndarray) -> np.ndarray:
        """Full-thrust time ``I(u) / F`` [s] of pulses of on-time ``on_s`` (any shape)."""
        u = np.asarray(on_s, float)
        u_last, t_last = self.on_time_s[-1], self.thrust_time_s[-1]
        inside = np.interp(u, np.r_[0.0, self.on_time_s], np.r_[0.0, self.thrust_time_s])
        return np.where(u > u_last, t_last + (u - u_last), np.where(u > 0, inside, 0.0))

    @property
    def deficit_s(self) -> float:
        """``u_m - I_m / F`` [s]: what a steady-state pulse loses to its transients (negative
        when its tail delivers more than its rise loses)."""
        return float(self.on_time_s[-1] - self.thrust_time_s[-1])


@dataclass(frozen=True)
class IspTable:
    """Specific impulse against commanded on-time (pulse-mode Isp).

    Attributes
    ----------
    on_time_s : ndarray, (m,)
        Commanded on-times [s], strictly increasing, > 0.
    isp_s : ndarray, (m,)
        Isp of a pulse of that on-time [s].
    steady_isp_s : float
        The vehicle's steady-state Isp [s] (``[propellant] isp_s``), above the last point.
    """

    on_time_s: np.ndarray
    isp_s: np.ndarray
    steady_isp_s: float

    def isp_at(self, on_s: np.ndarray) -> np.ndarray:
        """Isp [s] of pulses of on-time ``on_s`` (NaN or inf: steady), any shape."""
        u = np.asarray(on_s, float)
        inside = np.interp(u, self.on_time_s, self.isp_s)  # the first value below the table
        steady = ~np.isfinite(u) | (u > self.on_time_s[-1])
        return np.where(steady, self.steady_isp_s, inside)


@dataclass(frozen=True)
class PulseShape:
    """The pulse model of a vehicle's jets for ``n_runs`` runs (module docstring).

    Attributes
    ----------
    model : {"exponential", "linear", "table"}
    rise_s, tail_s : ndarray, (n_runs, n_jets)
        Rise and tail-off: time constants (exponential) or ramp lengths (linear) [s]; zero
        for a table.
    impulse : ImpulseTable or None
        The impulse-bit table (``model = "table"``).
    impulse_scale : ndarray, (n_runs, n_jets)
        Factor on every pulse's impulse bit of the table (dispersed; 1 nominal).
    isp : IspTable or None
        Pulse-mode Isp, any model.
    """

    model: str
    rise_s: np.ndarray
    tail_s: np.ndarray
    impulse: ImpulseTable | None = None
    impulse_scale: np.ndarray | None = None
    isp: IspTable | None = None

    def take(self, rows) -> PulseShape:
        """The shape of runs ``rows`` (indices into the runs, repeats allowed)."""
        rows = np.asarray(rows, int)
        scale = None if self.impulse_scale is None else self.impulse_scale[rows]
        return replace(
            self, rise_s=self.rise_s[rows], tail_s=self.tail_s[rows], impulse_scale=scale
        )

    def tail_length_s(self) -> np.ndarray:
        """How long thrust lasts after a valve closes at full thrust [s], (n_runs, n_jets)."""
        if self.model == "exponential":
            return TAIL_CUT * self.tail_s
        if self.model == "linear":
            return self.tail_s.copy()
        assert self.impulse is not None
        return np.full_like(self.rise_s, _table_excess(self))

    def thrust_time_s(self, on_s: np.ndarray) -> np.ndarray:
        """Full-thrust time ``I / F`` [s] of one isolated pulse of commanded on-time ``on_s``
        (n_runs, n_jets) [s]: the closed-form integral of the shape (tails included)."""
        on = np.asarray(on_s, float)
        if self.model == "table":
            assert self.impulse is not None
            scale = 1.0 if self.impulse_scale is None else self.impulse_scale
            return self.impulse.equivalent_s(on) * scale
        g = thrust_integral(self.model, 0.0, on, self.rise_s, self.tail_s, np.inf)
        return g

    def n_slots(self, cycle_s: float, delay_s: float) -> int:
        """Valve slots a flight needs (:class:`rcsim.spacecraft.valves.ValveState`): the
        firing in progress, the previous one's close latency, a spare, and one more for each
        cycle a tail or a table pulse outlasts its closing by (``delay_s``: the longest
        command-plus-close delay)."""
        extra = float(np.max(self.tail_length_s(), initial=0.0)) + delay_s
        return 3 + int(np.ceil(extra / cycle_s))


def _table_excess(shape: PulseShape) -> float:
    """Longest the equivalent square pulse of a table point outlasts its on-time [s]."""
    t = shape.impulse
    assert t is not None
    scale = 1.0 if shape.impulse_scale is None else float(np.max(shape.impulse_scale))
    return float(max(np.max(t.thrust_time_s * scale - t.on_time_s), 0.0))


def thrust_integral(
    model: str,
    start_s: ArrayLike,
    end_s: ArrayLike,
    rise_s: ArrayLike,
    tail_s: ArrayLike,
    t_s: ArrayLike,
) -> np.ndarray:
    """``G(t) = integral of f from start_s to t_s`` [s] of valve intervals ``[start_s, end_s]``
    (``end_s`` may be +inf: still open), the module docstring's shapes, all arrays
    broadcasting together.  ``G`` is 0 before the opening and constant once the tail is over;
    the impulse of a jet of thrust ``F`` over ``[t0, t1]`` is ``F (G(t1) - G(t0))``."""
    s = np.asarray(start_s, float)
    e = np.asarray(end_s, float)
    r = np.asarray(rise_s, float)
    tau = np.asarray(tail_s, float)
    t = np.asarray(t_s, float)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        x = np.clip(np.minimum(t, e) - s, 0.0, None)  # time open before t
        u = e - s  # open time (inf: still open)
        open_e = np.isfinite(e)
        if model == "exponential":
            rr = np.where(r > 0, r, 1.0)
            rising = np.where(r > 0, x + rr * np.expm1(-x / rr), x)
            peak = np.where(r > 0, -np.expm1(-np.where(open_e, u, 0.0) / rr), 1.0)
            tt = np.where(tau > 0, tau, 1.0)
            y = np.clip(t - e, 0.0, TAIL_CUT * tau)
            tail = np.where(tau > 0, -peak * tt * np.expm1(-y / tt), 0.0)
        elif model == "linear":
            rr = np.where(r > 0, r, 1.0)
            rising = np.where(r > 0, np.where(x <= rr, 0.5 * x * x / rr, 0.5 * rr + (x - rr)), x)
            peak = np.where(r > 0, np.minimum(np.where(open_e, u, 0.0) / rr, 1.0), 1.0)
            tt = np.where(tau > 0, tau, 1.0)
            y = np.clip(t - e, 0.0, peak * tau)
            tail = np.where(tau > 0, peak * y - 0.5 * y * y / tt, 0.0)
        else:
            raise ValueError(f"no thrust integral for pulse model {model!r}")
        tail = np.where(open_e & (t > e), tail, 0.0)
        return np.where(u > 0, rising + tail, 0.0)


def shaped_pieces(
    start_s: np.ndarray,
    end_s: np.ndarray,
    cycle_s: float,
    dt_s: float | None,
    shape: PulseShape,
    inv_isp: np.ndarray | None = None,
    stop_s: np.ndarray | None = None,
) -> Pieces:
    """:func:`rcsim.spacecraft.pieces.cycle_pieces` with the thrust of ``shape``: pieces cut
    at the valve's instants and the shape's knots, each piece's level the *mean* thrust
    fraction over it (:func:`thrust_integral`), so every piece's impulse is exact.

    Parameters
    ----------
    start_s, end_s : ndarray, (n_runs, n_jets, k)
        Valve intervals relative to the cycle's start [s] (NaN: empty; ``end`` +inf: open).
        For a table, the equivalent square pulses (:func:`table_intervals`).
    cycle_s, dt_s : float
        As :func:`~rcsim.spacecraft.pieces.cycle_pieces`.
    shape : PulseShape
    inv_isp : ndarray, (n_runs, n_jets, k), optional
        ``isp_s / Isp(u)`` of each interval (pulse-mode Isp); the pieces' ``flow`` then weighs
        each interval's thrust by it.

    Returns
    -------
    Pieces
        With ``level`` the mean thrust fraction of each jet in each piece (and ``flow``, the
        same weighted by ``inv_isp``, when given).
    stop_s : ndarray, (n_runs,), optional
        Every jet of the run gives no thrust from this instant of the cycle on [s] (inf:
        none): the propellant ran out, tails included.
    """
    with np.errstate(invalid="ignore"):
        # A run thrusts in this cycle when an interval opened before its end and its thrust
        # (tail included, at most the longest tail) lasts past its start.
        longest = np.max(shape.tail_length_s(), axis=1, initial=0.0)[:, None, None]
        active = ((end_s > start_s) & (start_s < cycle_s) & (end_s + longest > 0.0)).any(
            axis=(1, 2)
        )
    rows = np.flatnonzero(active)
    if rows.size == 0:  # nothing thrusts: the grid steps (no switch in them)
        return cycle_pieces(start_s, end_s, cycle_s, dt_s)
    if rows.size == start_s.shape[0]:
        return _shaped_rows(start_s, end_s, cycle_s, dt_s, shape, inv_isp, stop_s)
    cut = _shaped_rows(
        start_s[rows],
        end_s[rows],
        cycle_s,
        dt_s,
        shape.take(rows),
        None if inv_isp is None else inv_isp[rows],
        None if stop_s is None else stop_s[rows],
    )
    # The other runs fly the grid steps without thrust, padded as cycle_pieces pads them.
    n, jets = start_s.shape[:2]
    n_grid = 1 if dt_s is None or dt_s >= cycle_s else int(round(cycle_s / dt_s))
    width = max(cut.n_pieces, n_grid)
    length = np.zeros((n, width))
    length[:, :n_grid] = cycle_s if n_grid == 1 else dt_s
    count = np.full(n, n_grid)
    level = np.zeros((n, width, jets))
    length[rows] = 0.0
    length[rows, : cut.n_pieces] = cut.length_s
    count[rows] = cut.count
    assert cut.level is not None
    level[rows, : cut.n_pieces] = cut.level
    flow = None
    if cut.flow is not None:
        flow = np.zeros((n, width, jets))
        flow[rows, : cut.n_pieces] = cut.flow
    return Pieces(length, level > 0, count, uniform=False, level=level, flow=flow)


def _shaped_rows(
    start_s: np.ndarray,
    end_s: np.ndarray,
    cycle_s: float,
    dt_s: float | None,
    shape: PulseShape,
    inv_isp: np.ndarray | None,
    stop_s: np.ndarray | None = None,
) -> Pieces:
    """:func:`shaped_pieces` of the runs that thrust in the cycle."""
    n = start_s.shape[0]
    model = "linear" if shape.model == "table" else shape.model
    rise = np.zeros((n, start_s.shape[1])) if shape.model == "table" else shape.rise_s
    tail = np.zeros_like(rise) if shape.model == "table" else shape.tail_s
    r3, t3 = rise[..., None], tail[..., None]
    with np.errstate(invalid="ignore"):
        valid = end_s > start_s
        peak_tail = tail_len = np.zeros_like(start_s)
        if model == "exponential":
            tail_len = np.where(t3 > 0, TAIL_CUT * t3, 0.0) + 0 * start_s
        else:
            peak = np.where(r3 > 0, np.clip((end_s - start_s) / np.where(r3 > 0, r3, 1), 0, 1), 1)
            peak_tail = peak * t3
            tail_len = peak_tail
    tail_end = end_s + tail_len
    with np.errstate(invalid="ignore"):
        live = valid & (start_s < cycle_s) & (tail_end > 0.0)
    rise_knots, tail_knots = (
        (_EXP_RISE_KNOTS, _EXP_TAIL_KNOTS)
        if model == "exponential"
        else (_LINEAR_KNOTS, _LINEAR_KNOTS)
    )
    shaped = (r3 > 0) | (t3 > 0)
    up = start_s[..., None] + (r3 * np.ones_like(start_s))[..., None] * rise_knots
    if model == "exponential":
        down = end_s[..., None] + (t3 * np.ones_like(start_s))[..., None] * tail_knots
    else:
        down = end_s[..., None] + peak_tail[..., None] * tail_knots
    cuts = np.where((live & shaped)[..., None], np.concatenate([up, down], axis=-1), np.nan)
    cuts = cuts.reshape(n, -1)
    if stop_s is not None:
        cuts = np.concatenate([cuts, np.asarray(stop_s, float).reshape(n, 1)], axis=1)
    p = cycle_pieces(
        np.where(live, start_s, np.nan),
        np.where(live, tail_end, np.nan),
        cycle_s,
        dt_s,
        extra_cuts=cuts,
    )
    t1 = np.cumsum(p.length_s, axis=1)
    t0 = t1 - p.length_s
    if stop_s is not None:  # no thrust after it: the integral stops growing there
        stop = np.asarray(stop_s, float)[:, None]
        t1, t0 = np.minimum(t1, stop), np.minimum(t0, stop)
    s4, e4 = start_s[:, None], end_s[:, None]  # (n, 1, jets, k)
    r4, ta4 = rise[:, None, :, None], tail[:, None, :, None]
    g1 = thrust_integral(model, s4, e4, r4, ta4, t1[:, :, None, None])
    g0 = thrust_integral(model, s4, e4, r4, ta4, t0[:, :, None, None])
    part = np.where(live[:, None], np.nan_to_num(g1 - g0), 0.0)  # (n, pieces, jets, k)
    length = np.where(p.length_s > 0, p.length_s, 1.0)[:, :, None]
    level = np.minimum(part.sum(axis=-1) / length, 1.0)
    level = np.where(p.length_s[:, :, None] > 0, level, 0.0)
    flow = None
    if inv_isp is not None:
        weighted = (part * inv_isp[:, None]).sum(axis=-1) / length
        total = part.sum(axis=-1) / length
        # The cap on overlapping contributions scales the flow with the thrust.
        flow = np.where(total > 1.0, weighted / np.where(total > 0, total, 1.0), weighted)
        flow = np.where(p.length_s[:, :, None] > 0, flow, 0.0)
    # A jet is "on" (its on-time, runs.parquet's jet_NN_on_time_s) while its valve is open and
    # it thrusts: not over its tail after the valve closed, nor after the propellant ran out.
    # The pieces are cut at every valve edge, so a piece's middle tells its valve's state.
    mid = (np.cumsum(p.length_s, axis=1) - 0.5 * p.length_s)[:, :, None, None]  # (n, pieces, 1, 1)
    with np.errstate(invalid="ignore"):
        open_ = ((s4 <= mid) & (mid < e4) & live[:, None]).any(axis=-1)
    return Pieces(p.length_s, open_ & (level > 0), p.count, uniform=False, level=level, flow=flow)


def table_intervals(
    shape: PulseShape,
    start_s: np.ndarray,
    end_s: np.ndarray,
    new_start: np.ndarray,
    new_end: np.ndarray,
) -> None:
    """Turn the valve intervals the cycle's commands just opened or closed into the table's
    equivalent square pulses, in place (``start_s``, ``end_s`` (n_runs, n_jets, k) of the
    :class:`~rcsim.spacecraft.valves.ValveState`).

    ``new_start``: a slot opened this cycle; ``new_end``: its close was set this cycle.  A
    pulse opened and closed in the same cycle (on-time ``u = e - s`` known) ends at
    ``s + I(u) / F``.  A firing commanded over a whole cycle is at steady state: it loses the
    table's deficit ``u_m - I_m / F`` at its opening (a later start; a negative deficit, a
    surplus, is added at its closing instead), so it delivers ``I_m + F (u - u_m)``.
    """
    t = shape.impulse
    assert t is not None
    scale = 1.0 if shape.impulse_scale is None else shape.impulse_scale[..., None]
    short = new_start & new_end
    if short.any():
        u = end_s - start_s
        eq = t.equivalent_s(np.where(short, u, 0.0)) * scale
        end_s[short] = np.broadcast_to(start_s + eq, end_s.shape)[short]
        empty = short & ~(np.broadcast_to(eq, end_s.shape) > 0)
        start_s[empty] = np.nan
        end_s[empty] = np.nan
    # A dispersed impulse bit scales the table's impulse, the steady pulse's last point too.
    deficit = np.broadcast_to(t.on_time_s[-1] - t.thrust_time_s[-1] * scale, end_s.shape)
    opened = new_start & ~new_end & (deficit > 0)  # a full-cycle firing: steady state
    start_s[opened] += deficit[opened]
    closing = ~new_start & new_end & (deficit < 0)  # its close, commanded this cycle
    end_s[closing] -= deficit[closing]


def propellant_instant(
    shape: PulseShape,
    start_s: np.ndarray,
    end_s: np.ndarray,
    flow_kg_s: np.ndarray,
    left_kg: np.ndarray,
    cycle_s: float,
    inv_isp: np.ndarray | None = None,
) -> np.ndarray:
    """The instant of the cycle [s] at which runs' jets have used ``left_kg`` (n,), from the
    shapes' integrals: ``sum_j flow_j sum_i w_i (G_i(t) - G_i(0)) = left`` solved by bisection
    to the last bit (the left side grows with ``t``); inf where the cycle uses less.

    ``start_s``, ``end_s`` (n, n_jets, k) as :func:`shaped_pieces`'; ``flow_kg_s`` (n, n_jets)
    each jet's steady flow at full thrust; ``inv_isp`` (n, n_jets, k) the intervals' Isp
    weights (None: 1).  Overlapping intervals count in full (no cap at full thrust)."""
    model = "linear" if shape.model == "table" else shape.model
    n = start_s.shape[0]
    zeros = np.zeros(start_s.shape[:2])
    rise = (zeros if shape.model == "table" else shape.rise_s)[..., None]
    tail = (zeros if shape.model == "table" else shape.tail_s)[..., None]
    weight = 1.0 if inv_isp is None else inv_isp

    def used(t: np.ndarray) -> np.ndarray:
        g = thrust_integral(model, start_s, end_s, rise, tail, t[:, None, None])
        g0 = thrust_integral(model, start_s, end_s, rise, tail, np.zeros((n, 1, 1)))
        part = np.nan_to_num((g - g0) * weight).sum(axis=-1)
        return (part * flow_kg_s).sum(axis=-1)

    lo, hi = np.zeros(n), np.full(n, float(cycle_s))
    crosses = used(hi) >= left_kg
    for _ in range(64):  # halves [0, cycle] to below a bit of any instant in it
        mid = 0.5 * (lo + hi)
        over = used(mid) >= left_kg
        hi = np.where(over, mid, hi)
        lo = np.where(over, lo, mid)
    return np.where(crosses, hi, np.inf)
