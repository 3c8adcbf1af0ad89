"""Closed-loop tuning of a generated table's rows: every rate case ends near its command.

The paper's rule (:mod:`rcsim.lookup.table_generation`, :mod:`rcsim.lookup.channel_generation`)
picks each row's whole cycles per axis from the firing loop, one axis at a time.  On a vehicle
whose jets are coarse, whose channels share jets, or whose axes couple, that row can end a case
farther from its command than the campaigns' failure threshold allows, below the controller's
dead band, where it never fires again.  Here every row is judged as it is flown:

1. *Nominal check*: the nominal vehicle flies each of the 26 rate cases from rest under the
   lookup controller itself (closed loop,
   :class:`~rcsim.lookup.pattern_recognition.LookupController` with the table), for the
   longest row's firing plus a settling window.  The case's error is what its row's firing
   left: each axis's rate error when the controller starts a second firing on it (a re-plan,
   a firing the other way, one after the hold: it fires again only above its dead band) or,
   without one, at the end of the flight.
   A case *meets the target* when every axis's is within ``target_fraction`` of the failure
   threshold: with a dead band at or above the target, it then ends in one firing.
2. *Tuning*: for each case that misses, every combination of its commanded axes' whole cycles
   within ``reach`` cycles of its row is flown the same way -- all candidates of all cases in
   one batched flight, each run carrying its own table
   (:meth:`~rcsim.lookup.pattern_recognition.LookupController.for_runs`) -- and the case keeps
   the candidate whose firing ends nearest (largest axis error least) among those that meet
   the target; a case none of whose candidates meets it keeps the rule's row (``rounds``
   bounds the search rounds; as a row moves only to one that meets the target, one does).  The
   table as tuned is then flown again: a tuned case that ranks worse there (after an
   overshoot the controller flies other cases' rows too) gets the rule's row back.
3. *Named misses*: a case that no candidate brings within the target keeps the rule's row,
   and the reason and the least error any candidate reached are stated: an axis direction no
   jet turns, a cycle's rate step coarser than the band (a whole-cycle row cannot land inside
   ``2 x target``: the row's minimum impulse bit is one cycle), or the axes' coupling.

Rows the paper's rule already brings within the target are not changed, so the paper's table
(residuals at most half a cycle's rate change, well inside the target) stays Table 6's.

Imports ``models``, ``spacecraft`` and ``lookup`` only.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from rcsim.lookup.pattern_recognition import LookupController, LookupParams
from rcsim.models.errors import InputError
from rcsim.models.tables import LookupTable
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import History, simulate_batch
from rcsim.spacecraft.valves import JetFaults, ValveTiming
from rcsim.spacecraft.vehicle.definition import PAPER_RATE_ERROR_DEG_S
from rcsim.spacecraft.vehicle.model import AXES

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle

#: The campaigns' default failure threshold on the final rate error of any axis [deg/s]
#: (Gambone sec. III), for a vehicle whose file gives no ``[failure]`` of its own
#: (:func:`vehicle_threshold_deg_s`).
FAILURE_RATE_ERROR_DEG_S = PAPER_RATE_ERROR_DEG_S
#: Default fraction of the failure threshold a nominal case must end within.
DEFAULT_TARGET_FRACTION = 0.5
#: Cycles searched either side of a row's, per commanded axis and round.
DEFAULT_REACH_CYCLES = 2
#: Search rounds (a round re-centres a case on its best row when that lay on the edge).
DEFAULT_ROUNDS = 3


def vehicle_threshold_deg_s(vehicle: Vehicle, threshold_deg_s: float | None) -> float:
    """The failure threshold a generated table is tuned to [deg/s]: ``threshold_deg_s`` when
    given, else the vehicle file's own ``[failure] rate_error_deg_s``, else the paper's."""
    if threshold_deg_s is not None:
        return float(threshold_deg_s)
    return float(vehicle.definition.failure.get("rate_error_deg_s", FAILURE_RATE_ERROR_DEG_S))


def check_target_fraction(value: float) -> float:
    """``value`` as a target fraction of the failure threshold, in (0, 1].

    Raises
    ------
    InputError
        Outside (0, 1]: a target at or above the failure threshold is no margin.
    """
    v = float(value)
    if not (np.isfinite(v) and 0.0 < v <= 1.0):
        raise InputError(
            f"must be in (0, 1] (a fraction of the failure threshold), got {value!r}",
            parameter="target_fraction",
            value=value,
        )
    return v


@dataclass(frozen=True)
class NominalCheck:
    """The 26 rate cases flown closed loop on the nominal vehicle with the final table.

    Attributes
    ----------
    rate_err_rad_s : ndarray, (26, 3)
        Rate error per axis the row's firing left [rad/s] (:func:`row_result`).
    end_rate_err_rad_s : ndarray, (26, 3)
        Rate error per axis at the end of the flight [rad/s] (after the controller's further
        firings, if any).
    firings : ndarray of int, (26,)
        Firings the controller started in the case (:class:`FiringRecorder`).
    flight_s : float
        Length of the closed-loop flight [s]: the longest row's firing (stretched by shared
        jets for a channel table) plus the settling window, in whole cycles.
    threshold_rad_s : float
        Failure threshold the target is a fraction of [rad/s].
    target_fraction : float
        The fraction: a case meets the target when it fires once and every axis ends within
        ``target_fraction * threshold_rad_s``.
    tuned : ndarray of bool, (26,)
        The row differs from the paper's rule's.
    reason : tuple of str
        Per case, why it misses the target (``""`` where it meets it).
    """

    rate_err_rad_s: np.ndarray
    end_rate_err_rad_s: np.ndarray
    firings: np.ndarray
    flight_s: float
    threshold_rad_s: float
    target_fraction: float
    tuned: np.ndarray
    reason: tuple

    @property
    def target_rad_s(self) -> float:
        """The target on every axis's final rate error [rad/s]."""
        return self.target_fraction * self.threshold_rad_s

    @property
    def worst_rad_s(self) -> np.ndarray:
        """Per case, the largest axis's final |rate error| [rad/s], (26,)."""
        return np.abs(self.rate_err_rad_s).max(axis=1)

    @property
    def met(self) -> np.ndarray:
        """Per case, its row's firing left every axis within the target, (26,) bool."""
        return self.worst_rad_s <= self.target_rad_s


class FiringRecorder:
    """The lookup controller, recording the cycles in which it starts a new firing.

    A row from rest starts a firing on each commanded axis in the first cycle; any later
    firing the controller starts (:meth:`LookupController.step_detail`'s ``axis_new``: a
    re-plan at the end of a firing, a firing the other way after an overshoot, one after the
    hold) is a second firing.  The delivery's own tails (a channel's short shares owed and
    fired later) are not.

    Parameters
    ----------
    controller : LookupController
    """

    def __init__(self, controller: LookupController):
        self.controller = controller
        self.new_firing: list[np.ndarray] = []  # per cycle, (n_runs, 3) bool

    @property
    def cycle_s(self) -> float:
        return self.controller.cycle_s

    def initial_state(self, n_runs: int):
        self.new_firing = []
        return self.controller.initial_state(n_runs)

    def step(self, nav, state):
        on, state, detail = self.controller.step_detail(nav, state)
        self.new_firing.append(np.asarray(detail["axis_new"], bool).copy())
        return on, state

    def first_firing(self) -> tuple[np.ndarray, np.ndarray]:
        """Per run, the firings started (cycles in which the controller starts one on some
        axis) and per axis the cycle a second firing starts on it (the number of cycles flown
        when none does), ``((n,), (n, 3))``."""
        new = np.stack(self.new_firing, axis=1)  # (n, K, 3)
        later = new.copy()
        later[:, 0] = False
        n_k = new.shape[1]
        second = np.where(later.any(axis=1), np.argmax(later, axis=1), n_k)
        return new.any(axis=2).sum(axis=1), second


def row_result(hist: History, recorder: FiringRecorder) -> tuple[np.ndarray, np.ndarray]:
    """Per run, the rate error the first firing left and the firings, ``((n, 3), (n,))``.

    Each axis's error is read at the start of the cycle a second firing starts on that axis
    (before it fires), or at the end of the flight when none does: what the row achieved,
    whatever the controller does after it."""
    firings, second = recorder.first_firing()
    err = np.concatenate([hist.rate_err_B, hist.final.rate_err_B[:, None]], axis=1)
    runs = np.arange(err.shape[0])[:, None]
    return err[runs, second, np.arange(3)[None, :]], firings


@dataclass(frozen=True)
class _Flown:
    """Candidate rows flown: their case, cycles, final errors and firings."""

    case: np.ndarray  # (m,)
    cycles: np.ndarray  # (m, 3)
    rate_err_rad_s: np.ndarray  # (m, 3)
    end_rate_err_rad_s: np.ndarray  # (m, 3)
    firings: np.ndarray  # (m,)

    def score(self, target_rad_s: float) -> np.ndarray:
        """Per row, the keys to rank it by, the least best, (m, 2): whether it misses the
        target, then the error its firing left."""
        row = np.abs(self.rate_err_rad_s).max(axis=1)
        return np.stack([row > target_rad_s, row], axis=1).astype(float)


class RowTuner:
    """Flies candidate rows of a table closed loop and keeps each case's best (module docstring).

    Parameters
    ----------
    table : LookupTable
        The table the paper's rule generated (jet or channel columns; a channel table carries
        its recipe).  Its jet roles are kept: a candidate changes times only.
    served : ndarray of bool, (26, 3)
        Per case, the commanded axes some jet (channel) turns the commanded way (the others
        never fire).
    row_times : callable
        ``(cycles (m, 3), direction (m, 3)) -> (m, n_columns)``: a row's times [s] from its
        cycles per axis.
    vehicle : Vehicle
        The vehicle flown nominally (its profile gives the controller's inputs and cycle).
    stretch : float
        Longest wall time of a row per second of its longest column (1 for a jet table; a
        channel table's shared jets spread a firing over up to 3 times its time).
    settle_window_s : float
        Flight after the longest row's firing [s].
    faults, timing : optional
        One run's jet faults and valve timing (taken for every run); None: none / nominal.
    jets_off : tuple of int
        Jets the table was made without (the controller accepts a lost direction).
    cycle_step_rad_s : ndarray, (26, 3), optional
        Per case and axis, the largest rate change one cycle of the case's firing makes on
        the axis [rad/s] (:func:`cycle_steps` of the firing loop): what a whole-cycle row
        cannot resolve below.  None: no miss is put down to it.
    """

    def __init__(
        self,
        table: LookupTable,
        served: np.ndarray,
        row_times: Callable[[np.ndarray, np.ndarray], np.ndarray],
        *,
        vehicle: Vehicle,
        stretch: float,
        settle_window_s: float,
        faults: JetFaults | None = None,
        timing: ValveTiming | None = None,
        jets_off: tuple = (),
        cycle_step_rad_s: np.ndarray | None = None,
    ):
        self.table = table
        self.served = np.asarray(served, bool)
        # From rest the torque sign of each axis is its command's.
        self.direction = np.sign(np.asarray(table.rate_cmd, float)).astype(int) * self.served
        self.row_times = row_times
        self.vehicle = vehicle
        self.stretch = float(stretch)
        self.settle_window_s = float(settle_window_s)
        self.faults = faults
        self.timing = timing
        self.jets_off = tuple(jets_off)
        self.cycle_step_rad_s = cycle_step_rad_s
        self.params = LookupParams.from_profile(vehicle.control)

    def flight_s(self, times_s: np.ndarray) -> float:
        """Closed-loop flight length for rows of these times [s], whole cycles."""
        cyc = self.vehicle.control.cycle_s
        longest = self.stretch * float(np.max(times_s, initial=0.0)) + self.settle_window_s
        return float(np.ceil(longest / cyc - 1e-9) * cyc)

    def fly(
        self, base_times_s: np.ndarray, case: np.ndarray, cycles: np.ndarray, duration_s: float
    ) -> tuple[_Flown, History]:
        """Fly run ``i``: case ``case[i]`` from rest with the table ``base_times_s`` whose row
        ``case[i]`` has ``cycles[i]`` -- one batch, every run its own table."""
        case = np.asarray(case, int)
        cycles = np.asarray(cycles, int).reshape(-1, 3)
        m = case.size
        run_times = np.repeat(np.asarray(base_times_s, float)[None], m, axis=0)
        run_times[np.arange(m), case] = self.row_times(cycles, self.direction[case])
        # Every run's table fires the same jets in every case (only times differ): the roles
        # are learned from the first run's.
        roles = replace(self.table, firing_time_s=run_times[0])
        controller = FiringRecorder(
            LookupController.for_runs(roles, run_times, self.params, jets_off=self.jets_off)
        )
        zeros = np.zeros(m, int)
        hist = simulate_batch(
            self.vehicle.nominal(1).take(zeros),
            controller,
            Guidance.rate(np.asarray(self.table.rate_cmd, float)[case]),
            duration_s,
            vehicle=self.vehicle,
            faults=None if self.faults is None else self.faults.take(zeros),
            timing=None if self.timing is None else self.timing.take(zeros),
        )
        err, firings = row_result(hist, controller)
        flown = _Flown(
            case=case,
            cycles=cycles,
            rate_err_rad_s=err,
            end_rate_err_rad_s=hist.final.rate_err_B.copy(),
            firings=firings,
        )
        return flown, hist

    def tune(
        self,
        cycles: np.ndarray,
        *,
        target_fraction: float = DEFAULT_TARGET_FRACTION,
        threshold_rad_s: float = float(np.radians(FAILURE_RATE_ERROR_DEG_S)),
        reach: int = DEFAULT_REACH_CYCLES,
        rounds: int = DEFAULT_ROUNDS,
    ) -> tuple[np.ndarray, NominalCheck]:
        """Tune the rows (module docstring); return the cycles (26, 3) and the nominal check
        of the table they make.

        Parameters
        ----------
        cycles : ndarray of int, (26, 3)
            The paper's rule's cycles per case and axis.
        target_fraction : float
            Fraction of ``threshold_rad_s`` each axis must end within, in (0, 1].
        threshold_rad_s : float
            The failure threshold [rad/s].
        reach, rounds : int
            Cycles searched either side per commanded axis; search rounds.
        """
        original = np.asarray(cycles, int).copy()
        n = original.shape[0]
        target = target_fraction * threshold_rad_s
        # The axes a row may tune: those it fires.  An axis the rule left at 0 cycles (one
        # cycle overshoots by more than the command) stays so: the controller learns which
        # jets serve a case from the table, and every candidate must fire the same ones.
        fires = self.served & (original > 0)
        cur = original.copy()
        times = self.row_times(cur, self.direction)
        # One flight length for every flight (the longest row the default search may try,
        # whatever ``rounds`` is: the rule's table is judged alike with and without a search),
        # so that every row of a case is judged at the same time.
        cyc = self.vehicle.control.cycle_s
        longest = reach * max(rounds, DEFAULT_ROUNDS) * cyc
        duration = self.flight_s(times + (times > 0) * longest)
        first, _ = self.fly(times, np.arange(n), cur, duration)
        best = first.score(target)
        first_keys = best.copy()
        # The least error any row of the case left in its firing (what a miss reports).
        least = np.abs(first.rate_err_rad_s).max(axis=1)
        seen = [{tuple(cur[i])} for i in range(n)]
        open_ = best[:, 0] > 0
        for _ in range(rounds):
            case, cand = [], []
            for i in np.flatnonzero(open_):  # cases that miss: at most 26, each <= 125 rows
                axes = [
                    range(max(c - reach, 1), c + reach + 1) if f else (c,)
                    for c, f in zip(cur[i], fires[i], strict=True)
                ]
                for combo in itertools.product(*axes):
                    if combo not in seen[i]:
                        seen[i].add(combo)
                        case.append(i)
                        cand.append(combo)
            if not case:
                break
            cand_arr = np.array(cand, int)
            flown, _ = self.fly(times, np.array(case), cand_arr, duration)
            keys = flown.score(target)
            row_err = np.abs(flown.rate_err_rad_s).max(axis=1)
            np.minimum.at(least, flown.case, row_err)
            moved = np.zeros(n, bool)
            for i in np.unique(flown.case):  # per case: the best of its candidates
                own = np.flatnonzero(flown.case == i)
                k = own[np.lexsort(keys[own].T[::-1])[0]]
                # A row is replaced only by one that meets the target: a row that misses it
                # may still end its case better than another that misses it by less (the
                # controller corrects a residual above its dead band, not one under it), which
                # only the dispersed runs of a refinement can judge.
                if keys[k, 0] == 0 and tuple(keys[k]) < tuple(best[i]):
                    cur[i], best[i] = flown.cycles[k], keys[k]
                    moved[i] = True
            # Search again only around a case whose best moved (its new neighbours are unflown).
            open_ = (best[:, 0] > 0) & moved
            times = self.row_times(cur, self.direction)
        times = self.row_times(cur, self.direction)
        final, _ = self.fly(times, np.arange(n), cur, duration)
        # After an overshoot the controller flies other cases' rows too: a case's own best
        # may rank worse among the other rows as tuned.  Such a case keeps the rule's row.
        for _ in range(n):  # each pass reverts at least one row: at most 26 passes
            ranked = final.score(target)
            worse = np.array([tuple(ranked[i]) > tuple(first_keys[i]) for i in range(n)])
            worse &= np.any(cur != original, axis=1)
            if not worse.any():
                break
            cur[worse] = original[worse]
            times = self.row_times(cur, self.direction)
            final, _ = self.fly(times, np.arange(n), cur, duration)
        check = NominalCheck(
            rate_err_rad_s=final.rate_err_rad_s,
            end_rate_err_rad_s=final.end_rate_err_rad_s,
            firings=final.firings,
            flight_s=duration,
            threshold_rad_s=float(threshold_rad_s),
            target_fraction=float(target_fraction),
            tuned=np.any(cur != original, axis=1),
            reason=(),
        )
        reasons = tuple(
            "" if check.met[i] else self._reason(i, check, float(least[i])) for i in range(n)
        )
        return cur, replace(check, reason=reasons)

    def _reason(self, i: int, check: NominalCheck, least_rad_s: float) -> str:
        """Why case ``i`` misses the target, with the best error reached (``least_rad_s``:
        the least any flown row left in its firing)."""
        target = check.target_rad_s
        err = check.rate_err_rad_s[i]
        end = float(np.abs(check.end_rate_err_rad_s[i]).max())
        best = (
            f"best {np.degrees(least_rad_s):.4f} deg/s in one firing; the row kept leaves "
            f"{np.degrees(check.worst_rad_s[i]):.4f} and the case ends at "
            f"{np.degrees(end):.4f} deg/s"
        )
        rate = np.asarray(self.table.rate_cmd, float)[i]
        lost = [
            f"{'+' if rate[a] > 0 else '-'}{AXES[a]}"
            for a in range(3)
            if rate[a] != 0 and self.direction[i, a] == 0
        ]
        if lost:
            return f"unreachable: no jet left turns {', '.join(lost)} ({best})"
        steps = self.cycle_step_rad_s
        coarse = [
            f"{AXES[a]} {np.degrees(steps[i, a]):.4f}"
            for a in np.flatnonzero(np.abs(err) > target)
            if steps is not None and steps[i, a] > 2 * target
        ]
        if coarse:
            return (
                f"cycle coarser than the band: one cycle changes {', '.join(coarse)} deg/s, "
                f"more than the band's {np.degrees(2 * target):.4f} deg/s width (a whole-cycle "
                f"row's minimum impulse bit is one cycle; {best})"
            )
        return (
            "coupling: no whole-cycle row within the searched cycles ends every axis within "
            f"{np.degrees(target):.4f} deg/s ({best})"
        )


def cycle_steps(firing_loop: History) -> np.ndarray:
    """Per run and axis, the largest rate change one cycle of the firing loop made on the
    axis [rad/s], (n, 3): a whole-cycle row's resolution there."""
    err = np.concatenate([firing_loop.rate_err_B, firing_loop.final.rate_err_B[:, None]], axis=1)
    return np.abs(np.diff(err, axis=1)).max(axis=1)
