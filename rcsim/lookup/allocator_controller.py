"""The allocator controller (``--controller allocator``): coupling-aware jet selection.

Gambone sec. IV's next step: pick jets from each jet's own response so that any layout can be
flown and a jet's coupled torque is cancelled by others ("if a pitch thruster generates roll
torque, a roll thruster must fire to cancel that torque").  Each control cycle, batched over
runs (no Python loop over runs):

1. the rate change the logic acts on, ``need = -(omega - target)``, with the lookup
   controller's maneuver rule: above the maneuver limit the target is the commanded rate plus
   the maneuver rate toward the commanded attitude (the vehicle's profile,
   :class:`rcsim.spacecraft.vehicle_file.ControlProfile`; the paper's Table 4 values for the
   paper's vehicle);
2. dead band: no new plan while ``max |need| < deadband`` (the profile's
   ``allocator.rate_deadband_deg_s``, 0.004 deg/s for the paper's vehicle: a tenth of the
   0.04 deg/s success threshold of the rate cases, so a run settles well inside it);
3. plan: the minimum-propellant on-times ``t`` for all of ``need`` from the allocator
   (:class:`rcsim.lookup.allocator.Allocator`, nominal jet model) over the available jets, rounded
   so that every jet's total is 0 or at least the minimum on-time by the profile's minimum
   pulse policy (``min_pulse``): ``accumulate``, all ``2^k`` roundings of the ``k`` short jets
   scored by the rate error they leave; ``round-up``, every short total to the minimum;
   ``drop``, every short total to 0;
4. the plan is spread over ``L = ceil(max t / cycle)`` cycles, every cycle firing ``t / L`` of
   each jet, so the coupled torques cancel within every cycle, not only at the plan's end; a
   share below the minimum on-time is owed and fired as one pulse when it reaches it;
5. when the plan is done, re-plan from the measured rate (receding horizon): model error,
   rounding and dispersions are corrected by feedback.

State (:class:`AllocatorState`): the plan's per-cycle shares, the owed short pulses, the
cycles left and which jets ended the last cycle on.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from rcsim.lookup.allocator import Allocator
from rcsim.models.errors import InputError
from rcsim.spacecraft.control_profile import MIN_PULSE_POLICIES
from rcsim.spacecraft.propellant import full_inertia
from rcsim.spacecraft.vehicle import BODY, G0_M_S2, VehicleParams, torque_per_jet_B

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle_file import Vehicle

#: Cycles to wait before re-planning when no rounding of a plan helps.
GIVE_UP_CYCLES = 5


def jet_model(model: mujoco.MjModel, isp_s: float):
    """The nominal jet model of a vehicle of ``n`` jets (the model's,
    :func:`rcsim.spacecraft.vehicle.jet_count`) whose jets have specific impulse ``isp_s`` [s]:
    ``D`` (3, n) [rad/s per s], ``G`` (3, n) [m/s per s], ``mdot`` (n,) [kg/s], mass [kg]; from
    the compiled model (full inertia, with its principal frame ``body_iquat``)."""
    params = VehicleParams.nominal(1, model, isp_s=isp_s)
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

    ``share_s``: on-time per cycle of the current plan; ``owed_s``: short-pulse on-time not
    yet fired; ``cycles_left`` (n_runs,): cycles left in the plan; ``on_at_end``: the jet
    filled the last cycle (its next pulse is not a new one)."""

    share_s: np.ndarray
    owed_s: np.ndarray
    cycles_left: np.ndarray
    on_at_end: np.ndarray


class AllocatorController:
    """Batched allocator controller (module docstring).

    Parameters
    ----------
    allocator : Allocator
    min_on_s : float
        Shortest new pulse the valves make [s].
    maneuver_limit_rad, maneuver_rate_rad_s : float
        The maneuver rule [rad, rad/s] (the vehicle's profile).
    deadband_rad_s : float
        No new plan below this rate error on every axis [rad/s] (the profile's).
    cycle_s : float
        Control cycle [s] (the profile's).
    min_pulse : str
        The profile's minimum pulse policy: how a plan's totals below ``min_on_s`` are rounded
        (module docstring, step 3).
    available : ndarray of bool, (n_jets,) or (n_runs, n_jets), optional
        The jets the controller may use (``--jets-off``); default all.
    """

    def __init__(
        self,
        allocator: Allocator,
        *,
        min_on_s: float,
        maneuver_limit_rad: float,
        maneuver_rate_rad_s: float,
        deadband_rad_s: float,
        cycle_s: float,
        min_pulse: str,
        available=None,
    ):
        self.allocator = allocator
        self.n = allocator.n
        self.min_on_s = float(min_on_s)
        self.maneuver_limit_rad = maneuver_limit_rad
        self.maneuver_rate_rad_s = maneuver_rate_rad_s
        self.deadband_rad_s = deadband_rad_s
        self.available = None if available is None else np.asarray(available, bool)
        self.cycle_s = cycle_s
        if min_pulse not in MIN_PULSE_POLICIES:
            raise InputError(
                f"min_pulse must be one of {', '.join(MIN_PULSE_POLICIES)}, got {min_pulse!r}"
            )
        self.min_pulse = min_pulse

    def initial_state(self, n_runs: int) -> AllocatorState:
        z = np.zeros((n_runs, self.n))
        return AllocatorState(z, z.copy(), np.zeros(n_runs, int), np.zeros((n_runs, self.n), bool))

    def step(self, nav, state: AllocatorState) -> tuple[np.ndarray, AllocatorState]:
        """On-times this cycle (n_runs, n_jets) [s] and the next state."""
        n_runs = nav.rate_err_B.shape[0]
        e = nav.att_err_B
        theta = np.linalg.norm(e, axis=1, keepdims=True)
        toward = np.where(theta > 0, e / np.where(theta > 0, theta, 1.0), 0.0)
        maneuver = theta > self.maneuver_limit_rad
        need = -(nav.rate_err_B + np.where(maneuver, self.maneuver_rate_rad_s * toward, 0.0))
        share, owed = state.share_s.copy(), state.owed_s.copy()
        left = state.cycles_left.copy()
        plan = (left == 0) & (np.abs(need).max(axis=1) >= self.deadband_rad_s)
        if plan.any():
            idx = np.flatnonzero(plan)
            avail = None
            if self.available is not None:
                avail = np.broadcast_to(self.available, (n_runs, self.n))[idx]
            t, _ = self.allocator.allocate(need[idx], avail)
            t = self._round(t, need[idx])
            longest = t.max(axis=1)
            cycles = np.maximum(np.ceil(longest / self.cycle_s - 1e-9), 1).astype(int)
            cycles = np.where(longest > 0, cycles, GIVE_UP_CYCLES)
            share[idx] = t / cycles[:, None]
            owed[idx] = 0.0
            left[idx] = cycles
        s = np.where((left > 0)[:, None], share, 0.0)
        short = (s > 0) & (s < self.min_on_s) & ~state.on_at_end
        owed = np.where(short, owed + s, owed)
        last = (left == 1)[:, None]
        due = short & ((owed >= self.min_on_s - 1e-12) | (last & (owed >= self.min_on_s / 2)))
        u = np.where(short, np.where(due, np.maximum(owed, self.min_on_s), 0.0), s)
        u = np.minimum(u, self.cycle_s)
        owed = np.where(due, 0.0, owed)
        left = np.maximum(left - 1, 0)
        owed = np.where((left == 0)[:, None], 0.0, owed)
        return u, AllocatorState(share, owed, left, u >= self.cycle_s * (1 - 1e-12))

    def _round(self, t: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Totals below the minimum on-time to 0 or the minimum by the minimum pulse policy;
        ``accumulate``: of all 2^k roundings of a run's k short jets, the one leaving the least
        rate error (none when no rounding improves on firing nothing by 10 %)."""
        small_all = (t > 0) & (t < self.min_on_s)
        if self.min_pulse != "accumulate":
            fired = self.min_on_s if self.min_pulse == "round-up" else 0.0
            return np.where(small_all, fired, t)
        rows = np.flatnonzero(small_all.any(axis=1))
        if rows.size == 0:
            return t
        D = self.allocator.D
        small = small_all[rows]
        k = int(small.sum(axis=1).max())
        order = np.argsort(~small, axis=1, kind="stable")[:, :k]  # the short jets first
        valid = np.take_along_axis(small, order, axis=1)
        base = np.where(small, 0.0, t[rows])
        resid0 = target[rows] - base @ D.T
        contrib = D.T[order] * (self.min_on_s * valid)[..., None]  # (R, k, 3)
        bits = ((np.arange(2**k)[:, None] >> np.arange(k)[None, :]) & 1).astype(float)
        err = np.linalg.norm(resid0[:, None, :] - np.einsum("pk,rkc->rpc", bits, contrib), axis=2)
        best = np.argmin(err, axis=1)
        keep = err[np.arange(rows.size), best] < 0.9 * np.linalg.norm(target[rows], axis=1)
        pick = bits[best].astype(bool) & valid
        new = base.copy()
        r_idx = np.repeat(np.arange(rows.size)[:, None], k, axis=1)
        new[r_idx[pick], order[pick]] = self.min_on_s
        out = t.copy()
        out[rows] = np.where(keep[:, None], new, 0.0)
        return out


def allocator_controller(vehicle: Vehicle, *, jets_off=()) -> AllocatorController:
    """The allocator controller of ``vehicle`` (any number of jets): minimum propellant,
    translation priced at the propellant that would null it (``m / (Isp g0)`` per m/s), jets
    ``jets_off`` (1-based numbers) never used; the maneuver rule, deadband and cycle of the
    vehicle's profile, its minimum on-time.

    Raises
    ------
    InputError
        A number in ``jets_off`` that is not a jet of the vehicle.
    """
    D, G, mdot, mass = jet_model(vehicle.model, vehicle.isp_s)
    allocator = Allocator(D, mdot, G=G, w_v=mass / (vehicle.isp_s * G0_M_S2))
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
    control = vehicle.control
    return AllocatorController(
        allocator,
        min_on_s=vehicle.min_on_s,
        maneuver_limit_rad=control.maneuver_limit_rad,
        maneuver_rate_rad_s=control.maneuver_rate_rad_s,
        deadband_rad_s=control.allocator_rate_deadband_rad_s,
        cycle_s=control.cycle_s,
        min_pulse=control.min_pulse,
        available=available,
    )
