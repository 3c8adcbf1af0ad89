"""The allocator controller (``--controller allocator``): coupling-aware jet selection.

Gambone sec. IV's next step: pick jets from each jet's own response so that any layout can be
flown and a jet's coupled torque is cancelled by others ("if a pitch thruster generates roll
torque, a roll thruster must fire to cancel that torque").  Each control cycle, batched over
runs (no Python loop over runs):

1. the rate change the logic acts on, ``need = -(omega - target)``, with the lookup
   controller's maneuver rule: in a maneuver the target is the commanded rate plus the
   maneuver rate toward the commanded attitude (the vehicle's profile,
   :class:`rcsim.spacecraft.vehicle.ControlProfile`).  A maneuver starts when the total
   attitude error exceeds ``maneuver_limit_deg`` and ends when it falls below the limit minus
   ``maneuver_hysteresis_deg`` (0 for the paper: enter and leave at the limit);
2. dead band: no new plan while ``max |need| < deadband`` (the profile's
   ``allocator.rate_deadband_deg_s``, 0.004 deg/s for the paper's vehicle: a tenth of the
   0.04 deg/s success threshold of the rate cases, so a run settles well inside it);
3. plan: the on-times ``t`` for all of ``need`` from the allocator
   (:class:`rcsim.lookup.allocator.Allocator`, nominal jet model, the profile's ``allocation``
   objective) over the available jets, every total 0 or at least the jet's minimum delivered
   pulse (the optimisation honours it: nothing is dropped or deferred after solving).  No
   trim pairs: a plan that needs a minimum pulse (its LP relaxation has a total below the
   minimum) is not fired while ``max |need|`` is below ``allocator.trim_deadband_deg_s``;
4. the plan is flown over ``L = ceil(max t / cycle)`` cycles: jet ``j`` fires ``p_j`` equal
   pulses of ``t_j / p_j``, ``p_j = min(L, floor(t_j / t_min_j))`` (``L`` when it has no
   minimum), spread evenly over the ``L`` cycles from the first, so the coupled torques cancel
   within every cycle when the minimum allows it (every jet then fires ``t / L`` each cycle)
   and over the plan otherwise (every jet of the plan fires in its first cycle), and no pulse
   is below the minimum;
5. valve delays (the vehicle file's nominal ``open_delay_s`` / ``close_delay_s``, lag
   ``d_o - d_c``): an *opening* of the valve commanded ``u`` in all thrusts ``u - lag``
   (:mod:`rcsim.spacecraft.valves`), and a full-cycle command continues into the next
   cycle's without a new opening.  So the lag is planned per opening, not per pulse: a pulse
   that starts an opening is commanded its planned delivered time plus the lag; a command
   cut at the full cycle carries what it could not command into the next cycle, where the
   opening continues (the jet fires then even if its pulses do not, and a plan is not done
   while anything is carried); a pulse in a cycle that continues an opening (the previous
   command was the full cycle) is commanded its planned time alone; and a lagging valve
   whose command would fall short of the full cycle by less than the lag stays open into
   the next cycle when the jet fires there (the shortfall commanded then: one lag, not
   two).  The minimum delivered pulse is ``max(min_on - lag, 0)``, and a planned total
   below :data:`NOTHING_S` is no pulse: every pulse commanded delivers what was planned, to
   rounding;
6. when the plan is done, re-plan from the measured rate (receding horizon): model error and
   dispersions are corrected by feedback.

State (:class:`AllocatorState`): the plan's pulse lengths and counts, its length and the
cycles flown, and whether a maneuver is being flown.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from rcsim.lookup.allocator import Allocator, allocation_prices
from rcsim.models.errors import InputError
from rcsim.spacecraft.propellant import full_inertia
from rcsim.spacecraft.vehicle.model import BODY
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2, RunParameters, torque_per_jet_B

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle

#: Cycles to wait before re-planning when no rounding of a plan helps.
GIVE_UP_CYCLES = 5
#: A planned total on-time below this [s] is no pulse (LP round-off, not a firing).
NOTHING_S = 1e-9


def _fires(k, pulses, length):
    """``ceil(k p / L)``: jet pulses of the plan begun before cycle ``k`` (step 4's spread)."""
    return -((-k * pulses) // length)


def jet_model(model: mujoco.MjModel, isp_s: float):
    """The nominal jet model of a vehicle of ``n`` jets (the model's,
    :func:`rcsim.spacecraft.vehicle.model.jet_count`) whose jets have specific impulse
    ``isp_s`` [s]:
    ``D`` (3, n) [rad/s per s], ``G`` (3, n) [m/s per s], ``mdot`` (n,) [kg/s], mass [kg]; from
    the compiled model (full inertia, with its principal frame ``body_iquat``)."""
    params = RunParameters.nominal(1, model, isp_s=isp_s)
    torque = torque_per_jet_B(params, model)[0]  # (n, 3) about the CG [N m]
    inertia = full_inertia(params.inertia_B, model.body_iquat[model.body(BODY).id])[0]
    D = np.linalg.solve(inertia, torque.T)
    force = np.einsum(
        "jab,jb->ja",
        _site_rotations(model),
        params.jet_dir_S[0] * params.thrust_n[0][:, None],
    )
    G = force.T / params.mass_kg[0]
    mdot = params.thrust_n[0] / (isp_s * G0_M_S2)
    return D, G, mdot, float(params.mass_kg[0])


def _site_rotations(model: mujoco.MjModel) -> np.ndarray:
    from rcsim.spacecraft.flight_model import jet_sites_B

    return jet_sites_B(model)[1]


@dataclass
class AllocatorState:
    """Per-run plan state, arrays ``(n_runs, n_jets)`` unless said.

    ``pulse_s``: delivered length of each of the plan's pulses of a jet [s]; ``pulses``: how
    many pulses the jet fires in the plan; ``cycles`` (n_runs,): the plan's length in cycles;
    ``flown`` (n_runs,): cycles of it flown; ``maneuvering`` (n_runs,) bool: a maneuver is
    being flown (step 1's hysteresis); ``carried_s``: command the open valve still owes
    (step 5) [s]; ``full``: the jet's last command was the full cycle (its valve stays open
    if the next command fires it)."""

    pulse_s: np.ndarray
    pulses: np.ndarray
    cycles: np.ndarray
    flown: np.ndarray
    maneuvering: np.ndarray
    carried_s: np.ndarray
    full: np.ndarray


class AllocatorController:
    """Batched allocator controller (module docstring).

    Parameters
    ----------
    allocator : Allocator
        Its ``t_min`` is the minimum *delivered* pulse of each jet (module docstring, step 5).
    maneuver_limit_rad, maneuver_rate_rad_s : float
        The maneuver rule [rad, rad/s] (the vehicle's profile).
    deadband_rad_s : float
        No new plan below this rate error on every axis [rad/s] (the profile's).
    cycle_s : float
        Control cycle [s] (the profile's).
    hysteresis_rad : float
        A maneuver ends below ``maneuver_limit_rad - hysteresis_rad`` [rad]; default 0.
    trim_deadband_rad_s : float
        No plan needing a minimum pulse below this rate error on every axis [rad/s]; default 0.
    lag_s : ndarray, (n_jets,), optional
        Open minus close delay of each jet's valve [s], added to every commanded pulse.
    available : ndarray of bool, (n_jets,) or (n_runs, n_jets), optional
        The jets the controller may use (``--jets-off``); default all.
    """

    def __init__(
        self,
        allocator: Allocator,
        *,
        maneuver_limit_rad: float,
        maneuver_rate_rad_s: float,
        deadband_rad_s: float,
        cycle_s: float,
        hysteresis_rad: float = 0.0,
        trim_deadband_rad_s: float = 0.0,
        lag_s=None,
        available=None,
    ):
        self.allocator = allocator
        self.n = allocator.n
        self.maneuver_limit_rad = maneuver_limit_rad
        self.maneuver_rate_rad_s = maneuver_rate_rad_s
        self.deadband_rad_s = deadband_rad_s
        self.hysteresis_rad = hysteresis_rad
        self.trim_deadband_rad_s = trim_deadband_rad_s
        self.lag_s = np.zeros(self.n) if lag_s is None else np.broadcast_to(lag_s, (self.n,))
        self.available = None if available is None else np.asarray(available, bool)
        self.cycle_s = cycle_s

    def solver_counts(self) -> dict[str, int]:
        """The allocator's solver work so far (:meth:`rcsim.lookup.allocator.Allocator.counts`:
        LPs, branch-and-bound searches and nodes, exact MILP solves)."""
        return self.allocator.counts()

    def initial_state(self, n_runs: int) -> AllocatorState:
        z = np.zeros((n_runs, self.n))
        zi = np.zeros(n_runs, int)
        return AllocatorState(
            z, z.astype(int), zi, zi.copy(), np.zeros(n_runs, bool), z.copy(), z.astype(bool)
        )

    def step(self, nav, state: AllocatorState) -> tuple[np.ndarray, AllocatorState]:
        """On-times this cycle (n_runs, n_jets) [s] and the next state."""
        n_runs = nav.rate_err_B.shape[0]
        e = nav.att_err_B
        theta = np.linalg.norm(e, axis=1, keepdims=True)
        toward = np.where(theta > 0, e / np.where(theta > 0, theta, 1.0), 0.0)
        limit = self.maneuver_limit_rad
        maneuvering = (theta[:, 0] > limit) | (
            state.maneuvering & (theta[:, 0] > limit - self.hysteresis_rad)
        )
        maneuver = maneuvering[:, None]
        need = -(nav.rate_err_B + np.where(maneuver, self.maneuver_rate_rad_s * toward, 0.0))
        pulse, pulses = state.pulse_s.copy(), state.pulses.copy()
        cycles, flown = state.cycles.copy(), state.flown.copy()
        size = np.abs(need).max(axis=1)
        owed = (state.carried_s != 0).any(axis=1)
        plan = (flown >= cycles) & (size >= self.deadband_rad_s) & ~owed
        if plan.any():
            idx = np.flatnonzero(plan)
            avail = None
            if self.available is not None:
                avail = np.broadcast_to(self.available, (n_runs, self.n))[idx]
            t = self._plan(need[idx], avail, size[idx])
            t = np.where(t >= NOTHING_S, t, 0.0)
            longest = t.max(axis=1)
            n_cyc = np.maximum(np.ceil(longest / self.cycle_s - 1e-9), 1).astype(int)
            n_cyc = np.where(longest > 0, n_cyc, GIVE_UP_CYCLES)
            t_min = self.allocator.t_min
            fit = np.floor(t / np.where(t_min > 0, t_min, 1.0) * (1 + 1e-12)).astype(int)
            count = np.where(t_min > 0, np.minimum(n_cyc[:, None], fit), n_cyc[:, None])
            count = np.where(t > 0, np.maximum(count, 1), 0)
            pulse[idx] = np.where(count > 0, t / np.maximum(count, 1), 0.0)
            pulses[idx] = count
            cycles[idx] = n_cyc
            flown[idx] = 0
        # Jet j fires in cycle k of L when ceil((k+1) p / L) > ceil(k p / L): p pulses, evenly,
        # the first in cycle 0 (every jet of the plan fires in its first cycle).
        active = (flown < cycles)[:, None]
        length = np.maximum(cycles, 1)[:, None]
        k = flown[:, None]
        fires = active & (_fires(k + 1, pulses, length) > _fires(k, pulses, length))
        planned = np.where(fires & (pulse > 0), pulse, 0.0)  # delivered time wanted [s]
        # Step 5: the lag once per opening.  The valve is still open when the last command
        # filled its cycle and this one fires: then what it owes and this pulse, no new lag.
        carried = state.carried_s
        same = state.full & ((planned > 0) | (carried != 0))
        want = np.where(same, carried + planned, np.where(planned > 0, planned + self.lag_s, 0.0))
        # A lagging valve stays open into the next cycle when the jet fires there, this cycle
        # wants all but less than the lag of it, and the two cycles' wants fill it: the
        # shortfall now (under the lag) is commanded then, and the opening pays its lag once
        # instead of twice.  Without a lag nothing is saved, and every cycle keeps its own
        # share (the coupled torques cancel within each cycle).
        lagging = (self.lag_s > 0) & (want >= self.cycle_s - self.lag_s)
        following = (k + 1 < length) & (
            _fires(k + 2, pulses, length) > _fires(k + 1, pulses, length)
        )
        stay = (want > 0) & following & (pulse > 0) & (want + pulse >= self.cycle_s) & lagging
        u = np.where(stay, self.cycle_s, np.minimum(want, self.cycle_s))
        carried = want - u
        full = u >= self.cycle_s * (1.0 - 1e-12)  # as the propulsion model continues a firing
        flown = np.where(flown < cycles, flown + 1, flown)
        return u, AllocatorState(pulse, pulses, cycles, flown, maneuvering, carried, full)

    def _plan(self, need: np.ndarray, available, size: np.ndarray) -> np.ndarray:
        """The allocator's totals for ``need`` (rows of runs that plan), with the trim rule:
        a run below the trim deadband whose plan needs a minimum pulse gets none."""
        alloc = self.allocator
        if not alloc.t_min.any() or self.trim_deadband_rad_s <= 0:
            return alloc.allocate(need, available)[0]
        t, _ = alloc.allocate_relaxed(need, available)
        trim = (size < self.trim_deadband_rad_s) & ((t > 0) & (t < alloc.t_min)).any(axis=1)
        rows = np.flatnonzero(~trim)
        out = np.zeros_like(t)
        if rows.size:
            sub = None if available is None else available[rows]
            out[rows] = alloc.allocate(need[rows], sub, relaxed=t[rows])[0]
        return out


def allocator_controller(
    vehicle: Vehicle, *, jets_off=(), allocation: str | None = None
) -> AllocatorController:
    """The allocator controller of ``vehicle`` (any number of jets): the objective of its
    profile's ``allocation`` (or ``allocation`` given here), its minimum on-time and valve
    delays honoured, jets ``jets_off`` (1-based numbers) never used; the maneuver rule,
    hysteresis, deadbands and cycle of the vehicle's profile.

    Raises
    ------
    InputError
        A number in ``jets_off`` that is not a jet of the vehicle.
    """
    control = vehicle.control
    D, G, mdot, mass = jet_model(vehicle.model, vehicle.isp_s)
    w_v = allocation_prices(allocation or control.allocation, mass, vehicle.isp_s, G0_M_S2)
    lag = np.zeros(D.shape[1])
    timing = vehicle.timing(1)
    if timing is not None:
        timing = timing.for_jets(D.shape[1])
        lag = timing.open_delay_s[0] - timing.close_delay_s[0]
    t_min = np.maximum(vehicle.min_on_s - lag, 0.0)
    allocator = Allocator(D, mdot, G=G, w_v=w_v, t_min_s=t_min)
    available = None
    if len(jets_off):
        n_jets = D.shape[1]
        bad = [j for j in jets_off if not 1 <= int(j) <= n_jets]
        if bad:
            raise InputError(
                f"no jet {bad[0]}: the vehicle has jets 1..{n_jets}",
                parameter="jets_off",
                value=list(jets_off),
            )
        available = np.ones(n_jets, bool)
        available[np.asarray(jets_off, int) - 1] = False
    return AllocatorController(
        allocator,
        maneuver_limit_rad=control.maneuver_limit_rad,
        maneuver_rate_rad_s=control.maneuver_rate_rad_s,
        deadband_rad_s=control.allocator_rate_deadband_rad_s,
        cycle_s=control.cycle_s,
        hysteresis_rad=control.maneuver_hysteresis_rad,
        trim_deadband_rad_s=control.allocator_trim_deadband_rad_s,
        lag_s=lag,
        available=available,
    )
