"""The per-cycle record of a batch of flights (:class:`History`).

Imports ``rcsim.spacecraft.navigation``, ``rcsim.spacecraft.propulsion`` and
``rcsim.spacecraft.vehicle`` only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rcsim.spacecraft.navigation import NavState
from rcsim.spacecraft.propulsion import PropulsionState
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: A flight lost control when its total attitude error rose more than this above its value at
#: the start [deg] (:meth:`History.control_lost`).  No controller of rcsim lets an error grow
#: that far past where it began: a maneuver turns toward its target, a hold keeps the error
#: within its deadbands (the paper's maneuver limit is 0.6 deg, 50 times below), and braking
#: from the fastest validated rate (3 deg/s) at the paper's weakest pure-axis authority (roll,
#: 0.58 deg/s^2, ``rcsim vehicle check paper``) takes 7.8 deg.  Yet it is far enough below
#: 180 deg that a tumble, whose error sweeps up to 180 deg, is caught from any start below
#: 150 deg.
CONTROL_LOST_DEG = 30.0


@dataclass
class History:
    """Per-cycle record of a batch of runs (cycle k starts at ``t_s[k]``).

    Attributes
    ----------
    cycle_s : float
        The control cycle flown [s] (``PropulsionParams.cycle_s``): the one carrier of the
        cycle downstream of a flight (outcomes, envelopes, manifests read it here).
    t_s : ndarray, (n_cycles,)
        Start of each cycle, ``k * cycle_s`` [s].
    q_BN : ndarray, (n_runs, n_cycles, 4)
    omega_B, att_err_B, rate_err_B : ndarray, (n_runs, n_cycles, 3)
        Body rate, attitude error and rate error at the cycle's start [rad/s, rad, rad/s].
    on_time_s : ndarray, (n_runs, n_cycles, n_jets)
        On-time each of the vehicle's ``n_jets`` jets was commanded for the cycle, after the
        valve limits [s] (from the cycle's start; what firing counts are made of).
    final : NavState
        State at the end of the last cycle.
    propulsion : PropulsionState
        Firings, on-time, impulse per jet over the run.
    failed : ndarray of bool, (n_runs,)
        The simulation itself failed (invalid parameters, MuJoCo warning -- the physics
        diverged --, MuJoCo error, non-finite state).  A failed run is frozen from the cycle it
        failed in; its later records are not a flight.
    reason : list of str
        Why, per run ('' when it did not fail).
    flown_params : RunParameters or None
        The parameters each run was flown with, read back from MuJoCo's per-run model
        (:meth:`BatchSimulation.flown_params`); None for a history not made by a simulation.
    delivered_s : ndarray, (n_runs, n_cycles, n_jets), or None
        Time each jet thrust during the cycle [s]: the command moved by valve timing
        (:mod:`rcsim.spacecraft.valves`), plus stuck-on windows, minus failed time (with a thrust
        profile, time with any thrust).  None when there is no valve timing, fault or profile:
        then it is ``on_time_s``.
    meas_att_err_B, meas_rate_err_B : ndarray, (n_runs, n_cycles, 3), or None
        Attitude and rate errors the controller saw (from the measured state,
        :mod:`rcsim.spacecraft.sensors`) [rad, rad/s]; None when the sensors are perfect (then the
        controller saw ``att_err_B`` and ``rate_err_B``).  Outcomes use the true state.
    propellant_exhausted_s : ndarray, (n_runs,), or None
        When each run's propellant ran out [s] (inf: it did not); None when propellant is not
        tracked (:class:`rcsim.spacecraft.propellant.PropellantTank`).
    delta_v_N : ndarray, (n_runs, 3), or None
        Net change of the CG's velocity over the flight, in N [m/s]: MuJoCo's end state minus
        its start (:meth:`rcsim.spacecraft.batch_physics.BatchPhysics.cg_velocity_N`); None for
        a history not made by a simulation.
    delta_v_B : ndarray, (n_runs, 3), or None
        Net delta-v in B [m/s]: every jet's delivered impulse along its flown direction in B,
        summed, over the run's wet mass at the start (the integral of the thrust acceleration
        in body axes; a propellant-tracked run's falling mass is not followed: off by at most
        the propellant used over the mass, relative).  None: not made by a simulation.
    min_pulse_s : float
        The valves' shortest firing flown [s] (``PropulsionParams.min_pulse_s``; 0: no limit).
    """

    cycle_s: float
    t_s: np.ndarray
    q_BN: np.ndarray
    omega_B: np.ndarray
    att_err_B: np.ndarray
    rate_err_B: np.ndarray
    on_time_s: np.ndarray
    final: NavState
    propulsion: PropulsionState
    failed: np.ndarray
    reason: list[str] = field(default_factory=list)
    flown_params: RunParameters | None = None
    delivered_s: np.ndarray | None = None
    meas_att_err_B: np.ndarray | None = None
    meas_rate_err_B: np.ndarray | None = None
    propellant_exhausted_s: np.ndarray | None = None
    delta_v_N: np.ndarray | None = None
    delta_v_B: np.ndarray | None = None
    min_pulse_s: float = 0.0

    @property
    def n_runs(self) -> int:
        return int(self.omega_B.shape[0])

    @property
    def n_jets(self) -> int:
        """The flown vehicle's jet count (the width of ``on_time_s``)."""
        return int(self.on_time_s.shape[2])

    def control_lost(self) -> np.ndarray:
        """Per run, whether it lost control, (n_runs,) bool: its total attitude error rose
        more than :data:`CONTROL_LOST_DEG` above its value at the start, at some cycle or at
        the end (a run that failed as a simulation is judged on the cycles it flew)."""
        return np.isfinite(self.control_lost_at_s())

    def control_lost_at_s(self) -> np.ndarray:
        """Per run, when its attitude error first rose past the :meth:`control_lost` line
        [s], (n_runs,); inf when it never did."""
        att = np.concatenate([self.att_err_B, self.final.att_err_B[:, None]], axis=1)
        total = np.linalg.norm(att, axis=2)  # (n_runs, n_cycles + 1)
        t = np.append(self.t_s, self.final.t_s)
        over = total > total[:, :1] + math.radians(CONTROL_LOST_DEG)
        first = np.argmax(over, axis=1)
        return np.where(over.any(axis=1), t[first], np.inf)

    def control_lost_text(self, run: int = 0) -> str:
        """Why run ``run`` lost control, one line; '' when it did not."""
        at = float(self.control_lost_at_s()[run])
        if not math.isfinite(at):
            return ""
        att = np.concatenate([self.att_err_B[run], self.final.att_err_B[run][None]], axis=0)
        total = np.degrees(np.linalg.norm(att, axis=1))
        return (
            f"control lost at t = {at:g} s: the attitude error rose from {total[0]:.3g} deg at "
            f"the start to {total.max():.4g} deg, more than {CONTROL_LOST_DEG:g} deg above it"
        )

    @property
    def propellant_kg(self) -> np.ndarray:
        """Propellant each run used [kg], (n_runs,): its impulse over the Isp it was flown
        with (``flown_params.isp_s``, the vehicle file's) times g0."""
        if self.flown_params is None:
            raise ValueError("a history without flown_params has no Isp to convert impulse with")
        return self.propulsion.propellant_kg(self.flown_params.isp_s)


def history_buffers(
    n_cycles: int, n_runs: int, n_jets: int, *, measured: bool, delivered: bool
) -> dict:
    """Cycle-major record buffers of a flight, (n_cycles, n_runs, k) each: every cycle writes
    one contiguous block, and the flight returns them as (n_runs, n_cycles, k) views
    (:attr:`History` fields; ``measured``: the sensors' errors, ``delivered``: the jets'
    delivered on-times)."""
    n = n_runs
    rec = {
        "q_BN": np.empty((n_cycles, n, 4)),
        "omega_B": np.empty((n_cycles, n, 3)),
        "att_err_B": np.empty((n_cycles, n, 3)),
        "rate_err_B": np.empty((n_cycles, n, 3)),
        "on_time_s": np.empty((n_cycles, n, n_jets)),
    }
    if delivered:
        rec["delivered_s"] = np.empty((n_cycles, n, n_jets))
    if measured:
        rec["meas_att_err_B"] = np.empty((n_cycles, n, 3))
        rec["meas_rate_err_B"] = np.empty((n_cycles, n, 3))
    return rec
