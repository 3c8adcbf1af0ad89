"""A control cycle cut at every jet switch: piece lengths and which jets are on in each piece.

Within one control cycle each jet is on over a few intervals (a commanded firing, the tail of
the previous cycle's firing when the valve closes late, a stuck-on window).  Integrating the
cycle in pieces whose boundaries are all those switch instants -- per run, each run at its own
instants -- keeps every jet constant inside every piece, so the physics sees the exact force
history: impulse *and* attitude are exact for any pulse length, not only the impulse (a duty
spread over a whole step shifts the attitude by ``alpha t (T - t) / 2`` per pulse;
``docs/convergence.md``).

The model's physics step ``dt`` stays a ceiling: when ``dt`` is shorter than the cycle, the grid
points ``k dt`` are boundaries too, so a cycle without switches is integrated in exactly the
steps of a plain fixed-step rollout (bit for bit).

Imports nothing of rcsim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Pieces:
    """The pieces of one control cycle for ``n_runs`` runs (padded to the longest run).

    Attributes
    ----------
    length_s : ndarray, (n_runs, n_pieces)
        Duration of each piece [s]; a run's pieces come first, then zero-length padding.
    on : ndarray of bool, (n_runs, n_pieces, n_jets)
        Jet on during the piece.
    count : ndarray of int, (n_runs,)
        Number of pieces of each run (nonzero lengths).
    uniform : bool
        No switch inside any grid step: every run's pieces are the fixed physics steps.
    level : ndarray, (n_runs, n_pieces, n_jets), or None
        Thrust fraction of each jet in each piece, when a thrust profile applies
        (:func:`profile_pieces`); None: full thrust wherever ``on``.
    flow : ndarray, (n_runs, n_pieces, n_jets), or None
        Propellant flow of each jet in each piece, as a fraction of its steady flow at full
        thrust, when it is not ``level`` (a pulse-mode Isp,
        :func:`rcsim.spacecraft.pulse_shape.shaped_pieces`); None: ``level``.
    """

    length_s: np.ndarray
    on: np.ndarray
    count: np.ndarray
    uniform: bool = False
    level: np.ndarray | None = None
    flow: np.ndarray | None = None

    @property
    def n_pieces(self) -> int:
        return int(self.length_s.shape[1])

    def on_time_s(self) -> np.ndarray:
        """Time each jet is on during the cycle [s], shape (n_runs, n_jets)."""
        return np.einsum("rp,rpj->rj", self.length_s, self.on)

    def thrust_time_s(self) -> np.ndarray:
        """Impulse of each jet over its full thrust [s] (= on-time without a profile)."""
        if self.level is None:
            return self.on_time_s()
        return np.einsum("rp,rpj->rj", self.length_s, self.level)

    def flow_time_s(self) -> np.ndarray:
        """Propellant of each jet over its steady flow at full thrust [s] (= the thrust
        time without a pulse-mode Isp)."""
        if self.flow is None:
            return self.thrust_time_s()
        return np.einsum("rp,rpj->rj", self.length_s, self.flow)

    def flow_fraction(self) -> np.ndarray:
        """Flow of each jet in each piece over its steady full-thrust flow, (n_runs,
        n_pieces, n_jets)."""
        if self.flow is not None:
            return self.flow
        return self.on if self.level is None else self.level

    def control(self) -> np.ndarray:
        """Actuator control of each jet in each piece, (n_runs, n_pieces, n_jets) in [0, 1]."""
        return self.on if self.level is None else self.level


def any_last(a: np.ndarray) -> np.ndarray:
    """``a.any(axis=-1)`` of a bool array whose last axis is short (a jet's few intervals).

    numpy reduces over a short inner axis slowly: ~90 us for (512, 16, 3), most of a cycle's
    cutting; or-ing the slices takes ~7 us, with the same result.
    """
    if a.shape[-1] == 0:
        return np.zeros(a.shape[:-1], bool)
    out = a[..., 0].copy()
    for i in range(1, a.shape[-1]):  # the intervals of a jet (1-3), not runs
        out |= a[..., i]
    return out


def cycle_pieces(
    start_s: np.ndarray,
    end_s: np.ndarray,
    cycle_s: float,
    dt_s: float | None = None,
    extra_cuts: np.ndarray | None = None,
) -> Pieces:
    """Cut one control cycle at every switch instant of every jet, per run.

    Parameters
    ----------
    start_s, end_s : ndarray, (n_runs, n_jets, k)
        On-intervals of each jet, relative to the cycle's start [s]; ``k`` intervals per jet
        (they may overlap: the jet is on in their union).  Bounds outside ``[0, cycle_s]`` are
        clipped; an interval with ``end <= start`` (or NaN) is empty.
    cycle_s : float
        Control cycle [s].
    dt_s : float, optional
        Longest piece [s] (the model's physics step); the grid ``k dt_s`` is added to the
        boundaries.  None or ``>= cycle_s``: no grid.
    extra_cuts : ndarray, (n_runs, m), optional
        More boundaries [s] (NaN or outside the cycle: ignored); giving them forces the cut.

    Returns
    -------
    Pieces
        Pieces of length exactly ``dt_s`` (or ``cycle_s``) wherever no switch falls inside a
        grid step, so switch-free cycles reproduce a fixed-step rollout bit for bit.
    """
    n = start_s.shape[0]
    # Live: overlaps the cycle (NaN compares False).  Checked on the raw bounds first: in most
    # cycles most runs have no switch inside, and this is the closed loop's per-cycle overhead.
    live = (end_s > start_s) & (start_s < cycle_s) & (end_s > 0.0)
    n_grid = 1 if dt_s is None or dt_s >= cycle_s else int(round(cycle_s / dt_s))
    step = cycle_s if n_grid == 1 else dt_s
    if extra_cuts is None:
        # A run switches inside the cycle when one of its live intervals starts after the
        # cycle's start or ends before its end; the others fly the grid steps themselves.
        switching = (live & ((start_s > 0.0) | (end_s < cycle_s))).any(axis=(1, 2))
    else:  # given cuts force every run through the cut
        switching = np.ones(n, bool)
    rows = np.flatnonzero(switching)
    if rows.size == 0:  # every interval empty or the whole cycle: the grid steps themselves
        on = np.broadcast_to(any_last(live)[:, None, :], (n, n_grid, live.shape[1]))
        return Pieces(np.full((n, n_grid), step), on, np.full(n, n_grid), uniform=True)
    cut = _cut(
        start_s[rows],
        end_s[rows],
        live[rows],
        cycle_s,
        n_grid,
        dt_s,
        None if extra_cuts is None else np.asarray(extra_cuts, float)[rows],
    )
    if rows.size == n:
        return cut
    # Runs without a switch: their grid steps (what the cut gives them, bit for bit), padded
    # with zero-length pieces to the longest run's count.
    width = max(cut.n_pieces, n_grid)
    length = np.zeros((n, width))
    on = np.zeros((n, width, live.shape[1]), bool)
    count = np.full(n, n_grid)
    length[:, :n_grid] = step
    on[:, :n_grid] = any_last(live)[:, None, :]
    length[rows] = 0.0
    on[rows] = False
    length[rows, : cut.n_pieces] = cut.length_s
    on[rows, : cut.n_pieces] = cut.on
    count[rows] = cut.count
    return Pieces(length, on, count, uniform=False)


def _cut(
    start_s: np.ndarray,
    end_s: np.ndarray,
    live: np.ndarray,
    cycle_s: float,
    n_grid: int,
    dt_s: float | None,
    extra_cuts: np.ndarray | None,
) -> Pieces:
    """:func:`cycle_pieces` of runs that switch inside the cycle: boundaries at every switch
    instant and grid point, sorted per run."""
    n = start_s.shape[0]
    s = np.where(live, np.clip(start_s, 0.0, cycle_s), 0.0)
    e = np.where(live, np.clip(end_s, 0.0, cycle_s), 0.0)
    grid = np.arange(n_grid + 1) * (cycle_s / n_grid)
    grid[-1] = cycle_s
    parts = [s.reshape(n, -1), e.reshape(n, -1), np.broadcast_to(grid, (n, grid.size))]
    if extra_cuts is not None:
        cuts = extra_cuts.reshape(n, -1)
        parts.append(np.where(np.isfinite(cuts), np.clip(cuts, 0.0, cycle_s), 0.0))
    inner = np.concatenate(parts, axis=1)
    bounds = np.sort(inner, axis=1)
    length = np.diff(bounds, axis=1)
    if n_grid > 1 and dt_s is not None:
        # Grid steps cut by no switch: exactly dt (k dt - (k-1) dt can be an ulp off).
        length = np.where(np.abs(length - dt_s) <= 1e-12 * dt_s, dt_s, length)
    nonzero = length > 0.0
    count = nonzero.sum(axis=1)
    order = np.argsort(~nonzero, axis=1, kind="stable")[:, : int(count.max())]
    length = np.take_along_axis(np.where(nonzero, length, 0.0), order, axis=1)
    t0 = np.take_along_axis(bounds[:, :-1], order, axis=1)
    mid = (t0 + 0.5 * length)[:, :, None, None]  # (n, p, 1, 1) vs intervals (n, 1, jets, k)
    on = any_last((s[:, None] <= mid) & (mid < e[:, None]) & live[:, None])
    on &= (length > 0.0)[:, :, None]
    return Pieces(length, on, count, uniform=False)


def profile_pieces(
    start_s: np.ndarray,
    end_s: np.ndarray,
    cycle_s: float,
    dt_s: float | None,
    rise_s: float,
    fall_s: float,
    segments: int,
) -> Pieces:
    """:func:`cycle_pieces` with the thrust transients of
    :class:`rcsim.spacecraft.valves.ThrustProfile`.

    A jet whose valve opens at ``s`` and closes at ``e`` thrusts ``min((t - s) / rise_s, 1)``
    of its thrust while open, then decays linearly at ``1 / fall_s`` per second from the level
    it reached at ``e`` to zero.  Each ramp is cut into ``segments`` pieces (plus any switch of
    another jet), and a piece's level is the ramp's value at the piece's midpoint: the mean of
    a linear ramp over the piece, so the impulse is exact; the attitude is exact to the
    piecewise-constant approximation of the ramps (second order in ``ramp / segments``).
    Overlapping intervals add, up to full thrust.  ``start_s``/``end_s`` as in
    :func:`cycle_pieces` (relative to the cycle, NaN: empty, ``end`` may be +inf).
    """
    with np.errstate(invalid="ignore"):
        valid = end_s > start_s
    peak = np.where(
        valid, np.clip((end_s - start_s) / rise_s, 0.0, 1.0) if rise_s > 0 else 1.0, 0.0
    )
    peak = np.where(np.isnan(peak), 0.0, peak)
    tail_end = end_s + peak * fall_s  # thrust reaches zero
    live = valid & (start_s < cycle_s) & (tail_end > 0.0)
    ramping = live & ((start_s + rise_s > 0.0) | (end_s < cycle_s))
    if not ramping.any():
        return cycle_pieces(start_s, end_s, cycle_s, dt_s)
    k = np.arange(segments + 1) / segments  # k = 0 keeps the valve's own switch instants
    up = start_s[..., None] + rise_s * k  # (n, jets, slots, segments)
    down = end_s[..., None] + (peak * fall_s)[..., None] * k
    cuts = np.where(ramping[..., None], np.concatenate([up, down], axis=-1), np.nan)
    s = np.where(live, start_s, np.nan)
    p = cycle_pieces(
        s,
        np.where(live, tail_end, np.nan),
        cycle_s,
        dt_s,
        extra_cuts=cuts.reshape(start_s.shape[0], -1),
    )
    t0 = np.concatenate(
        [np.zeros((p.length_s.shape[0], 1)), np.cumsum(p.length_s, axis=1)[:, :-1]], axis=1
    )
    mid = (t0 + 0.5 * p.length_s)[:, :, None, None]  # (n, pieces, 1, 1)
    s4, e4, pk4 = (a[:, None] for a in (start_s, end_s, peak))  # (n, 1, jets, slots)
    with np.errstate(invalid="ignore"):
        rising = np.clip((mid - s4) / rise_s, 0.0, 1.0) if rise_s > 0 else np.ones_like(mid - s4)
        opening = (mid >= s4) & (mid < e4)
        decay = (
            np.clip(pk4 - (mid - e4) / fall_s, 0.0, None) if fall_s > 0 else np.zeros_like(mid - e4)
        )
        closed = mid >= e4
    level = np.where(opening, rising, 0.0) + np.where(closed & live[:, None], decay, 0.0)
    level = np.minimum(np.nan_to_num(level).sum(axis=-1), 1.0)
    level = np.where(p.length_s[:, :, None] > 0, level, 0.0)
    return Pieces(p.length_s, level > 0, p.count, uniform=False, level=level)
