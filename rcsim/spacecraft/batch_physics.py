"""MuJoCo's side of the closed loop: ``n_runs`` vehicles in one :class:`mujoco.batch.Batch`.

:class:`BatchPhysics` owns the batch: each run's parameters written into its per-simulation
model fields (with ``mj_setConst``), the read-back of what each run flies, the reset to an
initial state, the integration of one control cycle piece by piece with each run's jet wrench
(:mod:`rcsim.spacecraft.flight_model`), the runs a MuJoCo warning or error fails
(:mod:`rcsim.spacecraft.simulation`, "Failures"), and the mass properties of runs whose
propellant is tracked (:mod:`rcsim.spacecraft.propellant`).  The closed loop around it
(sensors, controller, valves, the cut of a cycle into pieces) is
:class:`rcsim.spacecraft.simulation.BatchSimulation`.
"""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np
from mujoco.batch import Batch, SimulationError

from rcsim.spacecraft import cycle_kernel
from rcsim.spacecraft.flight_model import flight_model, jet_wrench_B
from rcsim.spacecraft.guards import warning_reasons
from rcsim.spacecraft.modes.draws import ModeRuns
from rcsim.spacecraft.modes.state import subtree_velocity_N
from rcsim.spacecraft.navigation import quat_conj, quat_mul
from rcsim.spacecraft.pieces import Pieces
from rcsim.spacecraft.propellant import (
    PropellantTank,
    full_inertia,
    mass_properties,
    principal,
)
from rcsim.spacecraft.vehicle.model import BODY, IDENTITY_QUAT
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2, RunParameters

_CTRL = int(mujoco.mjtState.mjSTATE_CTRL)


class BatchPhysics:
    """The batch of ``params.n_runs`` simulations of ``model`` (module docstring).

    Parameters
    ----------
    model : mujoco.MjModel
        The vehicle's compiled model.
    params : RunParameters
        One entry per run; runs whose ``invalid`` reason is not empty get the nominal values.
    invalid : list of str
        Per run, why its parameters cannot be flown ('' when they can).
    nthread : int
        MuJoCo worker threads (0: all CPUs).
    level : ndarray, (n_runs, n_jets)
        Each jet's thrust fraction (a degraded jet's factor; ones otherwise).
    n_sub : int
        Physics steps of the model's ``opt.timestep`` in one control cycle.
    flight : mujoco.MjModel, optional
        ``model``'s wrench model already built (:attr:`Vehicle.flight_model`, once per
        process); built here when not given.
    modes : ModeRuns, optional
        Each run's mode masses, springs and dampers (:mod:`rcsim.spacecraft.modes.draws`);
        None: the modes as compiled, every run alike.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        params: RunParameters,
        invalid: list[str],
        *,
        nthread: int,
        level: np.ndarray,
        n_sub: int,
        flight: mujoco.MjModel | None = None,
        modes: ModeRuns | None = None,
    ):
        self.model, self.params, self.invalid = model, params, invalid
        self.modes = modes
        self.level, self.n_sub = level, n_sub
        self.dt_s = float(model.opt.timestep)
        self.compiled = False  # the compiled state check; set by the loop for each flight
        # MuJoCo integrates the wrench model; the jets are summed by a matrix per run
        # (rcsim/spacecraft/flight_model.py: the same physics to rounding, cheaper a step).
        # (``flight``: the vehicle's, built once per process; a Batch simulates copies of it)
        self._flight = flight_model(model) if flight is None else flight
        self.batch = Batch(self._flight, params.n_runs, nthread)
        self._write_params()
        self.qpos = self.batch.bind("qpos")
        self.qvel = self.batch.bind("qvel")
        # Per-run physics step: the length of each run's current piece of a cycle.
        self._timestep = self.batch.expand("opt.timestep")
        self._stretched = False  # some run's timestep is not the model's
        # Live (n_runs, mjNWARNING, 2) view of each simulation's MjData.warning (lastinfo, number).
        self._warning = self.batch.warning
        self.tank: PropellantTank | None = None
        self._start_params: RunParameters | None = None

    @property
    def n_runs(self) -> int:
        return self.params.n_runs

    @property
    def mode_names(self) -> tuple[str, ...]:
        """The mode coordinates' joint names (slosh, appendages: :mod:`rcsim.spacecraft.modes`),
        in qpos order after the hub's free joint (qpos 7.., qvel 6..); empty for a rigid
        vehicle."""
        f = self._flight
        return tuple(mujoco.mj_id2name(f, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(1, f.njnt))

    @property
    def mode_mass_kg(self) -> np.ndarray:
        """The modes' mass of each run [kg], (n_runs,): the whole vehicle is the hub's
        (:meth:`flown_params`) plus this (0.0 for a rigid vehicle); a run's own when the
        slosh masses are dispersed (the batch's per-run masses), else the compiled model's."""
        body = self._flight.body(BODY).id
        per_run = self.batch.expanded("body_mass")
        if per_run is not None:
            return np.asarray(per_run)[:, body + 1 :].sum(axis=1)
        return np.full(self.n_runs, float(self._flight.body_mass[body + 1 :].sum()))

    @property
    def mode_kinds(self) -> tuple[str, ...]:
        """``slide`` [m] or ``angle`` [rad] per mode coordinate (:attr:`mode_names`)."""
        slide = mujoco.mjtJoint.mjJNT_SLIDE
        f = self._flight
        return tuple("slide" if f.jnt_type[j] == slide else "angle" for j in range(1, f.njnt))

    def _write_params(self) -> None:
        """Per-run model fields; invalid runs keep the nominal values (they are reported failed)."""
        b, m, p = self.batch, self.model, self.params
        body = self._flight.body(BODY).id
        ok = np.array([not r for r in self.invalid])
        nominal = RunParameters.nominal(1, m, isp_s=p.isp_s)

        def pick(value: np.ndarray, nom: np.ndarray) -> np.ndarray:
            return np.where(ok.reshape((-1,) + (1,) * (value.ndim - 1)), value, nom)

        b.expand("body_mass")[:, body] = pick(p.mass_kg, nominal.mass_kg)
        b.expand("body_ipos")[:, body] = pick(p.cg_B, nominal.cg_B)
        b.expand("body_inertia")[:, body] = pick(p.inertia_B, nominal.inertia_B)
        if p.iquat is not None:  # each run's principal frame (products of inertia)
            b.expand("body_iquat")[:, body] = pick(p.iquat, self._flight.body_iquat[body][None])
        # The jets as flown: thrust and direction per run, summed into the wrench matrix.
        self._flown_thrust_n = pick(p.thrust_n, nominal.thrust_n)
        self._flown_dir_S = pick(p.jet_dir_S, nominal.jet_dir_S)
        self._wrench = jet_wrench_B(
            replace(p, thrust_n=self._flown_thrust_n, jet_dir_S=self._flown_dir_S), m
        )
        if self.modes is not None:  # each run's drawn mode masses, springs and dampers
            if self.modes.n_runs != p.n_runs:
                raise ValueError(f"modes of {self.modes.n_runs} runs for {p.n_runs} runs")
            self.modes.write(self._flight, b.expand)
        # mass, CG and inertia feed constants (body_subtreemass, body_invweight0, dof_M0,
        # actuator_acc0, ...) that MuJoCo only recomputes in mj_setConst; without it some
        # changes are silently ignored.
        b.set_const()

    def flown_params(self) -> RunParameters:
        """The parameters each run is flown with, read back from MuJoCo's per-run model.

        Mass, CG and inertia are read from the batch's per-simulation fields after
        ``mj_setConst`` (``body_mass``, ``body_ipos``, ``body_inertia``, and ``body_iquat``
        when :attr:`params` gives each run its principal frame); the jets' thrust and
        directions are the ones their wrench matrix was built from
        (:func:`rcsim.spacecraft.flight_model.jet_wrench_B`).  They equal :attr:`params` bit for
        bit, except for runs with invalid parameters, which are flown (and read back) with the
        nominal values.  ``isp_s`` is not a MuJoCo quantity and is copied from :attr:`params`.

        MuJoCo stores a body's inertia as principal moments ``body_inertia`` in the frame
        ``body_iquat``.  Both are *inputs* of ``mj_setConst`` (mujoco 4.0:
        ``MjModel._setconst_inputs``; its outputs are derived constants such as
        ``body_subtreemass``), so neither is re-oriented or re-diagonalized after the write:
        the moments read back are about the principal axes the run was given, as
        :class:`RunParameters` defines them (the body axes B for the packaged vehicle, whose
        ``body_iquat`` is the identity).  ``iquat`` is each run's frame whenever it is not the
        identity (the model's own for parameters without one), so the tensor in B
        (:func:`rcsim.spacecraft.propellant.inertia_tensor_B`) can always be rebuilt from the
        read-back.

        Returns
        -------
        RunParameters
            ``n_runs`` entries.
        """
        b = self.batch
        body = self._flight.body(BODY).id

        def field_of(name: str) -> np.ndarray:
            # expand() (done in _write_params) made these per-simulation; copy: the live
            # arrays are the batch's own model memory.
            values = b.expanded(name)
            if values is None:  # pragma: no cover - _write_params always expands them
                raise AssertionError(f"{name} is not per-simulation")
            return np.array(values)

        if self._start_params is not None:
            return self._start_params  # propellant tracked: the wet vehicle at t = 0
        if self.params.iquat is not None:
            iquat = field_of("body_iquat")[:, body]
        elif np.array_equal(self._flight.body_iquat[body], IDENTITY_QUAT):
            iquat = None  # principal axes along B, as RunParameters.nominal says it
        else:  # the model's own frame, every run (what iquat None flies)
            iquat = np.repeat(self._flight.body_iquat[body][None], self.n_runs, axis=0)
        return RunParameters(
            mass_kg=field_of("body_mass")[:, body],
            cg_B=field_of("body_ipos")[:, body],
            inertia_B=field_of("body_inertia")[:, body],
            thrust_n=self._flown_thrust_n.copy(),
            jet_dir_S=self._flown_dir_S.copy(),
            isp_s=self.params.isp_s,
            iquat=iquat,
        )

    def cg_velocity_N(self) -> np.ndarray:
        """Velocity of each run's centre of gravity in N [m/s], (n_runs, 3).

        The free joint's linear velocity (``qvel[0:3]``) is the body origin's, in N; the CG
        sits at ``body_ipos`` (its current value: it moves as propellant is used), so
        ``v_CG = v_O + R_NB (omega_B x cg_B)`` (rigid-body kinematics).  With modes (slosh,
        appendages) it is the whole vehicle's CG, hub and modes
        (:func:`rcsim.spacecraft.modes.state.subtree_velocity_N`).
        """
        if self.mode_names:  # the hub's CG is not the vehicle's: MuJoCo's whole-tree value
            return subtree_velocity_N(self.batch, self._flight.body(BODY).id)
        body = self._flight.body(BODY).id
        cg = self.batch.expanded("body_ipos")
        cg_B = self.params.cg_B if cg is None else np.asarray(cg)[:, body]
        spin_B = np.cross(self.qvel[:, 3:6], cg_B)
        q = self.qpos[:, 3:7]
        pure = np.concatenate([np.zeros((len(q), 1)), spin_B], axis=1)
        rotated = quat_mul(quat_mul(q, pure), quat_conj(q))  # R_NB applied to spin_B
        return self.qvel[:, 0:3] + rotated[:, 1:]

    def jet_directions_B(self) -> np.ndarray:
        """Unit thrust direction of each run's jets as flown, in B, (n_runs, n_jets, 3): the
        force rows of their wrench matrix over their thrust (a jet of zero thrust: zero)."""
        force = self._wrench[:, 0:3, :].transpose(0, 2, 1)
        thrust = self._flown_thrust_n[..., None]
        return np.divide(force, thrust, out=np.zeros_like(force), where=thrust > 0)

    def track_propellant(self, tank: PropellantTank) -> None:
        """Set up the per-run mass-property updates of a flight whose propellant runs out."""
        n = self.n_runs
        self.tank = tank
        self._start_params = self.flown_params()  # the wet vehicle, read back before flying
        # Principal frame of the wet vehicle: each run's own, or the model's for all.
        frames = self._start_params.iquat
        self._iquat0 = (
            self._flight.body_iquat[self._flight.body(BODY).id].copy() if frames is None else frames
        )
        # The wet tensors in B, once: every cycle's update starts from them (computing
        # them per cycle from moments and frames looped over the runs that fired).
        self._inertia0_B = full_inertia(self._start_params.inertia_B, self._iquat0)
        # Live per-run fields (expand() of an expanded field returns the same memory).
        self._mass_fields = {
            name: self.batch.expand(name)
            for name in ("body_mass", "body_ipos", "body_inertia", "body_iquat")
        }
        self.used_kg = np.zeros(n)
        self.exhausted_s = np.full(n, np.inf)

    def use_propellant(
        self, pieces: Pieces, thrust_n: np.ndarray, isp_s: float | np.ndarray | None = None
    ) -> None:
        """Add the cycle's propellant to each run's total and move the mass properties of the
        runs that fired (:mod:`rcsim.spacecraft.propellant`); ``isp_s`` the Isp flown [s]
        (a float, or (n_runs,) under a blowdown; default the parameters')."""
        isp = self.params.isp_s if isp_s is None else isp_s
        used = (pieces.flow_time_s() * thrust_n).sum(axis=1) / (isp * G0_M_S2)
        self.used_kg += used
        fired = np.flatnonzero(used > 0)
        if fired.size:
            self.write_mass_properties(fired)

    def write_mass_properties(self, ids: np.ndarray) -> None:
        """Mass, CG and inertia of runs ``ids`` after the propellant they used."""
        start, tank = self._start_params, self.tank
        assert start is not None and tank is not None  # only called when propellant is tracked
        m, c, inertia = mass_properties(
            start.mass_kg[ids],
            start.cg_B[ids],
            self._inertia0_B[ids],
            tank.position_B,
            self.used_kg[ids],
        )
        moments, quat = principal(inertia)
        body, fields = self._flight.body(BODY).id, self._mass_fields
        fields["body_mass"][ids, body] = m
        fields["body_ipos"][ids, body] = c
        fields["body_inertia"][ids, body] = moments
        fields["body_iquat"][ids, body] = quat
        self.batch.set_const(ids)

    def reset(self, q0_BN, omega0_B) -> None:
        n = self.n_runs
        self.batch.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
        if q0_BN is not None:
            q0 = np.asarray(q0_BN, float).reshape(n, 4)
            self.qpos[:, 3:7] = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
        if omega0_B is not None:
            self.qvel[:, 3:6] = np.asarray(omega0_B, float).reshape(n, 3)
        self.batch.forward()

    def check_warnings(
        self, failed: np.ndarray, reason: list[str], t0_s: float, t1_s: float
    ) -> None:
        """Fail the runs whose MuJoCo warning counters rose in ``[t0_s, t1_s]``.

        MuJoCo resets a diverged simulation and goes on; its warning counters (zeroed at
        reset) are the only trace (:mod:`rcsim.spacecraft.simulation`, "Failures").
        """
        for i, why in warning_reasons(self._warning, ~failed, t0_s, t1_s).items():
            failed[i] = True
            reason[i] = why

    def step(
        self,
        pieces: Pieces,
        torque: np.ndarray,
        failed: np.ndarray,
        reason: list[str],
        t0_s: float,
        t1_s: float,
    ) -> None:
        """Integrate cycle ``[t0_s, t1_s]`` of the runs still alive, piece by piece; newly
        failed ones are frozen.

        ``torque`` (n_runs, 3) [N m] is the disturbance held over the cycle.
        """
        alive = ~failed
        if not alive.any():
            return
        if pieces.uniform:  # no switch inside any grid step: the model's own fixed steps
            if self._stretched:
                self._timestep[:] = self.dt_s
                self._stretched = False
            # Flight-model controls: each run's jet wrench matrix times its on-fractions.
            control = np.einsum(
                "nwj,nsj->nsw", self._wrench, pieces.control() * self.level[:, None, :]
            )
            if control.shape[1] != self.n_sub:  # one on-fraction for all the cycle's steps
                control = np.repeat(control, self.n_sub, axis=1)
            control[:, :, 3:6] += torque[:, None, :]
            self._rollout(self.n_sub, control, alive, failed, reason)
        else:
            self._stretched = True
            wrench = np.einsum(
                "nwj,npj->npw", self._wrench, pieces.control() * self.level[:, None, :]
            )
            wrench[:, :, 3:6] += torque[:, None, :]
            for p in range(pieces.n_pieces):
                runs = alive & ~failed & (pieces.count > p)
                self._timestep[runs] = pieces.length_s[runs, p]
                self._rollout(1, wrench[:, p : p + 1], runs, failed, reason)
        self.check_warnings(failed, reason, t0_s, t1_s)
        if self.compiled and cycle_kernel.bounded_state(self.batch.state, self.qpos, self.qvel):
            return  # every run's state is finite (the test below, without its numpy passes)
        state_ok = np.isfinite(self.qvel.sum(axis=1) + self.qpos.sum(axis=1))
        if state_ok.all():
            return
        for i in np.flatnonzero(~state_ok & ~failed):
            failed[i] = True
            reason[i] = "non-finite state (diverged)"
        # Keep numbers finite so vectorized navigation/controllers stay warning-free.
        self.qpos[~state_ok] = np.nan_to_num(self.qpos[~state_ok])
        self.qvel[~state_ok] = 0.0

    def _rollout(
        self,
        nstep: int,
        control: np.ndarray,
        runs: np.ndarray,
        failed: np.ndarray,
        reason: list[str],
    ) -> None:
        """``nstep`` physics steps of the runs ``runs`` (bool, (n_runs,)) with ``control``
        (n_runs, nstep, nu); a MuJoCo error fails the run it names."""
        ids = np.flatnonzero(runs)
        if ids.size == 0:
            return
        everyone = ids.size == self.n_runs
        try:
            self.batch.rollout(
                nstep,
                control=control if everyone else control[ids],
                control_spec=_CTRL,
                record=(),
                ids=None if everyone else ids,
            )
        except SimulationError as exc:
            for i in exc.ids:
                failed[i] = True
                reason[i] = f"MuJoCo error: {self.batch.error(int(i))}"
