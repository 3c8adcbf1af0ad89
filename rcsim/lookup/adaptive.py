"""An adaptive pattern-recognition controller: table entries that learn their firing times.

Gambone (sec. IV) proposes a controller "that senses when multiple thruster firings are
necessary".  This one senses it per table entry, in flight, and corrects the entry:

* a table entry is one case's firing on one axis (26 x 3 entries per run); the lookup logic
  (:class:`rcsim.lookup.pattern_recognition.LookupController`) scales its firing time to the rate
  change it needs, so each firing *promises* a rate change ``need`` on its axis, at a constant
  rate over its planned time;
* when a firing starts, the controller remembers the entry, the promise and the measured rate
  error;
* **mid-course** (this is what cuts repeated firings): the controller samples the measured
  rate when a firing has fired one cycle and again once it has fired ``check_after_s``; the
  slope between the two samples (rate change per second of firing) is compared with the
  promise's (``need`` over the planned time) and, if the difference is significant, the rest
  of the firing is re-planned at the slope observed, so that one firing, lengthened or
  shortened, does what the table promised instead of a second firing later.  A slope between
  two samples taken while the jets fire is blind to a sensor-to-actuator or valve delay (both
  samples lag alike), which a rate change since the firing's start is not.  Once per firing;
* ``settle_cycles`` after the firing ends (the thrust has stopped, delays included) it
  measures the rate change achieved and corrects the entry for its next use;
* **confidence rule**: the entry is corrected only when the shortfall (or excess) is
  significant: ``|achieved - promised| > max(k_sigma * sqrt(2) * rate_noise, min_rel *
  |promised|)``.  The first term ignores what sensor noise alone explains (two noisy
  measurements; ``rate_noise_rad_s`` is the rate sensor's white noise, a sensor spec, not a
  vehicle property); the second ignores small model errors (disturbance torques, cross-axis
  coupling), so that nominal flights never drift;
* and the entry is corrected only on the *second* significant miss in a row in the same
  direction (one miss may be a disturbance or a noisy sample; two agreeing ones are evidence);
  a miss in the other direction, or a firing on target, resets the evidence;
* the correction is partial and bounded: the entry's time scale is multiplied by
  ``(promised / achieved) ** gain`` and kept within ``[scale_min, scale_max]``; an achieved
  change with the wrong sign or below a fifth of the promise is clipped to that fifth.

It still knows no mass property and no jet geometry: only its table, its commands and its
measurements.  State is batched (``(n_runs, ...)`` arrays) like every controller; runs learn
independently.

Imports ``models``, ``rcsim.spacecraft.navigation`` and ``rcsim.lookup.pattern_recognition`` only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rcsim.lookup.pattern_recognition import LookupController, LookupParams, LookupState
from rcsim.models.tables import LookupTable
from rcsim.spacecraft.navigation import NavState

N_AXES = 3


@dataclass(frozen=True)
class AdaptParams:
    """How the entries learn (see the module docstring).

    Attributes
    ----------
    rate_noise_rad_s : float
        White noise of the rate measurement, one sigma [rad/s] (0: noise-free sensors).
    k_sigma : float
        Significance in noise sigmas.
    min_rel : float
        Smallest relative shortfall acted on.
    gain : float
        Fraction (in log scale) of the measured correction applied per firing, in (0, 1].
    scale_min, scale_max : float
        Bounds of an entry's firing-time scale.
    settle_cycles : int
        Cycles after a firing ends before its result is measured (>= 1; more when valve
        closing latency or a command delay lets thrust run past the cycle).
    check_after_s : float
        On-time after which a firing is checked mid-course [s] (0 disables); the slope is
        measured from one cycle of on-time to this, so it must exceed a cycle.
    """

    rate_noise_rad_s: float = 0.0
    k_sigma: float = 4.0
    min_rel: float = 0.08
    gain: float = 0.7
    scale_min: float = 0.5
    scale_max: float = 2.0
    settle_cycles: int = 1
    check_after_s: float = 0.12

    def __post_init__(self):
        if not (
            self.rate_noise_rad_s >= 0
            and self.k_sigma >= 0
            and self.min_rel >= 0
            and 0 < self.gain <= 1
            and 0 < self.scale_min <= 1 <= self.scale_max
            and self.settle_cycles >= 1
            and self.check_after_s >= 0
        ):
            raise ValueError(f"invalid AdaptParams {self}")


@dataclass
class AdaptiveState:
    """Lookup state plus, per run, the learned scales and the firing being watched.

    ``scale`` (n, 26, 3): firing-time scale of each entry.  Per axis (n, 3): ``entry`` the
    case being watched (-1: none), ``promised`` rate change [rad/s], ``start_rate`` measured
    rate error at its start [rad/s], ``countdown`` cycles until it is measured (0: still
    firing or none), ``planned_s`` and ``fired_s`` the firing's planned and commanded-so-far
    on-time [s], ``checked`` its mid-course check is done.  ``updates`` (n, 26, 3):
    corrections applied to each entry so far; ``replans`` (n, 3): mid-course re-plans.
    """

    base: LookupState
    scale: np.ndarray
    entry: np.ndarray
    promised: np.ndarray
    start_rate: np.ndarray
    countdown: np.ndarray
    updates: np.ndarray
    planned_s: np.ndarray
    fired_s: np.ndarray
    checked: np.ndarray
    replans: np.ndarray
    evidence: np.ndarray
    ref_rate: np.ndarray
    ref_fired_s: np.ndarray


class AdaptiveLookupController(LookupController):
    """:class:`LookupController` whose table entries learn their firing times in flight.

    Parameters
    ----------
    table : LookupTable
    params : LookupParams
    adapt : AdaptParams, optional
        Default: :class:`AdaptParams`' values.  Its ``check_after_s`` must exceed the control
        cycle (the slope is measured from one cycle of on-time to it) or be 0.
    jets_off : sequence of int
        As :class:`LookupController`.
    """

    NAME = "adaptive"

    def __init__(
        self,
        table: LookupTable,
        params: LookupParams,
        adapt: AdaptParams | None = None,
        *,
        jets_off=(),
    ):
        super().__init__(table, params, jets_off=jets_off)
        self.adapt = AdaptParams() if adapt is None else adapt

    @property
    def adapt(self) -> AdaptParams:
        """How the entries learn; a mid-course check must come after a cycle of on-time."""
        return self._adapt

    @adapt.setter
    def adapt(self, value: AdaptParams) -> None:
        check = value.check_after_s
        if check != 0 and not check > self.params.cycle_s:
            raise ValueError(
                f"AdaptParams.check_after_s = {check} s must exceed the control cycle "
                f"{self.params.cycle_s} s (or be 0: no mid-course check)"
            )
        self._adapt = value

    # The adaptive state extends the lookup state (learned scales, the firing watched); the
    # parent's step logic is reused through step_detail, never with the parent's state type.
    def initial_state(self, n_runs: int) -> AdaptiveState:  # type: ignore[override]
        n_cases = self._rate_abs.shape[0]
        axes = (n_runs, N_AXES)
        return AdaptiveState(
            base=super().initial_state(n_runs),
            scale=np.ones((n_runs, n_cases, N_AXES)),
            entry=np.full(axes, -1),
            promised=np.zeros(axes),
            start_rate=np.zeros(axes),
            countdown=np.zeros(axes, int),
            updates=np.zeros((n_runs, n_cases, N_AXES), int),
            planned_s=np.zeros(axes),
            fired_s=np.zeros(axes),
            checked=np.zeros(axes, bool),
            replans=np.zeros(axes, int),
            evidence=np.zeros((n_runs, n_cases, N_AXES), int),
            ref_rate=np.full(axes, np.nan),
            ref_fired_s=np.full(axes, np.nan),
        )

    def _significant(self, achieved: np.ndarray, promised: np.ndarray) -> np.ndarray:
        a = self.adapt
        noise = a.k_sigma * np.sqrt(2.0) * a.rate_noise_rad_s
        return np.abs(achieved - promised) > np.maximum(noise, a.min_rel * np.abs(promised))

    def step(  # type: ignore[override]
        self, nav: NavState, state: AdaptiveState
    ) -> tuple[np.ndarray, AdaptiveState]:
        """One control cycle: learn from the firings that just settled, then fly the
        lookup logic with the learned scales."""
        a = self.adapt
        scale = state.scale.copy()
        updates = state.updates.copy()
        evidence = state.evidence.copy()
        replans = state.replans.copy()
        rate = nav.rate_err_B
        achieved = rate - state.start_rate  # (n, 3) since each watched firing started

        def learn(watched, significant, ratio):
            """Evidence from the watched firings; correct an entry on its second agreeing
            significant miss (``ratio`` = achieved / promised)."""
            runs, axes = np.nonzero(watched)
            cases = state.entry[runs, axes]
            sign = np.where(significant[runs, axes], np.sign(1.0 - ratio[runs, axes]), 0)
            act = (sign != 0) & (sign == evidence[runs, cases, axes])
            evidence[runs, cases, axes] = np.where(act, 0, sign)
            runs, axes, cases = runs[act], axes[act], cases[act]
            factor = np.maximum(ratio[runs, axes], 0.2) ** -a.gain  # wrong sign/tiny: clipped
            scale[runs, cases, axes] = np.clip(
                scale[runs, cases, axes] * factor, a.scale_min, a.scale_max
            )
            updates[runs, cases, axes] += 1

        # Mid-course: a long firing that has fired check_after_s is re-planned at the rate
        # observed if its pro-rata promise is significantly missed.
        rem = state.base.remaining_s
        rem_axis = (rem[:, :, None] * self._axis_onehot[None]).max(axis=1)  # (n, 3)
        firing = (state.entry >= 0) & (state.countdown == 0) & (rem_axis > 0)
        cyc = self.params.cycle_s
        first = firing & np.isnan(state.ref_fired_s) & (state.fired_s >= cyc - 1e-9)
        ref_rate = np.where(first, rate, state.ref_rate)
        ref_fired = np.where(first, state.fired_s, state.ref_fired_s)
        check = (
            firing
            & ~state.checked
            & ~first
            & ~np.isnan(ref_fired)
            & (a.check_after_s > 0)
            & (state.fired_s >= a.check_after_s - 1e-9)
        )
        checked = state.checked | check
        if check.any():
            span = np.where(check, state.fired_s - ref_fired, 1.0)
            slope_gain = np.divide(
                state.promised, state.planned_s, out=np.zeros_like(rate), where=state.planned_s > 0
            )
            expected = slope_gain * span  # promised rate change over the sampled span
            observed = rate - ref_rate
            ratio = np.divide(observed, expected, out=np.ones_like(rate), where=expected != 0)
            replan = check & self._significant(observed, expected)
            if replan.any():
                # Total on-time at the observed slope, bounded by the entry's scale bounds.
                total = state.planned_s / np.maximum(ratio, 0.2)
                total = np.clip(total, a.scale_min * state.planned_s, a.scale_max * state.planned_s)
                new_rem = np.maximum(total - state.fired_s, 0.0)
                jet_new = new_rem @ self._axis_onehot.T  # (n, 16)
                jet_replan = (replan.astype(float) @ self._axis_onehot.T > 0) & (rem > 0)
                base = LookupState(
                    remaining_s=np.where(jet_replan, jet_new, rem),
                    hold_s=state.base.hold_s,
                    maneuvering=state.base.maneuvering,
                )
                state = AdaptiveState(**{**vars(state), "base": base})
                replans += replan
            learn(check, replan, ratio)

        # After a firing has settled: the whole firing against the whole promise.
        countdown = state.countdown.copy()
        due = (state.entry >= 0) & (countdown == 1)
        countdown = np.where(countdown > 0, countdown - 1, 0)
        if due.any():
            ratio = np.divide(
                achieved, state.promised, out=np.ones_like(rate), where=state.promised != 0
            )
            # A firing checked mid-course has given its evidence already.
            learn(due & ~checked, self._significant(achieved, state.promised), ratio)

        on, base, detail = self.step_detail(nav, state.base, case_scale=scale)
        entry = np.where(due, -1, state.entry)
        new = detail["axis_new"]
        case = np.broadcast_to(detail["case"][:, None], new.shape)
        on_axis = (on[:, :, None] * self._axis_onehot[None]).max(axis=1)  # (n, 3)
        rem_next = (base.remaining_s[:, :, None] * self._axis_onehot[None]).max(axis=1)
        # A new firing (re-planned or not) starts a new watch; the old one is abandoned.
        entry = np.where(new, case, entry)
        promised = np.where(new, detail["need"], state.promised)
        start_rate = np.where(new, rate, state.start_rate)
        countdown = np.where(new, 0, countdown)
        planned = np.where(new, on_axis + rem_next, state.planned_s)
        fired = np.where(new, on_axis, state.fired_s + on_axis)
        checked = np.where(new, False, checked)
        ref_rate = np.where(new, np.nan, ref_rate)
        ref_fired = np.where(new, np.nan, ref_fired)
        done = detail["axis_done"] & (entry >= 0) & (countdown == 0)
        countdown = np.where(done, a.settle_cycles, countdown)
        return on, AdaptiveState(
            base=base,
            scale=scale,
            entry=entry,
            promised=promised,
            start_rate=start_rate,
            countdown=countdown,
            updates=updates,
            planned_s=planned,
            fired_s=fired,
            checked=checked,
            replans=replans,
            evidence=evidence,
            ref_rate=ref_rate,
            ref_fired_s=ref_fired,
        )
