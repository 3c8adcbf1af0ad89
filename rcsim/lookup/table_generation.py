"""Generate the pattern-recognition lookup table by simulation (Gambone sec. II, Tables 3, 6).

For each of the 26 rate cases (Table 3; at the vehicle profile's ``rate_case_deg_s``,
:func:`rcsim.models.tables.rate_cases_at`) the nominal vehicle is flown from rest with the case's
rate command and a *rate-command firing loop*: on every commanded axis the jets of the jet map
(the vehicle's own, from its geometry: Table 2 for the paper's) whose torque points along the
command fire for whole control cycles (the profile's, 40 ms) until the measured
rate reaches or passes the command on that axis (the paper: "the simulations were run until
thrusters were fired to reach the desired rate").  The firing time of the axis is the whole
number of cycles whose *measured* end rate is nearest the command -- the last cycle before the
crossing or the crossing cycle, whichever ends closer.  No mass property enters: the rates are
read from the simulation.

Every row is then checked and, where it misses, tuned in closed loop: the nominal vehicle flies
each case under the lookup controller with the table, and a case whose row leaves an axis
farther from its command than a fraction of the failure threshold gets a neighbouring
whole-cycle row that meets it, or is named with the reason it cannot
(:mod:`rcsim.lookup.row_tuning`; the paper's vehicle keeps every row).

The table is then *verified* by flying it open loop (every jet fires its table time from rest):
the residual rate error per axis and the rate settling time after firing
(``settle_after_firing_s``: time from the end of the firing until every axis stays within
``settle_tol_rad_s`` of the command) are recorded.

The rate-damping property (paper Figs 3-4) is shown the same way: start at each case's rate with
a zero rate command and let the same firing loop null it; the firing times needed are equal to
the maneuver table's, on the opposing jets.

Generation may use the jet map (it happens in simulation, where the vehicle is known); the
controller that uses the table (:mod:`rcsim.lookup.pattern_recognition`) never does.

A jet table has the paper's 16 columns: it is for a vehicle whose jets play Table 2's roles.
Any other layout gets a channel table (:mod:`rcsim.lookup.channel_generation`);
:func:`rcsim.lookup.generation.generate_table` picks the one that fits.  The comparison with the
paper's tables is in :mod:`rcsim.lookup.table_compare`.

Failed jets: ``generate_table(vehicle, jets_off=(13, 15))`` flies the vehicle with those jets
failed off (:class:`rcsim.spacecraft.valves.JetFaults`) and fires only the jets left: a pair with
one jet gone fires its remaining jet alone (twice as long, with a translation side effect); an axis
direction with no jet left cannot be commanded, and its cases fire nothing on that axis
(``GeneratedTable.unreachable``).  The companion file records the jets off, the unreachable
axes and each case's translation side effect (velocity change of the CG, body axes), and the
table checks and loads against the jet map without those jets
(:func:`rcsim.lookup.jet_sets.jet_map_without`).

Valve timing (a vehicle file's delays, ``generate_table(timing=...)``): every flight above flies
them, and since the firing loop's cycle-end rates then lag what a row of that many cycles
delivers, the rows are chosen among the loop's neighbours flown open loop
(:mod:`rcsim.lookup.table_candidates`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from rcsim.lookup.jet_sets import check_jets_off, jet_map_without
from rcsim.lookup.open_loop import OpenLoopController
from rcsim.lookup.row_tuning import (
    DEFAULT_ROUNDS,
    DEFAULT_TARGET_FRACTION,
    NominalCheck,
    RowTuner,
    check_target_fraction,
    cycle_steps,
    vehicle_threshold_deg_s,
)
from rcsim.lookup.table_candidates import nearest_rows
from rcsim.models.errors import InputError
from rcsim.models.tables import (
    LookupTable,
    RateCases,
    check_consistency,
    load_jet_map,
    rate_cases_at,
)
from rcsim.spacecraft.navigation import Guidance, NavState
from rcsim.spacecraft.simulation import History, simulate_batch
from rcsim.spacecraft.valves import JetFaults, ValveTiming
from rcsim.spacecraft.vehicle.model import AXES, N_JETS, jet_geometry_B
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle


# ------------------------------------------------------------------------------------------
# Open-loop controllers used only for generation (they know the jet map).
# ------------------------------------------------------------------------------------------
class RateFiringLoop:
    """Fire whole cycles on each commanded axis until the rate reaches its command.

    Per run and axis, the direction is fixed at the first cycle: ``d = -sign(rate error)``
    (axes with zero initial error do not fire).  The axis keeps firing the jets whose jet-map
    sign equals ``d`` while ``d * rate_error < 0`` (short of the command) and stops for good
    at the first cycle that starts at or past it.

    Parameters
    ----------
    jet_map : ndarray of int, (16, 3)
        The vehicle's own Table 2 (torque sign of each jet about each axis).
    cycle_s : float
        Control cycle [s] (the vehicle's profile's).

    State: ``direction`` (n_runs, 3) in {-1, 0, +1} and ``done`` (n_runs, 3) bool.
    """

    def __init__(self, jet_map: np.ndarray, cycle_s: float):
        jm = np.asarray(jet_map, int)
        self._pos = (jm.T > 0).astype(float)  # (3, 16)
        self._neg = (jm.T < 0).astype(float)
        self.cycle_s = cycle_s

    def initial_state(self, n_runs: int):
        return {"direction": None, "done": np.zeros((n_runs, 3), bool)}

    def step(self, nav: NavState, state):
        err = nav.rate_err_B
        direction = -np.sign(err) if state["direction"] is None else state["direction"]
        done = state["done"] | (direction * err >= 0)
        fire = (~done) * direction  # (n, 3)
        on = ((fire > 0) @ self._pos + (fire < 0) @ self._neg) * self.cycle_s
        return on, {"direction": direction, "done": done}


# ------------------------------------------------------------------------------------------
# Results
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FiringSweep:
    """Per-axis firing cycles found by the firing loop for a batch of rate changes.

    Attributes
    ----------
    cycles : ndarray of int, (n_cases, 3)
        Whole control cycles chosen per axis (0 on axes that do not fire).
    end_rate_err_rad_s : ndarray, (n_cases, 3)
        Measured rate error after the chosen number of cycles [rad/s] (with valve timing, or
        a row the closed-loop tuning changed: after the row's open-loop flight,
        :mod:`rcsim.lookup.table_candidates`, :mod:`rcsim.lookup.row_tuning`).
    direction : ndarray of int, (n_cases, 3)
        Torque sign fired per axis.
    history : History
        The simulated flights.
    """

    cycles: np.ndarray
    end_rate_err_rad_s: np.ndarray
    direction: np.ndarray
    history: History


@dataclass(frozen=True)
class GeneratedTable:
    """A generated lookup table with its verification and the rate-damping check.

    Attributes
    ----------
    table : LookupTable
        Firing times (26, 16) [s], rate commands (26, 3) [rad/s].
    command : FiringSweep
        Firing loop from rest to each rate command.
    damping : FiringSweep
        Firing loop from each rate to a zero command.
    damping_firing_time_s : ndarray, (26, 16)
        Firing time per jet the damping runs needed [s].
    verify_rate_err_rad_s : ndarray, (26, 3)
        Rate error when the table is flown open loop, measured ``settle_window_s`` after the
        longest firing ends [rad/s].
    settle_after_firing_s : ndarray, (26,)
        Settling time *after the firing ends*: from the end of the case's longest firing
        until every axis stays within ``settle_tol_rad_s`` of the commanded rate (cycle
        resolution); NaN if it never does within the window.  Measured from the firing's end,
        not from t = 0, hence its own name (unlike a campaign's ``rate_settled_time_s`` or a
        scenario's ``att_rate_settled_time_s``, both measured from the start of the flight).
    settle_tol_rad_s : float
        Tolerance of the settling time [rad/s].
    jets_off : tuple of int
        Jets (1..16) the table was generated without; empty for the full vehicle.
    unreachable : ndarray of bool, (26, 3)
        Case axes that needed a jet direction no jet left serves (all False for the full
        vehicle).
    dv_B_m_s : ndarray, (26, 3)
        Velocity change of the CG from the case's firing, body axes [m/s] (the translation side
        effect; ~0 for pure couples).
    nominal : NominalCheck, optional
        The 26 cases flown closed loop with the table on the nominal vehicle, and the rows
        tuned to meet the target (:mod:`rcsim.lookup.row_tuning`).
    """

    table: LookupTable
    command: FiringSweep
    damping: FiringSweep
    damping_firing_time_s: np.ndarray
    verify_rate_err_rad_s: np.ndarray
    settle_after_firing_s: np.ndarray
    settle_tol_rad_s: float
    jets_off: tuple = ()
    unreachable: np.ndarray | None = None
    dv_B_m_s: np.ndarray | None = None
    nominal: NominalCheck | None = None

    @property
    def damping_equal(self) -> np.ndarray:
        """Per case: damping fires the same cycles on every axis as the command, opposite
        jets, shape (26,) bool."""
        same_cycles = np.all(self.damping.cycles == self.command.cycles, axis=1)
        opposite = np.all(self.damping.direction == -self.command.direction, axis=1)
        return same_cycles & opposite

    def settling_frame(self) -> pd.DataFrame:
        """The companion table ``generated_table_settling.csv`` (deg/s at this boundary)."""
        cols: dict[str, Any] = {"case": self.table.case}
        for a, axis in enumerate(AXES):
            cols[f"{axis}_cycles"] = self.command.cycles[:, a]
        for a, axis in enumerate(AXES):
            cols[f"end_rate_err_{axis}_deg_s"] = np.degrees(self.verify_rate_err_rad_s[:, a])
        cols["settle_after_firing_s"] = self.settle_after_firing_s
        cols["settle_tol_deg_s"] = np.degrees(self.settle_tol_rad_s)
        for a, axis in enumerate(AXES):
            cols[f"damping_{axis}_cycles"] = self.damping.cycles[:, a]
        cols["damping_equal_opposing"] = self.damping_equal
        if self.nominal is not None:
            nom = self.nominal
            cols["nominal_err_deg_s"] = np.degrees(nom.worst_rad_s)
            for a, axis in enumerate(AXES):
                cols[f"nominal_err_{axis}_deg_s"] = np.degrees(nom.rate_err_rad_s[:, a])
            cols["nominal_end_err_deg_s"] = np.degrees(np.abs(nom.end_rate_err_rad_s).max(axis=1))
            cols["nominal_firings"] = nom.firings
            cols["nominal_target_deg_s"] = np.degrees(nom.target_rad_s)
            cols["nominal_met"] = nom.met
            cols["nominal_flight_s"] = nom.flight_s
            cols["tuned"] = nom.tuned
            cols["unmet_reason"] = list(nom.reason)
        if self.jets_off:  # only tables for a reduced jet set carry these columns
            assert self.unreachable is not None and self.dv_B_m_s is not None
            cols["jets_off"] = " ".join(str(j) for j in self.jets_off)
            for a, axis in enumerate(AXES):
                cols[f"unreachable_{axis}"] = self.unreachable[:, a]
            for a, axis in enumerate("xyz"):
                cols[f"dv_{axis}_m_s"] = self.dv_B_m_s[:, a]
        return pd.DataFrame(cols)


# ------------------------------------------------------------------------------------------
# Generation
# ------------------------------------------------------------------------------------------
def sweep(
    rate_target_rad_s: np.ndarray,
    omega0_rad_s: np.ndarray,
    jet_map: np.ndarray,
    *,
    vehicle: Vehicle,
    params: RunParameters,
    max_fire_s: float,
    faults: JetFaults | None = None,
    timing: ValveTiming | None = None,
) -> FiringSweep:
    """Fly the firing loop for every row and pick the nearest whole number of cycles per axis.

    Parameters
    ----------
    rate_target_rad_s : ndarray, (n, 3)
        Commanded body rate per run [rad/s].
    omega0_rad_s : ndarray, (n, 3)
        Initial body rate per run [rad/s].
    jet_map : ndarray of int, (16, 3)
    vehicle : Vehicle
        The vehicle flown (model, cycle, valve limits).
    params : RunParameters
        ``n`` vehicles (its nominal one repeated, for a table).
    max_fire_s : float
        Longest firing tried [s]; an axis that has not reached its command by then raises,
        unless no jet of ``jet_map`` serves its direction (then it fires 0 cycles).
    faults : JetFaults, optional
        Jet faults to fly with (e.g. failed jets, whose rows ``jet_map`` should zero).
    timing : ValveTiming, optional
        The ``n`` runs' valve timing (the cycle-end rates then lag the thrust:
        :mod:`rcsim.lookup.table_candidates`); None: the vehicle's nominal timing.

    Returns
    -------
    FiringSweep

    Raises
    ------
    InputError
        An axis short of its command after ``max_fire_s`` (the jets too weak for the rate
        cases: a smaller ``rate_case_deg_s`` in the vehicle's ``[control]``).
    """
    target = np.atleast_2d(np.asarray(rate_target_rad_s, float))
    n = target.shape[0]
    loop = RateFiringLoop(jet_map, vehicle.control.cycle_s)
    hist = simulate_batch(
        params,
        loop,
        Guidance.rate(target),
        max_fire_s,
        omega0_B=np.asarray(omega0_rad_s, float).reshape(n, 3),
        vehicle=vehicle,
        faults=faults,
        timing=timing,
    )
    # err[:, k] = rate error after k cycles (k = 0 .. K), the last one from the final state.
    err = np.concatenate([hist.rate_err_B, hist.final.rate_err_B[:, None]], axis=1)
    direction = -np.sign(err[:, 0]).astype(int)
    reached = direction[:, None, :] * err >= 0  # (n, K+1, 3)
    # First k at or past the command; argmax of an all-False column is 0 -> checked below.
    k_cross = np.argmax(reached, axis=1)  # (n, 3)
    jm = np.asarray(jet_map, int)
    served = np.stack(
        [(jm[None, :, a] == direction[:, a, None]).any(axis=1) for a in range(3)], axis=1
    )  # (n, 3): some jet serves that direction
    commanded = (direction != 0) & served
    never = commanded & ~reached.any(axis=1)
    if never.any():
        run, axis = np.argwhere(never)[0]
        reached_rad_s = abs(float(target[run, axis] - err[run, -1, axis]))
        raise InputError(
            f"{vehicle.source}: {AXES[axis]} rate {np.degrees(abs(target[run, axis])):.4g} deg/s "
            f"of a rate case not reached in {max_fire_s:g} s of firing (reached "
            f"{np.degrees(reached_rad_s):.4g} deg/s): the jets are too weak for the profile's "
            f"rate_case_deg_s = {np.degrees(vehicle.control.rate_case_rad_s):.4g}; give a "
            "smaller one in the vehicle's [control] (or --control rate_case_deg_s=...)",
            parameter="vehicle",
            value=vehicle.ref,
        )
    rows = np.arange(n)[:, None]
    axes = np.arange(3)[None, :]
    after = np.abs(err[rows, k_cross, axes])
    before = np.abs(err[rows, np.maximum(k_cross - 1, 0), axes])
    cycles = np.where(commanded, np.where(before < after, k_cross - 1, k_cross), 0)
    cycles = np.maximum(cycles, 0)
    end_err = err[rows, cycles, axes]
    return FiringSweep(
        cycles=cycles.astype(int), end_rate_err_rad_s=end_err, direction=direction, history=hist
    )


def firing_times(
    cycles: np.ndarray, direction: np.ndarray, jet_map: np.ndarray, cycle_s: float
) -> np.ndarray:
    """Per-jet firing time [s], (n, 16), from per-axis cycles and torque signs (n, 3)."""
    jm = np.asarray(jet_map, int)
    times = np.zeros((cycles.shape[0], N_JETS))
    for a in range(3):  # three axes; each jet of the map torques at most one
        on_axis = (jm[None, :, a] == direction[:, a, None]) & (jm[None, :, a] != 0)
        times += on_axis * (cycles[:, a, None] * cycle_s)
    return times


def settle_after_firing(verify: History, fire_end_s: np.ndarray, tol_rad_s: float) -> np.ndarray:
    """Per run, the time from the end of its firing (``fire_end_s``, (n,) [s]) until every axis
    stays within ``tol_rad_s`` of the command (cycle resolution), NaN if it never does
    (:attr:`GeneratedTable.settle_after_firing_s`)."""
    cyc = verify.cycle_s
    err = np.concatenate([verify.rate_err_B, verify.final.rate_err_B[:, None]], axis=1)
    t = np.append(verify.t_s, verify.t_s[-1] + cyc)
    outside = np.abs(err).max(axis=2) > tol_rad_s  # (n, K+1)
    after_fire = t[None, :] >= fire_end_s[:, None] - 1e-9
    # Settled from the first sample after the firing from which no later sample is outside.
    last_out = np.where(outside & after_fire, t[None, :], -np.inf).max(axis=1)
    settle_at = np.array(
        [
            t[(t >= fire_end_s[i] - 1e-9) & (t > last_out[i])].min()
            if np.any((t >= fire_end_s[i] - 1e-9) & (t > last_out[i]))
            else np.nan
            for i in range(len(fire_end_s))  # 26 cases, post-processing only
        ]
    )
    return settle_at - fire_end_s


def generate_jet_table(
    vehicle: Vehicle,
    *,
    jets_off=(),
    rate_cases: RateCases | None = None,
    settle_window_s: float = 2.0,
    max_fire_s: float = 3.0,
    target_fraction: float = DEFAULT_TARGET_FRACTION,
    threshold_deg_s: float | None = None,
    tune_rounds: int = DEFAULT_ROUNDS,
) -> GeneratedTable:
    """Generate, tune, verify and damping-check the lookup table of a vehicle whose jets play
    Table 2's roles (the paper's 16-jet layout, any mass, arms and thrust).

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle: its nominal parameters, jet geometry (its own Table 2), valve limits and
        timing, and its profile's cycle (firing times are whole multiples of it), rate-case
        magnitude and rate deadband (the settling tolerance: the rate error the lookup
        controller treats as "reached").
    jets_off : sequence of int
        Jets (numbered 1..16) failed off: the vehicle is flown without them and the table
        fires only the others (module docstring).
    rate_cases : RateCases, optional
        The 26 rate commands (default: the profile's, :func:`rcsim.models.tables.rate_cases_at`).
    settle_window_s : float
        How long the verification flight continues after the longest firing [s].
    max_fire_s : float
        Longest firing the firing loop tries [s].
    target_fraction : float
        Every case is tuned in closed loop to end within this fraction of ``threshold_deg_s``
        on every axis, in one firing (:mod:`rcsim.lookup.row_tuning`), in (0, 1].
    threshold_deg_s : float, optional
        The failure threshold on a case's final rate error [deg/s]; default the vehicle
        file's own ``[failure] rate_error_deg_s``, else the paper's 0.04 deg/s.
    tune_rounds : int
        Rounds of the closed-loop search (0: the paper's rule's rows as they are, still
        checked in closed loop).

    Returns
    -------
    GeneratedTable

    Raises
    ------
    InputError
        ``jets_off`` names a jet outside 1..16 or twice; the vehicle's jets do not play
        Table 2's roles (:func:`rcsim.lookup.generation.generate_table` gives it a channel
        table); a rate case the jets cannot reach.
    """
    from rcsim.spacecraft.vehicle.authority import jet_map_mismatch

    differs = jet_map_mismatch(vehicle.definition, load_jet_map())
    if differs:
        raise InputError(
            f"{vehicle.source}: a jet table fires the paper's jet map (Table 2), but {differs}; "
            "this vehicle gets a channel table (rcsim.generate_table, `rcsim lookup generate "
            "--vehicle`)",
            parameter="vehicle",
            value=vehicle.ref,
        )
    control = vehicle.control
    settle_tol_rad_s = control.rate_deadband_rad_s
    timing = vehicle.timing(1)
    rate_cases = rate_cases_at(control.rate_case_rad_s) if rate_cases is None else rate_cases
    jets_off = check_jets_off(jets_off)
    jet_map = jet_map_without(vehicle.axis_signs, jets_off)
    model = vehicle.model
    n = len(rate_cases.case)
    batch = vehicle.nominal(1).take(np.zeros(n, int))
    rate = np.asarray(rate_cases.rate_cmd, float)
    cyc = control.cycle_s
    faults = None
    if jets_off:
        off = np.full((n, N_JETS), np.inf)
        off[:, np.asarray(jets_off) - 1] = 0.0
        faults = JetFaults.of(n, off_from_s=off)
    delays = None if timing is None or timing.is_zero() else timing.take(np.zeros(n, int))
    flying: dict[str, Any] = dict(params=batch, vehicle=vehicle)

    def loop(target: np.ndarray, omega0: np.ndarray) -> FiringSweep:
        found = sweep(
            target,
            omega0,
            jet_map,
            max_fire_s=max_fire_s,
            faults=faults,
            timing=delays,
            **flying,
        )
        if delays is None:
            return found
        cycles, end_err = nearest_rows(
            found.cycles,
            found.direction,
            target,
            omega0,
            jet_map,
            lambda c, d: firing_times(c, d, jet_map, cyc),
            timing=delays,
            faults=faults,
            settle_window_s=settle_window_s,
            **flying,
        )
        return FiringSweep(cycles, end_err, found.direction, found.history)

    command = loop(rate, np.zeros_like(rate))
    sign = np.sign(rate).astype(int)
    served = (sign != 0) & np.stack(
        [(jet_map[None, :, a] == sign[:, a, None]).any(axis=1) for a in range(3)], axis=1
    )
    tuner = RowTuner(
        LookupTable(case=rate_cases.case, rate_cmd=rate, firing_time_s=np.zeros((n, N_JETS))),
        served,
        lambda c, d: firing_times(c, d, jet_map, cyc),
        vehicle=vehicle,
        stretch=1.0,
        settle_window_s=settle_window_s,
        faults=faults,
        timing=delays,
        jets_off=jets_off,
        cycle_step_rad_s=cycle_steps(command.history),
    )
    cycles, nominal = tuner.tune(
        command.cycles,
        target_fraction=check_target_fraction(target_fraction),
        threshold_rad_s=float(np.radians(vehicle_threshold_deg_s(vehicle, threshold_deg_s))),
        rounds=tune_rounds,
    )
    command = replace(command, cycles=cycles)
    times = firing_times(command.cycles, command.direction, jet_map, cyc)
    check_consistency(rate_cases.case, rate, times, jet_map, file="<generated table>", cycle_s=cyc)
    source = "generated by rcsim.lookup.table_generation" + (
        f" without jets {', '.join(map(str, jets_off))}" if jets_off else ""
    )
    table = LookupTable(case=rate_cases.case, rate_cmd=rate, firing_time_s=times, source=source)

    damping = loop(np.zeros_like(rate), rate)
    damping_times = firing_times(damping.cycles, damping.direction, jet_map, cyc)

    # Verification: fly the table open loop under the rate command, then watch the rate.
    fire_end = times.max(axis=1)  # (26,), pairs end together; axes may end earlier
    verify = simulate_batch(
        batch,
        OpenLoopController(times, cyc),
        Guidance.rate(rate),
        float(fire_end.max()) + settle_window_s,
        vehicle=vehicle,
        faults=faults,
        timing=delays,
    )
    settle = settle_after_firing(verify, fire_end, settle_tol_rad_s)
    unreachable = (
        (np.sign(rate) != 0)
        & (command.cycles == 0)
        & np.stack(
            [~(jet_map[None, :, a] == np.sign(rate)[:, a, None]).any(axis=1) for a in range(3)],
            axis=1,
        )
    )
    # Translation side effect: the jets' summed force impulse over the vehicle mass, in B
    # (the firings are short and the attitude barely moves while they last).
    _, dir_B = jet_geometry_B(model)
    impulse_B = (verify.propulsion.impulse_ns[:, :, None] * dir_B[None]).sum(axis=1)
    # A tuned row's end rate is its verification flight's (the firing loop never flew it).
    tuned = nominal.tuned[:, None]
    end_err = np.where(tuned, verify.final.rate_err_B, command.end_rate_err_rad_s)
    command = replace(command, end_rate_err_rad_s=end_err)
    return GeneratedTable(
        table=table,
        command=command,
        damping=damping,
        damping_firing_time_s=damping_times,
        verify_rate_err_rad_s=verify.final.rate_err_B.copy(),
        settle_after_firing_s=settle,
        settle_tol_rad_s=float(settle_tol_rad_s),
        jets_off=jets_off,
        unreachable=unreachable,
        dv_B_m_s=impulse_B / batch.mass_kg[:, None],
        nominal=nominal,
    )
