"""Pattern-recognition lookup controller (Gambone, *Pattern Recognition Control Design*, sec. II).

The controller knows no mass property and no jet map: only a lookup table of firing times
(26 rate cases x 16 jets, :class:`rcsim.models.tables.LookupTable`) and the five inputs of Table 4.

What it learns from the table (paper: "first reads the lookup table to determine the thrusters
firing in each axis, as well as the indices of opposing thrusters"):

* a jet's *axis* is the one axis whose rate-command sign is the same, and nonzero, in every case
  where the jet fires; that sign is the jet's *sign* (the direction it turns the vehicle);
* jets of the same axis and opposite sign *oppose* each other;
* a jet that fires in no case is unused.

Each control cycle, per run (all vectorized over ``n_runs``):

1. *Rate error.*  With attitude error ``e`` (rotation vector, rad) and total angle
   ``theta = |e|``: above the maneuver limit the target rate is ``omega_cmd - w_m e / theta``
   (the maneuver rate ``w_m`` split across axes along the attitude-error direction, toward
   zero error); at or below it, the target is ``omega_cmd``.  ``rate_err = omega - target``.
   With a hysteresis (the profile's ``maneuver_hysteresis_deg``, 0 for the paper) a maneuver
   once entered is flown until ``theta`` falls below the limit minus the hysteresis (the
   state remembers it), so an error hovering at the limit does not chatter.
2. *Dead band.*  Per axis, ``|rate_err| < rate_error_limit`` is set to zero.
3. *Case.*  The rate change needed is ``-rate_err``; its sign pattern selects the table case
   with that pattern (all 26 nonzero patterns are in every valid table).
4. *Scale factor* (our reading of "the rate error is compared to the lookup table to determine
   the firing time scale factor in each axis"): ``scale_a = |rate_err_a| / |omega_case_a|``,
   the fraction of the case's commanded rate the axis needs; the jet's new firing time is its
   table time times its axis's scale.  This assumes the rate change is linear in firing time,
   as the paper does (sec. IV).
5. *Gates.*  A jet may get a new firing only if its own remaining on-time and that of every
   opposing jet are below the on-time limit, and its axis's hold timer has run out.  An axis
   that gets a new firing is re-planned: its firing jets get their new times, the others
   (incl. an opposing tail) are cleared, so opposing jets never fire together.  An axis whose
   rate error is in the dead band keeps whatever tail it had.
6. *No-firing region* (paper Figs 17-18): while ``|theta - maneuver_limit| < no_fire_band``
   no new firing is commanded on any axis.
7. *Delivery.*  Each jet fires ``min(remaining, cycle)`` this cycle; remaining on-time is
   decremented by the cycle.  When an axis's firing ends, its hold timer is set to the hold
   time (the rate "settles" before the axis may fire again); hold timers count down by the cycle.

*Channel tables* (a vehicle whose jets torque several axes, :mod:`rcsim.lookup.channels`): the
table's columns are six axis channels instead of jets; everything above runs on them unchanged
(a channel's learned axis and sign are its own), and step 7 delivers the channels' on-times
through the table's recipe (:class:`rcsim.lookup.channels.ChannelMap`: jet on-times, shared jets
scaled, short shares owed until the minimum on-time), a channel's remaining on-time counting
down by the time delivered.  The state then carries the delivery's per-jet valve state.

See ``docs/lookup.md`` for the readings of the paper and why.  (About 400 lines: the logic
above, the table's jet roles it learns, and the per-run candidate tables of refinement,
:meth:`LookupController.for_runs`.)
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from importlib.resources import files
from pathlib import Path

import numpy as np

from rcsim.lookup.channels import ChannelMap, ValveState
from rcsim.lookup.jet_sets import load_table_for_jets
from rcsim.lookup.step_kernel import kernel_available, kernel_step
from rcsim.models.errors import InputError
from rcsim.models.tables import LookupTable, load_lookup_table
from rcsim.models.tables.lookup_tables import PAPER_LOOKUP_TABLES
from rcsim.spacecraft.control_profile import ControlProfile
from rcsim.spacecraft.navigation import NavState

N_AXES = 3
#: Tolerance for "a timer has run out" [s]: timers are sums of multiples of the cycle and
#: scaled table times; float error is ~1e-17 s, a microsecond is far below any on-time.
_TIMER_EPS_S = 1e-9


def default_table_path() -> Path:
    """The packaged table, ``rcsim/lookup/data/generated_table.csv`` (generated for the nominal
    vehicle; see ``rcsim/lookup/data/README.md``)."""
    return Path(str(files("rcsim.lookup") / "data" / "generated_table.csv"))


def load_default_table() -> LookupTable:
    """The packaged generated table."""
    return load_lookup_table(default_table_path())


def learn_jets(
    table: LookupTable, allow_unserved: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which axis and direction each jet serves, and which jets oppose, from the table alone.

    Parameters
    ----------
    table : LookupTable
        ``rate_cmd`` (26, 3) [rad/s] and ``firing_time_s`` (26, 16) [s].
    allow_unserved : bool
        Accept an axis direction no jet serves (a table made for a vehicle with failed jets,
        :mod:`rcsim.lookup.jet_sets`): that direction is never fired.

    Returns
    -------
    axis : ndarray of int, (16,)
        0 roll, 1 pitch, 2 yaw; -1 for a jet that fires in no case.
    sign : ndarray of int, (16,)
        +1/-1: the sign of the rate command on ``axis`` in every case the jet fires; 0 unused.
    opposing : ndarray of bool, (16, 16)
        ``opposing[j, k]``: jet k is on j's axis with the opposite sign.

    Raises
    ------
    InputError
        A jet that fires in cases of mixed sign on every axis (the logic needs each jet to
        serve one axis, paper sec. IV), or an axis direction no jet serves.
    """
    signs = np.sign(np.asarray(table.rate_cmd)).astype(int)  # (26, 3)
    fires = np.asarray(table.firing_time_s) > 0  # (26, 16)
    n_jets = fires.shape[1]
    axis = np.full(n_jets, -1)
    sign = np.zeros(n_jets, int)
    src = table.source or "<lookup table>"
    for j in range(n_jets):  # 16 jets, once at construction
        rows = signs[fires[:, j]]
        if rows.shape[0] == 0:
            continue
        constant = np.flatnonzero(np.all(rows == rows[0], axis=0) & (rows[0] != 0))
        if constant.size != 1:
            raise InputError(
                f"{src}: jet_{j + 1:02d} fires in cases whose rate sign is not constant on "
                "exactly one axis; the lookup logic needs each jet to serve one axis"
            )
        axis[j], sign[j] = constant[0], rows[0, constant[0]]
    for a in range(N_AXES):
        for s in (-1, 1):
            if not allow_unserved and not np.any((axis == a) & (sign == s)):
                raise InputError(f"{src}: no jet fires for a {s:+d} rate on axis {a}")
    used = axis >= 0
    opposing = (
        (axis[:, None] == axis[None, :])
        & (sign[:, None] == -sign[None, :])
        & used[:, None]
        & used[None, :]
    )
    return axis, sign, opposing


@dataclass(frozen=True)
class LookupParams:
    """Inputs of the lookup logic (paper Table 4) plus the no-firing region; SI units.  A
    vehicle's own are its profile's (:meth:`from_profile`; the paper's values in brackets).

    Attributes
    ----------
    maneuver_limit_rad : float
        Total attitude error above which the maneuver rate is flown [rad] (0.6 deg).
    maneuver_rate_rad_s : float
        Total maneuver rate [rad/s] (0.2 deg/s).
    rate_error_limit_rad_s : float
        Per-axis dead band on the rate error [rad/s] (0.06 deg/s).
    on_time_limit_s : float
        A jet gets a new firing only if its and its opposing jets' remaining on-time are
        below this [s] (0.03 s).
    hold_time_s : float
        Wait after an axis's firing ends before it may fire again [s] (0.16 s).
    no_fire_band_rad : float
        Half-width of the no-firing region around the maneuver limit [rad] (0.1 deg,
        paper Figs 17-18); 0 disables it.
    cycle_s : float
        Control cycle [s] (40 ms): the vehicle's profile's, the simulation's.
    min_pulse : str
        What a channel table's share shorter than the vehicle's minimum on-time becomes
        (``"accumulate"``; :mod:`rcsim.spacecraft.control_profile`).  A jet table fires its
        entries as they are.
    maneuver_hysteresis_rad : float
        A maneuver ends only below ``maneuver_limit_rad`` minus this [rad] (0: the paper's
        rule, enter and leave at the limit).
    """

    maneuver_limit_rad: float
    maneuver_rate_rad_s: float
    rate_error_limit_rad_s: float
    on_time_limit_s: float
    hold_time_s: float
    no_fire_band_rad: float
    cycle_s: float
    min_pulse: str
    maneuver_hysteresis_rad: float = 0.0

    def __post_init__(self):
        for name in (
            "maneuver_limit_rad",
            "maneuver_rate_rad_s",
            "rate_error_limit_rad_s",
            "on_time_limit_s",
            "cycle_s",
        ):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"LookupParams.{name} must be > 0, got {value}")
        for name in ("hold_time_s", "no_fire_band_rad", "maneuver_hysteresis_rad"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InputError(f"LookupParams.{name} must be >= 0, got {value}")

    @classmethod
    def from_profile(cls, control: ControlProfile, **overrides) -> LookupParams:
        """The lookup logic's inputs from a vehicle's flight-software profile, with keyword
        overrides (a scenario's study of one value, e.g. ``no_fire_band_rad=0.0``)."""
        base = cls(
            maneuver_limit_rad=control.maneuver_limit_rad,
            maneuver_rate_rad_s=control.maneuver_rate_rad_s,
            rate_error_limit_rad_s=control.rate_deadband_rad_s,
            on_time_limit_s=control.on_time_limit_s,
            hold_time_s=control.hold_time_s,
            no_fire_band_rad=control.maneuver_band_rad,
            cycle_s=control.cycle_s,
            min_pulse=control.min_pulse,
            maneuver_hysteresis_rad=control.maneuver_hysteresis_rad,
        )
        return replace(base, **overrides)


@dataclass
class LookupState:
    """Batched controller state.

    Attributes
    ----------
    remaining_s : ndarray, (n_runs, 16) or (n_runs, 6)
        On-time left in each jet's (a channel table: each channel's) current firing, from the
        start of the next cycle [s].
    hold_s : ndarray, (n_runs, 3)
        Time left before each axis may fire again [s].
    valves : ValveState, optional
        A channel table's per-jet delivery state (:class:`rcsim.lookup.channels.ValveState`); None
        for a jet table.
    maneuvering : ndarray of bool, (n_runs,), optional
        The last cycle flew the maneuver rate (step 1's hysteresis); None: no run was.
    """

    remaining_s: np.ndarray
    hold_s: np.ndarray
    valves: ValveState | None = None
    maneuvering: np.ndarray | None = None


class LookupController:
    """Batched pattern-recognition controller; see the module docstring for the logic.

    Parameters
    ----------
    table : LookupTable
        The firing-time table; the only vehicle knowledge the controller has.
    params : LookupParams
        The logic's inputs (a vehicle's: :meth:`LookupParams.from_profile`).
    jets_off : sequence of int
        Jets (1..16) the table was made without (:mod:`rcsim.lookup.jet_sets`): an axis direction
        left without a jet is accepted and never fired.

    A channel table (``table.recipe`` set) is flown through its recipe: :meth:`step` returns
    the vehicle's jet on-times, ``(n_runs, recipe.n_jets)``.  Subclasses (the adaptive
    controller) fly jet tables only.
    """

    #: The controller's name as the CLI and campaign specs give it (:mod:`rcsim.lookup.registry`),
    #: for messages.
    NAME = "lookup"

    def __init__(self, table: LookupTable, params: LookupParams, *, jets_off=()):
        self.table = table
        self.params = params
        self.jets_off = tuple(jets_off)
        recipe = table.recipe
        self._channels: ChannelMap | None = None
        if recipe is not None:
            if type(self) is not LookupController:
                raise InputError(
                    f"{table.source or '<lookup table>'}: a channel table (for a vehicle whose "
                    "jets torque several axes) flies with the lookup controller, not "
                    f"{self.NAME!r} (it learns jet tables only): --controller lookup, or "
                    'controller.name = "lookup" in a campaign spec'
                )
            self._channels = ChannelMap(
                recipe.fractions,
                recipe.min_on_s,
                self.params.cycle_s,
                min_pulse=self.params.min_pulse,
            )
        self.jet_axis_, self.jet_sign_, self.opposing_ = learn_jets(
            table,
            allow_unserved=bool(self.jets_off) or (recipe is not None and not recipe.served.all()),
        )
        signs = np.sign(np.asarray(table.rate_cmd)).astype(int)
        # Case row of each sign pattern, indexed by the base-3 code of (roll, pitch, yaw) + 1.
        codes = ((signs + 1) * np.array([9, 3, 1])).sum(axis=1)
        self._case_of_code = np.full(27, -1)
        self._case_of_code[codes] = np.arange(len(codes))
        # (26, 16); (n_runs, 26, 16) when every run flies its own candidate (for_runs).
        self._times = np.asarray(table.firing_time_s, float)
        self._rate_abs = np.abs(np.asarray(table.rate_cmd, float))  # (26, 3)
        # (16, 3) one-hot jet -> axis (zero row for unused jets), for per-axis reductions.
        self._axis_onehot = (self.jet_axis_[:, None] == np.arange(N_AXES)[None, :]).astype(float)
        # Jets grouped by (axis, sign): a jet's opponents are the group of its axis with the other
        # sign (``opposing_``).  A per-group max is O(n_jets) per run where a masked max over the
        # (16, 16) ``opposing_`` matrix is O(n_jets^2) -- it was half the controller's cost.
        used = self.jet_axis_ >= 0
        group = 2 * self.jet_axis_ + (self.jet_sign_ > 0)
        self._group_jets = [np.flatnonzero(used & (group == g)) for g in range(2 * N_AXES)]
        # Opposing group of each jet; unused jets point at an extra all-zero column.
        self._opp_group = np.where(used, 2 * self.jet_axis_ + (self.jet_sign_ < 0), 2 * N_AXES)
        # The same roles as the compiled cycle takes them (rcsim/lookup/step_kernel.py).
        self._kernel_roles = (
            np.ascontiguousarray(self._case_of_code, np.int64),
            np.ascontiguousarray(self._rate_abs, np.float64),
            np.ascontiguousarray(self.jet_axis_, np.int64),
            np.ascontiguousarray(np.where(used, group, 2 * N_AXES), np.int64),
            np.ascontiguousarray(self._opp_group, np.int64),
        )

    @property
    def cycle_s(self) -> float:
        """Control cycle the controller assumes [s] (checked by the simulation)."""
        return self.params.cycle_s

    @classmethod
    def from_files(
        cls, table: str | os.PathLike | None, control: ControlProfile, **overrides
    ) -> LookupController:
        """Controller from a table CSV (rcsim or paper layout) and a vehicle's profile.

        Parameters
        ----------
        table : path or None
            A table CSV, or anything else :func:`rcsim.models.tables.load_lookup_table` accepts;
            None: the packaged generated table (`rcsim/lookup/data/generated_table.csv`).  A
            table generated without some jets is checked against the jets left, as its
            companion file records (:mod:`rcsim.lookup.jet_sets`).
        control : ControlProfile
            The flown vehicle's profile (:attr:`rcsim.spacecraft.vehicle.Vehicle.control`).
        **overrides
            :class:`LookupParams` fields, e.g. ``no_fire_band_rad=0.0``.

        Raises
        ------
        InputError
            The table does not load (a missing file is named by its path).
        """
        # The table loader is the one place that refuses a missing file (InputError naming
        # the path) and knows what else ``table`` may name.
        jets_off = ()
        if table is None:
            tab = load_default_table()
        elif isinstance(table, (str, os.PathLike)) and str(table) not in PAPER_LOOKUP_TABLES:
            # A user's table in whole cycles of the vehicle's profile (the paper's tables, of
            # the paper's 40 ms, are checked as the paper's data).
            tab, jets_off = load_table_for_jets(table, cycle_s=control.cycle_s)
        else:
            tab = load_lookup_table(table)
        return cls(tab, LookupParams.from_profile(control, **overrides), jets_off=jets_off)

    #: Per run and table row, whether the row started a firing in the flight so far, (n_runs,
    #: n_cases) bool; None unless recording (:meth:`record_rows`).  What the refinement reads:
    #: a correction firing picks its row by the sign pattern of the rate error, so a row also
    #: flies in other cases' runs, and only the runs that fire a row can be moved by it.
    rows_fired: np.ndarray | None = None
    _record_rows = False

    def record_rows(self) -> LookupController:
        """Record :attr:`rows_fired` in the next flights (reset by :meth:`initial_state`).
        Recording only reads what the cycle decided (the row and the axes that started a new
        firing), the same in the compiled and the numpy cycle: the flight is unchanged, bit
        for bit.  Returns ``self``."""
        self._record_rows = True
        return self

    @classmethod
    def for_runs(
        cls,
        table: LookupTable,
        run_times_s: np.ndarray,
        params: LookupParams,
        *,
        jets_off=(),
    ) -> LookupController:
        """A controller in which every run flies its own firing times (candidate tables).

        Parameters
        ----------
        table : LookupTable
            The table the candidates edit: jet roles (axis, sign, opposing jets) are learned
            from it, so a candidate may change times but never which jets fire.
        run_times_s : ndarray, (n_runs, 26, 16)
            Firing times of run ``i``'s table [s].
        params : LookupParams
        jets_off : sequence of int
            As for the constructor: the jets the table was made without.

        Raises
        ------
        ValueError
            A candidate fires a jet the table does not fire in that case, or stops one it does.
        """
        times = np.asarray(run_times_s, float)
        base = np.asarray(table.firing_time_s, float)
        if times.ndim != 3 or times.shape[1:] != base.shape:
            raise ValueError(
                f"run_times_s must have shape (n_runs, {base.shape[0]}, "
                f"{base.shape[1]}), got {times.shape}"
            )
        if np.any((times > 0) != (base > 0)[None]):
            raise ValueError("a candidate table changes which jets fire; only times may change")
        controller = cls(table, params, jets_off=jets_off)
        controller._times = times
        return controller

    def _case_times(self, case: np.ndarray, case_scale: np.ndarray | None = None) -> np.ndarray:
        """(n_runs, 16) table times of each run's selected case, each axis's jets times
        ``case_scale[run, case, axis]`` when given (n_runs, n_cases, 3)."""
        times = (
            self._times[case] if self._times.ndim == 2 else self._times[np.arange(case.size), case]
        )
        if case_scale is None:
            return times
        per_axis = case_scale[np.arange(case.size), case]  # (n, 3)
        return times * (per_axis @ self._axis_onehot.T)

    def initial_state(self, n_runs: int) -> LookupState:
        if self._times.ndim == 3 and self._times.shape[0] != n_runs:
            raise ValueError(
                f"controller has tables for {self._times.shape[0]} runs, asked for {n_runs}"
            )
        if self._record_rows:
            self.rows_fired = np.zeros((n_runs, self._times.shape[-2]), bool)
        return LookupState(
            remaining_s=np.zeros((n_runs, self._times.shape[-1])),
            hold_s=np.zeros((n_runs, N_AXES)),
            valves=None if self._channels is None else self._channels.initial(n_runs),
        )

    def maneuvering(self, theta: np.ndarray, before: np.ndarray | None) -> np.ndarray:
        """Whether each run flies the maneuver rate this cycle, (n_runs,) bool (step 1):
        above the limit, or still above limit - hysteresis after a maneuver cycle.
        ``theta`` (n_runs,) [rad]; ``before`` the last cycle's flags (None: none)."""
        p = self.params
        above = theta > p.maneuver_limit_rad
        if before is None or p.maneuver_hysteresis_rad <= 0:
            return above
        return above | (before & (theta > p.maneuver_limit_rad - p.maneuver_hysteresis_rad))

    def rate_error(
        self,
        nav: NavState,
        theta: np.ndarray | None = None,
        maneuver: np.ndarray | None = None,
    ) -> np.ndarray:
        """Dead-banded rate error the logic acts on, (n_runs, 3) [rad/s] (steps 1-2).

        ``theta`` (n_runs, 1) is the total attitude error [rad] if the caller has it already;
        ``maneuver`` (n_runs,) bool the maneuver flags (:meth:`maneuvering`; default: above
        the limit).
        """
        p = self.params
        e = nav.att_err_B
        if theta is None:
            theta = np.sqrt(np.einsum("ij,ij->i", e, e))[:, None]
        if maneuver is None:
            maneuver = theta > p.maneuver_limit_rad
        else:
            maneuver = maneuver[:, None]
        direction = e / np.where(theta > 0, theta, 1.0)
        # omega - (omega_cmd - w_m e/theta) = rate_err_B + w_m e/theta
        err = nav.rate_err_B + np.where(maneuver, p.maneuver_rate_rad_s * direction, 0.0)
        return np.where(np.abs(err) < p.rate_error_limit_rad_s, 0.0, err)

    def step(self, nav: NavState, state: LookupState) -> tuple[np.ndarray, LookupState]:
        """One control cycle (see :meth:`step_detail`, without its details)."""
        on, nxt, detail = self.step_detail(nav, state)
        if self.rows_fired is not None:
            # A row's times are used only where a new firing starts (``axis_new``).
            started = np.flatnonzero(detail["axis_new"].any(axis=1))
            self.rows_fired[started, detail["case"][started]] = True
        return on, nxt

    def step_detail(
        self, nav: NavState, state: LookupState, case_scale: np.ndarray | None = None
    ) -> tuple[np.ndarray, LookupState, dict]:
        """One control cycle, with what it decided (for controllers built on this one).

        Parameters
        ----------
        nav : NavState
            Errors at the cycle start (arrays over ``n_runs``).
        state : LookupState
        case_scale : ndarray, (n_runs, n_cases, 3), optional
            Per run, table row and axis, a factor on that axis's firing times (what an
            adaptive controller has learned, :mod:`rcsim.lookup.adaptive`); default 1.

        Returns
        -------
        on_time_s : ndarray, (n_runs, 16)
            On-time of each jet this cycle [s], in ``[0, cycle]`` (a channel table: of each of
            the vehicle's jets, through the recipe).
        state : LookupState
        detail : dict
            ``case`` (n_runs,) table row selected; ``need`` (n_runs, 3) rate change asked for
            [rad/s]; ``axis_new`` (n_runs, 3) bool, a new firing started on the axis;
            ``axis_done`` (n_runs, 3) bool, the axis's firing ended this cycle.
        """
        p = self.params
        e = nav.att_err_B
        theta = np.sqrt(np.einsum("ij,ij->i", e, e))  # total attitude error [rad], (n,)
        maneuver = self.maneuvering(theta, state.maneuvering)
        # The same arithmetic as below, compiled (bit for bit); a channel table's delivery
        # (recipe, shared-jet scaling, owed short shares) is numpy's alone.
        if kernel_available() and self._channels is None:
            on, rem_next, hold, need, case, axis_new, axis_done = kernel_step(
                e,
                theta,
                nav.rate_err_B,
                state.remaining_s,
                state.hold_s,
                maneuver,
                self._times,
                case_scale,
                *self._kernel_roles,
                (
                    p.maneuver_limit_rad,
                    p.maneuver_rate_rad_s,
                    p.rate_error_limit_rad_s,
                    p.no_fire_band_rad,
                    p.on_time_limit_s,
                    p.cycle_s,
                    p.hold_time_s,
                    _TIMER_EPS_S,
                ),
            )
            detail = {"case": case, "need": need, "axis_new": axis_new, "axis_done": axis_done}
            nxt = LookupState(remaining_s=rem_next, hold_s=hold, maneuvering=maneuver)
            return on, nxt, detail
        err = self.rate_error(nav, theta[:, None], maneuver)
        need = -err  # rate change the vehicle needs
        code = ((np.sign(need).astype(int) + 1) * np.array([9, 3, 1])).sum(axis=1)
        any_err = np.any(need != 0, axis=1)
        case = self._case_of_code[np.where(any_err, code, 0)]  # code 0 = (-,-,-), a valid row
        denom = self._rate_abs[case]  # (n, 3); zero where the case commands no rate
        scale = np.divide(np.abs(need), denom, out=np.zeros_like(need), where=denom > 0)
        jet_scale = scale @ self._axis_onehot.T  # (n, 16): scale of each jet's axis
        new = np.where(any_err[:, None], self._case_times(case, case_scale) * jet_scale, 0.0)

        no_fire = np.abs(theta - p.maneuver_limit_rad) < p.no_fire_band_rad  # (n,)

        rem = state.remaining_s
        group_max = np.zeros((rem.shape[0], 2 * N_AXES + 1))
        for g, jets in enumerate(self._group_jets):  # 6 groups, not runs
            if jets.size:
                group_max[:, g] = rem[:, jets].max(axis=1)
        opp_max = group_max[:, self._opp_group]  # (n, 16): max remaining on opposing jets
        hold_jet = state.hold_s @ self._axis_onehot.T  # (n, 16)
        gate = (
            (rem < p.on_time_limit_s)
            & (opp_max < p.on_time_limit_s)
            & (hold_jet <= _TIMER_EPS_S)
            & ~no_fire[:, None]
        )
        fire_new = gate & (new > 0)
        # An axis with a new firing is re-planned: new times on its firing jets, 0 elsewhere.
        axis_new = (fire_new.astype(float) @ self._axis_onehot) > 0  # (n, 3)
        replan = (axis_new.astype(float) @ self._axis_onehot.T) > 0  # (n, 16)
        rem = np.where(replan, np.where(fire_new, new, 0.0), rem)

        valves = None
        if self._channels is None:
            on = np.minimum(rem, p.cycle_s)
            rem_next = np.maximum(rem - p.cycle_s, 0.0)
            out = on
        else:
            # Channels: the jets get the recipe's shares; a channel counts down by the time
            # delivered (less than the cycle when shared jets were scaled).
            assert state.valves is not None
            out, on, valves = self._channels.deliver(rem, state.valves)
            rem_next = rem - on
            rem_next = np.where(rem_next > _TIMER_EPS_S, rem_next, 0.0)
        # Hold starts when an axis's firing ends (it fired this cycle and nothing remains).
        fired = (on.astype(bool).astype(float) @ self._axis_onehot) > 0
        left = ((rem_next > 0).astype(float) @ self._axis_onehot) > 0
        hold = np.where(fired & ~left, p.hold_time_s, np.maximum(state.hold_s - p.cycle_s, 0.0))
        detail = {"case": case, "need": need, "axis_new": axis_new, "axis_done": fired & ~left}
        nxt = LookupState(remaining_s=rem_next, hold_s=hold, valves=valves, maneuvering=maneuver)
        return out, nxt, detail
