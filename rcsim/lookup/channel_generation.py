"""Generate a channel lookup table for a vehicle whose jets torque several axes (sec. II, sec. IV).

The paper's rule (:mod:`rcsim.lookup.table_generation`) carried over to the six axis channels of
:mod:`rcsim.lookup.channels`: for each of the 26 rate cases (Table 3) the nominal vehicle of the
file is flown from rest, and the table keeps, per commanded axis, the whole number of 40 ms cycles
of its channel whose *measured* end rate is nearest the command.  No mass property enters the
choice: the rates are read from the simulation (the recipes themselves come from the nominal
jet model, as the allocator's do).

Two steps, because shared jets stretch a firing over more cycles (:class:`ChannelMap` scales a
cycle whose channels ask a jet for more than the cycle, and counts a channel down by the time
it delivered):

1. *Firing loop* (the paper's): every commanded channel fires each cycle until its axis's
   measured rate reaches or passes the command.  The channel time delivered by the crossing,
   and the cycle before, bracket the time that reaches the command; the whole cycles between
   them (``floor`` of the one to ``ceil`` of the other: the paper's two candidates when nothing
   is shared) are the axis's candidates.
2. *Candidates flown*: every combination of the commanded axes' candidates is flown open loop
   (each channel fires its time from t = 0 through the delivery, as the lookup controller
   fires a table row) and watched for ``settle_window_s`` more; the combination whose final
   rate error (all three axes, squared) is least is the row.  That flight is the table's
   verification too (end rate error, settling time after the firing, translation).

3. *Nominal check and tuning* (:mod:`rcsim.lookup.row_tuning`, as for a jet table): each case
   flown closed loop under the lookup controller with the table; a row that leaves an axis
   farther than the target from its command is replaced by a neighbouring whole-cycle row
   that meets it (then flown open loop again as its verification), or the case is named.

Rate damping (Figs 3-4) is checked the same way: from each case's rate with a zero command,
the cycles found must be the command's on the opposing channels.

Valve timing (the vehicle file's delays) is flown in both steps.  The firing loop's cycle-end
rates then lag what a row delivers by the command delay plus the closing latency, less than a
cycle (:mod:`rcsim.lookup.table_candidates`), so each axis's candidates gain the whole cycle below
the bracket.

Imports ``models``, ``spacecraft`` and ``lookup`` only.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import numpy as np

from rcsim.lookup.channels import ChannelMap, solve_recipe
from rcsim.lookup.row_tuning import (
    DEFAULT_ROUNDS,
    DEFAULT_TARGET_FRACTION,
    RowTuner,
    check_target_fraction,
    cycle_steps,
    vehicle_threshold_deg_s,
)
from rcsim.lookup.table_generation import (
    FiringSweep,
    GeneratedTable,
    settle_after_firing,
)
from rcsim.models.tables import (
    CHANNEL_COLUMNS,
    CHANNEL_MAP,
    ChannelRecipe,
    LookupTable,
    RateCases,
    check_consistency,
    rate_cases_at,
)
from rcsim.spacecraft.navigation import Guidance, NavState
from rcsim.spacecraft.simulation import History, simulate_batch
from rcsim.spacecraft.vehicle.model import AXES, jet_geometry_B

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle

#: "A whole number of cycles" when bracketing delivered channel time [cycles].
_CYCLE_EPS = 1e-9
#: A cycle delivers at least a third of a channel's share (three channels, fractions <= 1), so
#: every row has ended by this many times its longest channel.
_STRETCH = 3.0


def channel_of(axis: int, sign: int) -> int:
    """Column of the channel turning ``axis`` (0..2) the ``sign`` (+1/-1) way."""
    return 2 * axis + (0 if sign > 0 else 1)


class ChannelFiringLoop:
    """Fire each commanded axis's channel every cycle until its rate reaches the command.

    Per run and axis the direction is fixed at the first cycle, ``d = -sign(rate error)``; the
    axis's channel of that sign fires (asks for a whole cycle, delivered through the recipe)
    while ``d * rate_error < 0`` and stops for good at the first cycle that starts at or past
    the command.  Axes whose channel is unserved (an empty recipe) do not fire.
    """

    def __init__(self, channel_map: ChannelMap, served: np.ndarray):
        self.map = channel_map
        self.served = np.asarray(served, bool)
        self.cycle_s = channel_map.cycle_s

    def initial_state(self, n_runs: int):
        return {"direction": None, "done": np.zeros((n_runs, 3), bool), "valves": None}

    def firing(self, direction: np.ndarray, done: np.ndarray) -> np.ndarray:
        """(n, 6) channel on-request: a cycle on each firing channel (more than a cycle of
        remaining time, so that the delivery treats it as continuing)."""
        fire = np.where(done, 0, direction)
        rem = np.zeros((fire.shape[0], len(CHANNEL_COLUMNS)))
        rem[:, 0::2] = fire > 0
        rem[:, 1::2] = fire < 0
        return rem * self.served[None, :] * 2.0 * self.cycle_s

    def step(self, nav: NavState, state):
        err = nav.rate_err_B
        direction = -np.sign(err) if state["direction"] is None else state["direction"]
        valves = self.map.initial(err.shape[0]) if state["valves"] is None else state["valves"]
        done = state["done"] | (direction * err >= 0)
        on, _, valves = self.map.deliver(self.firing(direction, done), valves)
        return on, {"direction": direction, "done": done, "valves": valves}


class ChannelOpenLoop:
    """Fire channel ``k`` of run ``i`` for ``total_s[i, k]`` seconds of channel time from
    t = 0, through the delivery, no feedback (a table row as the lookup controller fires it
    from rest)."""

    def __init__(self, total_s: np.ndarray, channel_map: ChannelMap):
        self.total_s = np.asarray(total_s, float)
        self.map = channel_map
        self.cycle_s = channel_map.cycle_s

    def initial_state(self, n_runs: int):
        return self.total_s.copy(), self.map.initial(n_runs)

    def step(self, nav: NavState, state):
        rem, valves = state
        on, delivered, valves = self.map.deliver(rem, valves)
        rem = rem - delivered
        return on, (np.where(rem > 1e-9, rem, 0.0), valves)


def _candidates(
    hist: History,
    channel_map: ChannelMap,
    served: np.ndarray,
    loop: ChannelFiringLoop,
    delayed: bool = False,
) -> tuple[list, np.ndarray]:
    """Per run, per axis, the whole-cycle channel times bracketing the crossing (step 1);
    ``delayed`` (the vehicle has valve timing): one cycle below the bracket too.

    Returns ``(cands, direction)``: ``cands[i][a]`` a list of cycle counts (``[0]`` on an axis
    that does not fire), ``direction`` (n, 3).
    """
    cyc = channel_map.cycle_s
    err = np.concatenate([hist.rate_err_B, hist.final.rate_err_B[:, None]], axis=1)
    n, k1, _ = err.shape
    direction = -np.sign(err[:, 0]).astype(int)
    reached = direction[:, None, :] * err >= 0  # (n, K+1, 3)
    served_dir = np.stack(
        [
            np.where(direction[:, a] > 0, served[2 * a], served[2 * a + 1]) & (direction[:, a] != 0)
            for a in range(3)
        ],
        axis=1,
    )
    never = served_dir & ~reached.any(axis=1)
    if never.any():
        run, axis = np.argwhere(never)[0]
        raise ValueError(
            f"run {run}: {AXES[axis]} rate not reached within the firing loop's "
            f"{hist.t_s[-1] + cyc:g} s; raise max_fire_s"
        )
    k_cross = np.argmax(reached, axis=1)  # (n, 3)
    # Replay the loop's requests and the delivery's scale: channel time delivered per cycle.
    done = np.cumsum(reached, axis=1)[:, :-1] > 0  # (n, K, 3): done at the start of cycle k
    delivered = np.zeros((n, k1 - 1, 3))
    for k in range(k1 - 1):  # cycles of a short flight, post-processing
        request = loop.firing(direction, done[:, k])
        on = np.minimum(request, cyc)
        peak = (on @ channel_map.fractions).max(axis=1)
        scale = np.where(peak > cyc, cyc / np.where(peak > 0, peak, 1.0), 1.0)
        ch = on * scale[:, None]
        delivered[:, k] = ch[:, 0::2] + ch[:, 1::2]
    total = np.concatenate([np.zeros((n, 1, 3)), np.cumsum(delivered, axis=1)], axis=1)
    cands = []
    for i in range(n):  # 26 cases
        per_axis = []
        for a in range(3):
            if not served_dir[i, a]:
                per_axis.append([0])
                continue
            kc = k_cross[i, a]
            lo = int(np.floor(total[i, max(kc - 1, 0), a] / cyc + _CYCLE_EPS)) - int(delayed)
            hi = int(np.ceil(total[i, kc, a] / cyc - _CYCLE_EPS))
            per_axis.append(list(range(max(lo, 1), max(hi, 1) + 1)))
        cands.append(per_axis)
    return cands, direction


def channel_row_times(cycles: np.ndarray, direction: np.ndarray, cycle_s: float) -> np.ndarray:
    """Channel times (m, 6) [s] of rows firing ``cycles`` (m, 3) whole cycles on each axis's
    channel of sign ``direction`` (m, 3) (0: none)."""
    cycles = np.asarray(cycles, int)
    direction = np.asarray(direction, int)
    times = np.zeros((cycles.shape[0], len(CHANNEL_COLUMNS)))
    rows = np.arange(cycles.shape[0])
    for a in range(3):
        col = 2 * a + (direction[:, a] < 0)
        times[rows, col] += np.where(direction[:, a] != 0, cycles[:, a], 0) * cycle_s
    return times


def _choose(
    cands: list,
    direction: np.ndarray,
    omega0: np.ndarray,
    target: np.ndarray,
    vehicle: Vehicle,
    channel_map: ChannelMap,
    settle_window_s: float,
):
    """Fly every combination of the candidates open loop (step 2); per run the best one.

    Returns ``(cycles (n, 3), times (n, 6), flight of the chosen rows, chosen row indices)``.
    """
    cyc = channel_map.cycle_s
    rows, owner, combos = [], [], []
    for i, per_axis in enumerate(cands):
        for combo in itertools.product(*per_axis):
            t = np.zeros(len(CHANNEL_COLUMNS))
            for a, c in enumerate(combo):
                if c:
                    t[channel_of(a, direction[i, a])] = c * cyc
            rows.append(t)
            owner.append(i)
            combos.append(combo)
    times = np.array(rows)
    owner_arr = np.array(owner)
    hist = _open_loop(
        times, target[owner_arr], omega0[owner_arr], vehicle, channel_map, settle_window_s
    )
    score = (hist.final.rate_err_B**2).sum(axis=1)
    n = len(cands)
    best = np.array(
        [np.flatnonzero(owner_arr == i)[np.argmin(score[owner_arr == i])] for i in range(n)]
    )
    cycles = np.array([combos[b] for b in best], int)
    return cycles, times[best], hist, best


def _open_loop(
    times: np.ndarray,
    target: np.ndarray,
    omega0: np.ndarray,
    vehicle: Vehicle,
    channel_map: ChannelMap,
    settle_window_s: float,
) -> History:
    """Fly rows of channel times (m, 6) [s] open loop from ``omega0`` under the rate command
    ``target`` (both (m, 3) [rad/s]) on the nominal vehicle, until every row has ended and
    ``settle_window_s`` more."""
    cyc = channel_map.cycle_s
    duration = _STRETCH * float(times.max()) + settle_window_s
    duration = np.ceil(duration / cyc - _CYCLE_EPS) * cyc
    return simulate_batch(
        vehicle.nominal(1).take(np.zeros(len(times), int)),
        ChannelOpenLoop(times, channel_map),
        Guidance.rate(target),
        float(duration),
        omega0_B=omega0,
        vehicle=vehicle,
    )


def generate_channel_table(
    vehicle: Vehicle,
    *,
    jets_off=(),
    rate_cases: RateCases | None = None,
    settle_window_s: float = 2.0,
    max_fire_s: float = 5.0,
    recipe: ChannelRecipe | None = None,
    target_fraction: float = DEFAULT_TARGET_FRACTION,
    threshold_deg_s: float | None = None,
    tune_rounds: int = DEFAULT_ROUNDS,
) -> GeneratedTable:
    """Solve the recipes and generate, verify and damping-check a channel table.

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle (resolved at the public edge: :meth:`Vehicle.load`); its profile's cycle,
        rate-case magnitude and rate deadband (the settling tolerance) as for a jet table.
    jets_off : sequence of int
        Jets (1-based) the recipes may not use.
    rate_cases : RateCases, optional
        Default: the profile's (:func:`rcsim.models.tables.rate_cases_at`).
    settle_window_s, max_fire_s
        As :func:`rcsim.lookup.table_generation.generate_jet_table`.
    recipe : ChannelRecipe, optional
        Recipes already solved (default: :func:`rcsim.lookup.channels.solve_recipe`).
    target_fraction, threshold_deg_s, tune_rounds
        Every case is tuned in closed loop to end within this fraction of the failure
        threshold [deg/s] (:mod:`rcsim.lookup.row_tuning`), as for a jet table.

    Returns
    -------
    GeneratedTable
        ``table`` has six channel columns and the recipe; ``command.cycles`` (26, 3) are the
        channel cycles per axis.
    """
    control = vehicle.control
    settle_tol_rad_s = control.rate_deadband_rad_s
    if recipe is None:
        recipe = solve_recipe(vehicle, jets_off=jets_off)
    rate_cases = rate_cases_at(control.rate_case_rad_s) if rate_cases is None else rate_cases
    rate = np.asarray(rate_cases.rate_cmd, float)
    zero = np.zeros_like(rate)
    cmap = ChannelMap(
        recipe.fractions, recipe.min_on_s, control.cycle_s, min_pulse=control.min_pulse
    )
    served = recipe.served

    def sweep(target, omega0):
        loop = ChannelFiringLoop(cmap, served)
        batch = vehicle.nominal(1).take(np.zeros(len(rate), int))
        hist = simulate_batch(
            batch,
            loop,
            Guidance.rate(target),
            max_fire_s,
            omega0_B=omega0,
            vehicle=vehicle,
        )
        cands, direction = _candidates(hist, cmap, served, loop, vehicle.definition.has_delays)
        cycles, times, chosen, rows = _choose(
            cands, direction, omega0, target, vehicle, cmap, settle_window_s
        )
        direction = np.where(cycles > 0, direction, 0)
        err = chosen.final.rate_err_B[rows]
        return FiringSweep(cycles, err, direction, hist), times, chosen, rows

    command, times, verify, rows = sweep(rate, zero)
    sign = np.sign(rate).astype(int)
    served_case = (sign != 0) & np.stack(
        [np.where(sign[:, a] > 0, served[2 * a], served[2 * a + 1]) for a in range(3)], axis=1
    )
    tuner = RowTuner(
        LookupTable(case=rate_cases.case, rate_cmd=rate, firing_time_s=times, recipe=recipe),
        served_case,
        lambda c, d: channel_row_times(c, d, control.cycle_s),
        vehicle=vehicle,
        stretch=_STRETCH,
        settle_window_s=settle_window_s,
        cycle_step_rad_s=cycle_steps(command.history),
    )
    cycles, nominal = tuner.tune(
        command.cycles,
        target_fraction=check_target_fraction(target_fraction),
        threshold_rad_s=float(np.radians(vehicle_threshold_deg_s(vehicle, threshold_deg_s))),
        rounds=tune_rounds,
    )
    if nominal.tuned.any():  # the verification flies the rows as tuned
        times = channel_row_times(cycles, sign * served_case, control.cycle_s)
        verify = _open_loop(times, rate, zero, vehicle, cmap, settle_window_s)
        rows = np.arange(len(rate))
        command = FiringSweep(
            cycles, verify.final.rate_err_B.copy(), np.where(cycles > 0, sign, 0), command.history
        )
    damping, damping_times, _, _ = sweep(zero, rate)
    jmap = CHANNEL_MAP * served[:, None]
    check_consistency(
        rate_cases.case,
        rate,
        times,
        jmap,
        file="<generated channel table>",
        cycle_s=control.cycle_s,
        columns=CHANNEL_COLUMNS,
    )
    off = f" without jets {', '.join(map(str, recipe.jets_off))}" if recipe.jets_off else ""
    table = LookupTable(
        case=rate_cases.case,
        rate_cmd=rate,
        firing_time_s=times,
        source=f"generated by rcsim.lookup.channel_generation for {recipe.vehicle}{off}",
        recipe=recipe,
    )
    # The chosen rows' flights: when each firing ended (its last jet off), how it settled.
    on = verify.on_time_s[rows]  # (26, K, n_jets)
    fired = on.max(axis=2) > 0
    last = np.where(fired.any(axis=1), fired.shape[1] - 1 - np.argmax(fired[:, ::-1], axis=1), 0)
    fire_end = verify.t_s[last] + on[np.arange(len(rows)), last].max(axis=1)
    sub = _rows(verify, rows)
    settle = settle_after_firing(sub, fire_end, settle_tol_rad_s)
    sign = np.sign(rate).astype(int)
    unreachable = np.stack(
        [
            (sign[:, a] != 0) & ~np.where(sign[:, a] > 0, served[2 * a], served[2 * a + 1])
            for a in range(3)
        ],
        axis=1,
    )
    _, dir_B = jet_geometry_B(vehicle.model)
    impulse_B = (verify.propulsion.impulse_ns[rows][:, :, None] * dir_B[None]).sum(axis=1)
    mass = vehicle.nominal(1).mass_kg[0]
    return GeneratedTable(
        table=table,
        command=command,
        damping=damping,
        damping_firing_time_s=damping_times,
        verify_rate_err_rad_s=verify.final.rate_err_B[rows].copy(),
        settle_after_firing_s=settle,
        settle_tol_rad_s=float(settle_tol_rad_s),
        jets_off=recipe.jets_off,
        unreachable=unreachable,
        dv_B_m_s=impulse_B / mass,
        nominal=nominal,
    )


def _rows(hist: History, rows: np.ndarray) -> History:
    """A history holding only the flights ``rows`` (rate errors and times: what
    :func:`~rcsim.lookup.table_generation.settle_after_firing` reads)."""
    from dataclasses import replace

    final = replace(hist.final, rate_err_B=hist.final.rate_err_B[rows])
    return replace(hist, rate_err_B=hist.rate_err_B[rows], final=final)
