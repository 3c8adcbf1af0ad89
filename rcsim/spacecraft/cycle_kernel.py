"""The closed loop's per-cycle bookkeeping in a few compiled passes (``_cycle_kernel.c``).

Each control cycle :meth:`rcsim.spacecraft.simulation.BatchSimulation.run` navigates, applies the
valve limits, commands the valves, checks whether any run switches a jet inside the cycle,
adds up the delivered on-time and impulse, and shifts the valves' pending intervals.  In numpy
that is some sixty calls on ``(n_runs, n_jets)`` arrays per cycle, each a few microseconds
whatever the run count (``docs/performance.md``).  The optional extension does the same
arithmetic in the same order, element by element; its results are the numpy forms' bit for bit
(``tests/spacecraft/test_cycle_kernel.py``).  The numpy forms (:func:`rcsim.spacecraft.navigation.
navigate`, :func:`rcsim.spacecraft.propulsion.apply_valve_limits`, :func:`rcsim.spacecraft.valves.
command_valves`, :func:`rcsim.spacecraft.pieces.cycle_pieces`,
:func:`rcsim.spacecraft.valves.end_cycle`) stay the reference and run whenever the extension was not
built (no C compiler at install) or ``RCSIM_NUMPY_CYCLE=1`` is set.

Two more passes read a finished flight's cycle-major on-time record in place for a campaign
chunk's tables (:func:`group_on_time`, :func:`group_firings`); their numpy forms are in
:mod:`rcsim.analysis.engine.campaign.chunk` and :mod:`rcsim.analysis.engine.campaign.outcomes`,
under the same switch.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rcsim.spacecraft.navigation import NavState
from rcsim.spacecraft.optional_kernel import optional_kernel
from rcsim.spacecraft.propulsion import PropulsionParams, PropulsionState
from rcsim.spacecraft.valves import ValveState, ValveTiming

_KERNEL = optional_kernel("rcsim.spacecraft._cycle_kernel", "RCSIM_NUMPY_CYCLE")
#: The compiled module (None when built without a C compiler: the numpy forms run).
_cycle_kernel: Any = _KERNEL.module  # its functions are called only when available()


def kernel_available() -> bool:
    """Whether the compiled passes are built and not switched off by ``RCSIM_NUMPY_CYCLE``."""
    return _KERNEL.available()


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def navigate(
    t_s: float, q_BN: np.ndarray, omega_B: np.ndarray, q_cmd_BN: np.ndarray, omega_cmd_B: np.ndarray
) -> NavState:
    """:func:`rcsim.spacecraft.navigation.navigate` against a given command ``(q_cmd_BN,
    omega_cmd_B)`` (one row per run, or one row for all), bit for bit.

    The three-square norm and arctan2 are numpy's own (see ``_cycle_kernel.c``)."""
    n = q_BN.shape[0]
    q_cmd, omega_cmd = _f64(q_cmd_BN), _f64(omega_cmd_B)
    if q_cmd.shape[0] not in (1, n) or omega_cmd.shape[0] not in (1, n):  # as numpy broadcasts
        raise ValueError(f"commands for {q_cmd.shape[0]}, {omega_cmd.shape[0]} runs, not {n}")
    w = np.empty(n)
    vec = np.empty((n, 3))
    _cycle_kernel.nav_product(n, 4 if q_cmd.shape[0] == n else 0, _f64(q_BN), q_cmd, w, vec)
    s = np.sqrt(np.einsum("...i,...i->...", vec, vec))  # navigation._norm, numpy's order
    half = np.arctan2(s, w)
    att = np.empty((n, 3))
    rate = np.empty((n, 3))
    omega = _f64(omega_B)
    _cycle_kernel.nav_finish(
        n, 3 if omega_cmd.shape[0] == n else 0, half, s, vec, omega, omega_cmd, att, rate
    )
    return NavState(t_s, q_BN, omega_B, att, rate, omega_cmd_B)


def command_valves(
    command: np.ndarray,
    failed: np.ndarray,
    prop: PropulsionState,
    params: PropulsionParams,
    valves: ValveState,
    timing: ValveTiming,
) -> np.ndarray:
    """Failed runs command nothing, then :func:`rcsim.spacecraft.propulsion.apply_valve_limits`
    (``account=False``) and :func:`rcsim.spacecraft.valves.command_valves`, in place on ``prop`` and
    ``valves``; returns the on-times the valves deliver (n_runs, n_jets) [s]."""
    n, n_jets = prop.firings.shape
    on = np.empty((n, n_jets))
    for name in ("on_at_end", "firings", "dropped"):  # in place needs the kernel's layout
        _require_contiguous(getattr(prop, name), name)
    for name in ("start", "end", "was_on"):
        _require_contiguous(getattr(valves, name), name)
    ok = _cycle_kernel.valves(
        n,
        n_jets,
        valves.start.shape[-1],
        _f64(command),
        np.ascontiguousarray(failed, np.bool_).view(np.uint8),
        prop.on_at_end.view(np.uint8),
        prop.firings,
        prop.dropped,
        valves.was_on.view(np.uint8),
        valves.start,
        valves.end,
        _f64(timing.command_delay_s),
        _f64(timing.open_delay_s),
        _f64(timing.close_delay_s),
        on,
        float(params.min_pulse_s),
        float(params.cycle_s),
    )
    if not ok:  # pragma: no cover - excluded by ValveTiming.check
        raise AssertionError("no free valve slot: delays longer than a cycle")
    return on


def uniform_on(start_s: np.ndarray, end_s: np.ndarray, cycle_s: float) -> np.ndarray | None:
    """Which jets are on over the whole cycle, (n_runs, n_jets) bool, when no run switches a
    jet inside it (:func:`rcsim.spacecraft.pieces.cycle_pieces`' first test); None when some run
    does (the caller cuts the cycle)."""
    n, n_jets, slots = start_s.shape
    on = np.empty((n, n_jets), np.bool_)
    if _cycle_kernel.uniform_on(
        n, n_jets, slots, _f64(start_s), _f64(end_s), on.view(np.uint8), float(cycle_s)
    ):
        return on
    return None


def account(
    on: np.ndarray, length_s: float, thrust_n: np.ndarray, prop: PropulsionState
) -> np.ndarray:
    """Delivered on-time of a one-piece cycle of ``length_s`` (``Pieces.on_time_s``), added
    with its impulse to ``prop``; returns it (n_runs, n_jets) [s]."""
    delivered = np.empty(on.shape)
    _require_contiguous(prop.on_time_s, "on_time_s")
    _require_contiguous(prop.impulse_ns, "impulse_ns")
    _cycle_kernel.account(
        on.size,
        np.ascontiguousarray(on, np.bool_).view(np.uint8),
        _f64(np.broadcast_to(thrust_n, on.shape)),
        prop.on_time_s,
        prop.impulse_ns,
        delivered,
        float(length_s),
    )
    return delivered


def end_cycle(valves: ValveState, cycle_s: float, tail_s: float = 0.0) -> None:
    """:func:`rcsim.spacecraft.valves.end_cycle`, in place."""
    _cycle_kernel.end_cycle(valves.start.size, valves.start, valves.end, float(cycle_s), tail_s)


def bounded_state(state: np.ndarray, qpos: np.ndarray, qvel: np.ndarray) -> bool:
    """Whether every entry of ``qpos`` and ``qvel`` (live column blocks of the batch's state
    rows ``state``, (n_runs, row_len)) is finite and below 1e300 in magnitude: then every
    run's sum of them is finite, the numpy form's test passes for all, and it can be skipped."""
    if not state.flags.c_contiguous:  # pragma: no cover - MuJoCo's state rows are
        return False
    base = state.__array_interface__["data"][0]

    def column(field: np.ndarray) -> int:
        if field.strides[0] != state.strides[0] or field.strides[-1] != state.itemsize:
            raise AssertionError("not a column block of the state rows")  # pragma: no cover
        return (field.__array_interface__["data"][0] - base) // state.itemsize

    return _cycle_kernel.bounded_state(
        state.shape[0],
        state.shape[1],
        state,
        column(qpos),
        qpos.shape[1],
        column(qvel),
        qvel.shape[1],
    )


def group_on_time(
    record: np.ndarray, runs: np.ndarray, groups: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per cycle, each jet group's on-time summed over ``runs`` and the number of those runs
    firing a jet of the group, read in place from a flight's cycle-major on-time record.

    Bit for bit the numpy form of :func:`rcsim.analysis.engine.campaign.chunk.envelope` (its
    summation order is reproduced: ``_cycle_kernel.c``).

    Parameters
    ----------
    record : ndarray, (n_cycles, n_runs_total, n_jets)
        [s] (``History.on_time_s.swapaxes(0, 1)`` of a flight: C-contiguous float64, read in
        place; anything else is copied first).
    runs : ndarray of int, (n,)
        The runs summed, in order.
    groups : ndarray of bool, (n_groups, n_jets)

    Returns
    -------
    sums : ndarray, (n_groups, n_cycles) [s]
    firing : ndarray of int64, (n_groups, n_cycles)
    """
    n_cycles, n_total, n_jets = record.shape
    record = _f64(record)  # read only; a copy if not C-contiguous float64
    runs = np.ascontiguousarray(runs, dtype=np.int64)
    if runs.size and (runs.min() < 0 or runs.max() >= n_total):
        raise IndexError(f"run indices outside 0..{n_total - 1}")
    groups = np.ascontiguousarray(groups, dtype=np.bool_).reshape(-1, n_jets)
    sums = np.empty((groups.shape[0], n_cycles))
    firing = np.empty((groups.shape[0], n_cycles), np.int64)
    _cycle_kernel.group_on_time(
        n_cycles,
        n_total,
        n_jets,
        runs.size,
        groups.shape[0],
        record,
        runs,
        groups.view(np.uint8),
        sums,
        firing,
    )
    return sums, firing


def group_firings(
    record: np.ndarray, groups: np.ndarray, full_at_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per cycle, run and jet group: some jet of the group starts a firing (on, and not on for
    a whole previous cycle: ``>= full_at_s``), and some jet goes on firing (on a whole previous
    cycle and on again), read in place from a flight's cycle-major on-time record.

    The rule of :func:`rcsim.analysis.engine.campaign.outcomes.axis_firings` (booleans, exact).

    Parameters
    ----------
    record : ndarray, (n_cycles, n_runs, n_jets)
        [s] (C-contiguous float64 is read in place; anything else is copied first).
    groups : ndarray of bool, (n_groups, n_jets)
    full_at_s : float
        On-time that fills a cycle [s].

    Returns
    -------
    starts : ndarray of bool, (n_cycles, n_runs, n_groups)
    going_on : ndarray of bool, (n_cycles - 1, n_runs, n_groups)
    """
    n_cycles, n_runs, n_jets = record.shape
    record = _f64(record)  # read only; a copy if not C-contiguous float64
    groups = np.ascontiguousarray(groups, dtype=np.bool_).reshape(-1, n_jets)
    starts = np.empty((n_cycles, n_runs, groups.shape[0]), np.bool_)
    going_on = np.empty((max(n_cycles - 1, 0), n_runs, groups.shape[0]), np.bool_)
    _cycle_kernel.group_firings(
        n_cycles,
        n_runs,
        n_jets,
        groups.shape[0],
        record,
        groups.view(np.uint8),
        starts.view(np.uint8),
        going_on.view(np.uint8),
        float(full_at_s),
    )
    return starts, going_on


def _require_contiguous(a: np.ndarray, name: str) -> None:
    if not a.flags.c_contiguous or not a.flags.writeable:  # pragma: no cover - built so
        raise AssertionError(f"{name} must be a writable C-contiguous array")


__all__ = [
    "account",
    "bounded_state",
    "command_valves",
    "end_cycle",
    "group_firings",
    "group_on_time",
    "kernel_available",
    "navigate",
    "uniform_on",
]
