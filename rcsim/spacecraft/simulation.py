"""The closed loop over many runs at once: controller step (numpy) <-> MuJoCo (native threads).

Each control cycle: the sensors read every run's state (:mod:`rcsim.spacecraft.sensors`; perfect by
default), navigation errors, one vectorized controller step, valve limits
(:mod:`rcsim.spacecraft.propulsion`), valve timing and jet faults (:mod:`rcsim.spacecraft.valves`),
then the cycle's physics of all runs in MuJoCo's thread pool (:class:`mujoco.batch.Batch`, GIL
released).  There is no Python loop over runs; one run is a batch of one.  MuJoCo integrates
the vehicle's flight model, one body under a six-component wrench into which each run's jets
are summed (:mod:`rcsim.spacecraft.flight_model`); the vehicle MJCF with its jets stays the
definition the parameters come from.

Exact in time
-------------
Each run's cycle is integrated in pieces cut at that run's own jet switch instants
(:func:`rcsim.spacecraft.pieces.cycle_pieces`), the jets constant in each piece: the physics sees
the exact thrust history, so impulse and attitude are exact whatever the pulse lengths and delays.
The pieces' lengths are per-simulation physics steps (``opt.timestep`` expanded per run); piece
``p`` of every run that has one is one batched ``rollout`` of one step.  A cycle in which no
run switches a jet is one rollout of the model's fixed steps, as before.  Cost and accuracy:
``docs/convergence.md``.

Failures
--------
A run whose physics diverges is marked failed (``History.failed``) with MuJoCo's own reason and
frozen; the others go on.  MuJoCo does not raise on divergence: on a NaN, infinite or huge
``qpos``/``qvel``/``qacc`` (or ``ctrl``) it raises a *warning* and silently resets that
simulation to the model's initial state (``mj_resetData``), which then "flies" on as if
nothing happened.  The signal is each simulation's warning counters (``MjData.warning``, read
per run from :attr:`mujoco.batch.Batch.warning`, shape ``(n_runs, mjNWARNING, 2)`` =
``(lastinfo, number)``; cleared by every reset): a run whose counters rose is failed with the
warning's name, MuJoCo's text (:func:`mujoco.mju_warningText`) and the control cycle it rose in.
A MuJoCo error (:class:`mujoco.batch.SimulationError`) and a non-finite state (a backstop) fail a
run the same way.  The warning messages themselves go to the ``rcsim.mujoco`` logger
(:func:`rcsim.spacecraft.vehicle.route_mujoco_warnings`), never to a ``MUJOCO_LOG.TXT``.

Refusals
--------
:meth:`BatchSimulation.run` refuses, before allocating anything, a controller whose control
cycle disagrees with the propulsion's, and a history that would not fit in memory
(:func:`rcsim.spacecraft.guards.memory_budget_bytes`).  The constructor refuses invalid sensor,
timing and fault parameters (:class:`rcsim.models.errors.InputError`).

Compiled passes
---------------
When the optional extension is built, navigation's algebra, the valve limits and commands, the
no-switch test, the propulsion totals and the end of a cycle run as compiled passes
(:mod:`rcsim.spacecraft.cycle_kernel`), bit for bit the numpy forms, which stay the reference
(``RCSIM_NUMPY_CYCLE=1``); the choice is made once per :meth:`BatchSimulation.run`.

Module size: about 800 lines with its docstrings, over the ~400 guideline: the cycle loop
(sensors, controller, valves, the cut) and the piecewise stepping share the batch's bound
arrays, per-run timesteps and failure bookkeeping; splitting them would pass those around for
no gain in clarity.  The
pure parts live in :mod:`rcsim.spacecraft.pieces`, :mod:`rcsim.spacecraft.valves`,
:mod:`rcsim.spacecraft.sensors`, :mod:`rcsim.spacecraft.history` and
:mod:`rcsim.spacecraft.flight_model`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

import mujoco
import numpy as np
from mujoco.batch import Batch, SimulationError

from rcsim.models.errors import InputError
from rcsim.spacecraft import cycle_kernel
from rcsim.spacecraft.flight_model import flight_model, jet_wrench_B
from rcsim.spacecraft.guards import check_cycle, check_history_memory, warning_reasons
from rcsim.spacecraft.history import History
from rcsim.spacecraft.mujoco_timers import quiet_stage_timers
from rcsim.spacecraft.navigation import CommandBlocks, Guidance, NavState, navigate
from rcsim.spacecraft.pieces import Pieces, cycle_pieces, profile_pieces
from rcsim.spacecraft.propellant import (
    PropellantTank,
    exhaustion_time_s,
    full_inertia,
    mass_flow_kg_s,
    mass_properties,
    principal,
)
from rcsim.spacecraft.propulsion import PropulsionParams, PropulsionState, apply_valve_limits
from rcsim.spacecraft.sensors import SensorNoise, SensorParams, SensorState, measure
from rcsim.spacecraft.valves import (
    JetFaults,
    ThrustProfile,
    ValveState,
    ValveTiming,
    command_valves,
    cycle_intervals,
    end_cycle,
)
from rcsim.spacecraft.vehicle import (
    BODY,
    G0_M_S2,
    IDENTITY_QUAT,
    VehicleParams,
    jet_count,
    load_model,
    route_mujoco_warnings,
)

_CTRL = int(mujoco.mjtState.mjSTATE_CTRL)

__all__ = ["BatchSimulation", "Controller", "History", "invalid_runs", "simulate_batch"]


class Controller(Protocol):
    """A batched controller: explicit state in, jet on-times and new state out.

    A controller whose logic assumes a control cycle (timers, firings split into cycles) says
    so with a ``cycle_s`` attribute [s]; :meth:`BatchSimulation.run` refuses it when it differs
    from the propulsion's ``cycle_s``.  A controller without the attribute is cycle-agnostic.
    """

    def initial_state(self, n_runs: int) -> Any: ...

    def step(self, nav: NavState, state: Any) -> tuple[np.ndarray, Any]:
        """Return on-times this cycle [s], shape (n_runs, n_jets), and the next state
        (``n_jets``: the flown vehicle's)."""


def invalid_runs(params: VehicleParams) -> list[str]:
    """Per run, why its parameters cannot be simulated ('' when they can)."""
    reasons = [""] * params.n_runs
    checks = (
        ("mass_kg", params.mass_kg[:, None], lambda v: v > 0),
        ("cg_B", params.cg_B, lambda v: np.ones_like(v, bool)),
        ("inertia_B", params.inertia_B, lambda v: v > 0),
        ("thrust_n", params.thrust_n, lambda v: v >= 0),
        ("jet_dir_S", params.jet_dir_S.reshape(params.n_runs, -1), lambda v: np.ones_like(v, bool)),
    )
    for name, values, ok in checks:
        with np.errstate(invalid="ignore"):
            bad = ~(np.isfinite(values) & ok(values))
        for i in np.flatnonzero(bad.any(axis=1)):
            if not reasons[i]:
                reasons[i] = f"invalid parameter {name}: {values[i].tolist()}"
    if params.iquat is not None:
        with np.errstate(invalid="ignore"):
            unit = np.abs(np.linalg.norm(params.iquat, axis=1) - 1.0) <= 1e-9
        for i in np.flatnonzero(~unit):
            if not reasons[i]:
                reasons[i] = (
                    f"invalid parameter iquat: {params.iquat[i].tolist()} (not a unit quaternion)"
                )
    # Principal moments of a rigid body obey the triangle inequality (a + b >= c); positive
    # moments that do not (a far tail draw of dispersed moments or products of inertia) are
    # no body, and are not flown (rcsim.spacecraft.dispersions, "Physical tensors").
    with np.errstate(invalid="ignore"):
        m = np.sort(params.inertia_B, axis=1)
        no_body = m[:, 0] + m[:, 1] < m[:, 2] * (1 - 1e-12)
    for i in np.flatnonzero(no_body):
        if not reasons[i]:
            reasons[i] = (
                f"invalid parameter inertia_B: {params.inertia_B[i].tolist()} (principal moments "
                "violate the triangle inequality: no rigid body has them)"
            )
    return reasons


class BatchSimulation:
    """``n_runs`` vehicles, each with its own parameters, stepped together.

    Parameters
    ----------
    params : VehicleParams
        One entry per run.  Runs with non-finite or non-physical values are flown with the
        nominal vehicle's values and reported failed ("invalid parameter ...").  Its per-jet
        arrays must be as wide as ``model`` has jets (:func:`rcsim.spacecraft.vehicle.jet_count`);
        every per-jet array of the flight is that wide.
    propulsion : PropulsionParams
        Control cycle and minimum pulse.
    model : mujoco.MjModel, optional
        Compiled vehicle (its ``opt.timestep`` and integrator are used); default the packaged one.
        The timestep is the longest piece of a cycle (module docstring, "Exact in time").
    nthread : int
        MuJoCo worker threads (0: all CPUs).
    sensors : SensorParams, optional
        Sensor errors per run; default perfect sensors.
    sensor_streams : sequence of numpy.random.SeedSequence, optional
        One per run, the run's sensor-noise stream
        (:func:`rcsim.spacecraft.effect_draws.effect_streams`); required when ``sensors`` has noise
        or a random walk.
    timing : ValveTiming, optional
        Command (sensor-to-actuator) delay and valve latencies per run (per jet, or one
        column for every jet); default none.
    faults : JetFaults, optional
        Jet faults per run (per jet, or one column for every jet); default none.
    profile : ThrustProfile, optional
        Thrust transients at valve opening and closing; default none (instant thrust).
    tank : PropellantTank, optional
        Propellant tracked per run: the mass properties follow the propellant used and the
        jets stop when it runs out (:mod:`rcsim.spacecraft.propellant`); default none (propellant is
        accounted, the mass properties stay ``params``').

    Raises
    ------
    InputError
        Invalid sensor, timing or fault parameters (per-jet values for another jet count
        among them); noisy sensors without streams; ``params`` for another jet count than
        ``model``'s.
    """

    def __init__(
        self,
        params: VehicleParams,
        *,
        propulsion: PropulsionParams = PropulsionParams(),
        model: mujoco.MjModel | None = None,
        nthread: int = 0,
        sensors: SensorParams | None = None,
        sensor_streams=None,
        timing: ValveTiming | None = None,
        faults: JetFaults | None = None,
        profile: ThrustProfile | None = None,
        tank: PropellantTank | None = None,
    ):
        route_mujoco_warnings()
        quiet_stage_timers()
        n = params.n_runs
        self.model = load_model() if model is None else model
        # The vehicle's jet count, from its model: every per-jet array below is this wide.
        self.n_jets = jet_count(self.model)
        if params.n_jets != self.n_jets:
            raise InputError(
                f"have {params.n_jets} jets per run; the vehicle model has {self.n_jets}",
                parameter="params",
                value=None,
            )
        if sensors is not None:
            sensors.check(n)
        if timing is not None:
            timing = timing.for_jets(self.n_jets)
            timing.check(propulsion.cycle_s, n)
        if faults is not None:
            faults = faults.for_jets(self.n_jets)
            faults.check(n)
        self.sensors = None if sensors is None or sensors.is_perfect() else sensors
        if self.sensors is not None and self.sensors.is_random():
            if sensor_streams is None or len(sensor_streams) != n:
                raise InputError(
                    f"noisy sensors need one noise stream per run ({n}), got "
                    f"{'none' if sensor_streams is None else len(sensor_streams)}",
                    parameter="sensor_streams",
                    value=None,
                )
        self.sensor_streams = sensor_streams
        self.timing = ValveTiming.of(n, n_jets=self.n_jets) if timing is None else timing
        self.faults = None if faults is None or faults.is_none() else faults
        self.profile = None if profile is None or profile.is_none() else profile
        self.params = params
        self.propulsion = propulsion
        dt = float(self.model.opt.timestep)
        n_sub = int(round(propulsion.cycle_s / dt))
        if n_sub < 1 or abs(n_sub * dt - propulsion.cycle_s) > 1e-9 * propulsion.cycle_s:
            raise ValueError(
                f"physics step {dt} s does not divide the control cycle {propulsion.cycle_s} s"
            )
        self.dt_s, self.n_sub = dt, n_sub
        self.invalid = invalid_runs(params)
        # MuJoCo integrates the wrench model; the jets are summed by a matrix per run
        # (rcsim/spacecraft/flight_model.py: the same physics to rounding, ~40 % cheaper a step).
        self._flight = flight_model(self.model)
        self._batch = Batch(self._flight, params.n_runs, nthread)
        self._write_params()
        self._qpos = self._batch.bind("qpos")
        self._qvel = self._batch.bind("qvel")
        # Per-run physics step: the length of each run's current piece of a cycle.
        self._timestep = self._batch.expand("opt.timestep")
        self._stretched = False  # some run's timestep is not the model's
        self._compiled = False  # the compiled per-cycle passes; decided by each run()
        self._level = (
            np.ones((n, self.n_jets)) if self.faults is None else self.faults.thrust_factor.copy()
        )
        # Live (n_runs, mjNWARNING, 2) view of each simulation's MjData.warning (lastinfo, number).
        self._warning = self._batch.warning
        self.tank = tank
        if tank is not None:
            if tank.initial_kg.shape != (n,):
                raise InputError(
                    f"needs one value per run ({n}), got {tank.initial_kg.shape}",
                    parameter="tank",
                )
            self._start_params = self.flown_params()  # the wet vehicle, read back before flying
            # Principal frame of the wet vehicle: each run's own, or the model's for all.
            frames = self._start_params.iquat
            self._iquat0 = (
                self._flight.body_iquat[self._flight.body(BODY).id].copy()
                if frames is None
                else frames
            )
            # The wet tensors in B, once: every cycle's update starts from them (computing
            # them per cycle from moments and frames looped over the runs that fired).
            self._inertia0_B = full_inertia(self._start_params.inertia_B, self._iquat0)
            # Live per-run fields (expand() of an expanded field returns the same memory).
            self._mass_fields = {
                name: self._batch.expand(name)
                for name in ("body_mass", "body_ipos", "body_inertia", "body_iquat")
            }
            self._used_kg = np.zeros(n)
            self._exhausted_s = np.full(n, np.inf)

    @property
    def n_runs(self) -> int:
        return self.params.n_runs

    def _write_params(self) -> None:
        """Per-run model fields; invalid runs keep the nominal values (they are reported failed)."""
        b, m, p = self._batch, self.model, self.params
        body = self._flight.body(BODY).id
        ok = np.array([not r for r in self.invalid])
        nominal = VehicleParams.nominal(1, m)

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
        # mass, CG and inertia feed constants (body_subtreemass, body_invweight0, dof_M0,
        # actuator_acc0, ...) that MuJoCo only recomputes in mj_setConst; without it some
        # changes are silently ignored.
        b.set_const()

    def flown_params(self) -> VehicleParams:
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
        :class:`VehicleParams` defines them (the body axes B for the packaged vehicle, whose
        ``body_iquat`` is the identity).  ``iquat`` is each run's frame whenever it is not the
        identity (the model's own for parameters without one), so the tensor in B
        (:func:`rcsim.spacecraft.propellant.inertia_tensor_B`) can always be rebuilt from the
        read-back.

        Returns
        -------
        VehicleParams
            ``n_runs`` entries.
        """
        b = self._batch
        body = self._flight.body(BODY).id

        def field_of(name: str) -> np.ndarray:
            # expand() (done in _write_params) made these per-simulation; copy: the live
            # arrays are the batch's own model memory.
            values = b.expanded(name)
            if values is None:  # pragma: no cover - _write_params always expands them
                raise AssertionError(f"{name} is not per-simulation")
            return np.array(values)

        if getattr(self, "_start_params", None) is not None:
            return self._start_params  # propellant tracked: the wet vehicle at t = 0
        if self.params.iquat is not None:
            iquat = field_of("body_iquat")[:, body]
        elif np.array_equal(self._flight.body_iquat[body], IDENTITY_QUAT):
            iquat = None  # principal axes along B, as VehicleParams.nominal says it
        else:  # the model's own frame, every run (what iquat None flies)
            iquat = np.repeat(self._flight.body_iquat[body][None], self.n_runs, axis=0)
        return VehicleParams(
            mass_kg=field_of("body_mass")[:, body],
            cg_B=field_of("body_ipos")[:, body],
            inertia_B=field_of("body_inertia")[:, body],
            thrust_n=self._flown_thrust_n.copy(),
            jet_dir_S=self._flown_dir_S.copy(),
            isp_s=self.params.isp_s,
            iquat=iquat,
        )

    def run(
        self,
        controller: Controller,
        guidance: Guidance,
        duration_s: float,
        *,
        q0_BN: np.ndarray | None = None,
        omega0_B: np.ndarray | None = None,
        disturbance_B: np.ndarray | Callable[[float], np.ndarray] | None = None,
        ctrl_state: Any = None,
        progress: Callable[[int], None] | None = None,
    ) -> History:
        """Fly every run for ``duration_s`` (rounded up to whole control cycles).

        Parameters
        ----------
        controller : Controller
        guidance : Guidance
            Commands, one row per run.
        duration_s : float
            Simulated time [s], > 0.
        q0_BN, omega0_B : ndarray, (n_runs, 4) and (n_runs, 3), optional
            Initial attitude and body rate [rad/s]; default identity and rest.
        disturbance_B : ndarray (n_runs, 3) or callable ``t_s -> (n_runs, 3)``, optional
            External torque about the CG in body axes [N m], held over each cycle.
        ctrl_state : optional
            Controller state to start from; default ``controller.initial_state(n_runs)``.
        progress : callable, optional
            Called with the number of cycles done after each cycle.

        Raises
        ------
        InputError
            ``duration_s`` not > 0; the controller's ``cycle_s`` differs from the
            propulsion's; the history would not fit in memory
            (:func:`rcsim.spacecraft.guards.memory_budget_bytes`); the controller commands another
            number of jets than the vehicle has (at its first step).
        """
        n, cycle = self.n_runs, self.propulsion.cycle_s
        if not np.isfinite(duration_s) or duration_s <= 0:
            raise InputError(
                f"must be > 0, got {duration_s}", parameter="duration_s", value=duration_s
            )
        check_cycle(controller, cycle)
        n_cycles = int(math.ceil(duration_s / cycle - 1e-9))
        check_history_memory(
            n,
            n_cycles,
            duration_s,
            measured=self.sensors is not None,
            delivered=not (self.timing.is_zero() and self.faults is None and self.profile is None),
            n_jets=self.n_jets,
        )
        self._reset(q0_BN, omega0_B)
        if self.tank is not None:
            self._used_kg[:] = 0.0
            self._exhausted_s[:] = np.inf
            self._write_mass_properties(np.arange(n))
        state = controller.initial_state(n) if ctrl_state is None else ctrl_state
        prop = PropulsionState.zeros(n, self.n_jets)
        failed = np.array([bool(r) for r in self.invalid])
        reason = list(self.invalid)
        self._check_warnings(failed, reason, 0.0, 0.0)  # the initial state itself

        t_s = np.arange(n_cycles) * cycle
        sensors = self.sensors
        effects = not (self.timing.is_zero() and self.faults is None and self.profile is None)
        rec = self._history_buffers(n_cycles, measured=sensors is not None, delivered=effects)
        if sensors is not None:
            noise = SensorNoise(self.sensor_streams) if sensors.is_random() else None
            sensor_state = SensorState(np.zeros((n, 3)))
        valves = ValveState.closed(n, self.n_jets)
        thrust = self.params.thrust_n * self._level
        torque = np.zeros((n, 3))
        # The compiled per-cycle passes (rcsim/spacecraft/cycle_kernel.py), bit for bit the numpy
        # forms; decided once per flight.
        self._compiled = cycle_kernel.kernel_available()
        commands = CommandBlocks(guidance, cycle)
        for k in range(n_cycles):
            t0 = k * cycle  # integer tick count -> time: no accumulated float error
            q, w = self._qpos[:, 3:7].copy(), self._qvel[:, 3:6].copy()
            nav = truth = self._navigate(t0, q, w, guidance, commands, k)
            if sensors is not None:
                q_m, w_m = measure(
                    q,
                    w,
                    None if noise is None else noise.draw(k),
                    sensors,
                    sensor_state,
                    cycle,
                )
                nav = self._navigate(t0, q_m, w_m, guidance, commands, k)
                rec["meas_att_err_B"][k] = nav.att_err_B
                rec["meas_rate_err_B"][k] = nav.rate_err_B
            command, state = controller.step(nav, state)
            if k == 0:
                self._check_command(controller, command)
            counted = None if self.tank is None else prop.firings.copy()
            if self._compiled:
                on = cycle_kernel.command_valves(
                    command, failed, prop, self.propulsion, valves, self.timing
                )
            else:
                command = np.where(failed[:, None], 0.0, command)
                on = apply_valve_limits(
                    command, prop, self.propulsion, self.params.thrust_n, account=False
                )
                command_valves(valves, on, self.timing, cycle)
            pieces = self._pieces(valves, t0)
            if counted is not None:
                # A firing commanded at or after the propellant ran out is no firing: the jet
                # delivers nothing (rcsim.spacecraft.propellant, "Exhaustion").  Commands start at
                # the cycle's start, so a run whose exhaustion instant is <= t0 fired nothing.
                dead = self._exhausted_s <= t0  # exhausted_before's rule, for this cycle
                prop.firings[dead] = counted[dead]
            if self._compiled and pieces.uniform and pieces.n_pieces == 1:
                delivered = cycle_kernel.account(pieces.on[:, 0], cycle, thrust, prop)
            else:
                delivered = pieces.on_time_s()
                prop.on_time_s += delivered
                prop.impulse_ns += pieces.thrust_time_s() * thrust
            rec["q_BN"][k] = truth.q_BN
            rec["omega_B"][k] = truth.omega_B
            rec["att_err_B"][k] = truth.att_err_B
            rec["rate_err_B"][k] = truth.rate_err_B
            rec["on_time_s"][k] = on
            if effects:
                rec["delivered_s"][k] = delivered
            if disturbance_B is not None:
                torque = np.asarray(
                    disturbance_B(t0) if callable(disturbance_B) else disturbance_B, float
                )
            self._step(pieces, torque, failed, reason, t0, t0 + cycle)
            if self.tank is not None:
                self._use_propellant(pieces, thrust)
            tail = 0.0 if self.profile is None else self.profile.fall_s
            if self._compiled:
                cycle_kernel.end_cycle(valves, cycle, tail)
            else:
                end_cycle(valves, cycle, tail)
            if progress is not None:
                progress(k + 1)
        final = navigate(
            n_cycles * cycle, self._qpos[:, 3:7].copy(), self._qvel[:, 3:6].copy(), guidance
        )
        # (n_runs, n_cycles, k) views of the cycle-major buffers: a copy would double the peak
        # memory of a large batch and cost a tenth of its wall time.
        rec = {key: value.swapaxes(0, 1) for key, value in rec.items()}
        return History(
            cycle_s=cycle,
            t_s=t_s,
            final=final,
            propulsion=prop,
            failed=failed,
            reason=reason,
            flown_params=self.flown_params(),
            propellant_exhausted_s=None if self.tank is None else self._exhausted_s.copy(),
            **rec,
        )

    def _navigate(
        self,
        t0_s: float,
        q_BN: np.ndarray,
        omega_B: np.ndarray,
        guidance: Guidance,
        commands: CommandBlocks,
        k: int,
    ) -> NavState:
        """Errors of ``(q_BN, omega_B)`` against the command of cycle ``k`` (at ``t0_s``)."""
        if not self._compiled:
            return navigate(t0_s, q_BN, omega_B, guidance)
        return cycle_kernel.navigate(t0_s, q_BN, omega_B, commands.at(k), guidance.omega_cmd_B)

    def _check_command(self, controller: Controller, command: np.ndarray) -> None:
        """Refuse a controller whose commands are not one on-time per run and jet of this
        vehicle (a controller built for another vehicle: a lookup table fires the paper's
        16 jets)."""
        shape = np.shape(command)
        if shape != (self.n_runs, self.n_jets):
            raise InputError(
                f"{type(controller).__name__} commands on-times of shape {shape}; the vehicle "
                f"flies {self.n_runs} run(s) of {self.n_jets} jets: give it a controller for "
                "this vehicle (the allocator flies any jet layout)",
                parameter="controller",
                value=None,
            )

    def _history_buffers(self, n_cycles: int, *, measured: bool, delivered: bool) -> dict:
        """Cycle-major record buffers, (n_cycles, n_runs, k) each: every cycle writes one
        contiguous block, and :meth:`run` returns them as (n_runs, n_cycles, k) views."""
        n = self.n_runs
        rec = {
            "q_BN": np.empty((n_cycles, n, 4)),
            "omega_B": np.empty((n_cycles, n, 3)),
            "att_err_B": np.empty((n_cycles, n, 3)),
            "rate_err_B": np.empty((n_cycles, n, 3)),
            "on_time_s": np.empty((n_cycles, n, self.n_jets)),
        }
        if delivered:
            rec["delivered_s"] = np.empty((n_cycles, n, self.n_jets))
        if measured:
            rec["meas_att_err_B"] = np.empty((n_cycles, n, 3))
            rec["meas_rate_err_B"] = np.empty((n_cycles, n, 3))
        return rec

    def _pieces(self, valves: ValveState, t0_s: float) -> Pieces:
        """The cycle starting at ``t0_s`` cut at every run's switch instants (and on the
        physics grid), with the thrust profile's rise and fall when there is one."""
        intervals = cycle_intervals(valves, self.faults, t0_s)
        pieces = self._cut(*intervals)
        if self.tank is None:
            return pieces
        # Propellant running out in this cycle ends every jet's thrust at that instant.
        thrust = self.params.thrust_n * self._level
        level = pieces.on if pieces.level is None else pieces.level
        left = np.maximum(self.tank.initial_kg - self._used_kg, 0.0)
        t_out = exhaustion_time_s(
            pieces.length_s, level, mass_flow_kg_s(thrust, self.params.isp_s), left
        )
        t_out = np.where(left <= 0.0, 0.0, t_out)
        if not np.isfinite(t_out).any():
            return pieces
        first = np.isfinite(t_out) & ~np.isfinite(self._exhausted_s)
        self._exhausted_s[first] = t0_s + t_out[first]
        start, end = intervals
        return self._cut(start, np.minimum(end, t_out[:, None, None]))

    def _cut(self, start: np.ndarray, end: np.ndarray) -> Pieces:
        """The cycle's pieces for on-intervals ``start``, ``end`` (n_runs, n_jets, k) [s]."""
        cycle = self.propulsion.cycle_s
        grid = self.dt_s if self.n_sub > 1 else None
        if self.profile is None and self._compiled:
            # No run switches a jet inside the cycle (most cycles): the grid steps, as
            # cycle_pieces gives them, without its numpy passes.
            on = cycle_kernel.uniform_on(start, end, cycle)
            if on is not None:
                n, steps = self.n_runs, self.n_sub
                return Pieces(
                    np.full((n, steps), self.dt_s if steps > 1 else cycle),
                    np.broadcast_to(on[:, None, :], (n, steps, on.shape[1])),
                    np.full(n, steps),
                    uniform=True,
                )
        if self.profile is None:
            return cycle_pieces(start, end, cycle, grid)
        return profile_pieces(
            start, end, cycle, grid, self.profile.rise_s, self.profile.fall_s, self.profile.segments
        )

    def _use_propellant(self, pieces: Pieces, thrust_n: np.ndarray) -> None:
        """Add the cycle's propellant to each run's total and move the mass properties of the
        runs that fired (:mod:`rcsim.spacecraft.propellant`)."""
        used = (pieces.thrust_time_s() * thrust_n).sum(axis=1) / (self.params.isp_s * G0_M_S2)
        self._used_kg += used
        fired = np.flatnonzero(used > 0)
        if fired.size:
            self._write_mass_properties(fired)

    def _write_mass_properties(self, ids: np.ndarray) -> None:
        """Mass, CG and inertia of runs ``ids`` after the propellant they used."""
        start, tank = self._start_params, self.tank
        assert tank is not None  # only called when propellant is tracked
        m, c, inertia = mass_properties(
            start.mass_kg[ids],
            start.cg_B[ids],
            self._inertia0_B[ids],
            tank.position_B,
            self._used_kg[ids],
        )
        moments, quat = principal(inertia)
        body, fields = self._flight.body(BODY).id, self._mass_fields
        fields["body_mass"][ids, body] = m
        fields["body_ipos"][ids, body] = c
        fields["body_inertia"][ids, body] = moments
        fields["body_iquat"][ids, body] = quat
        self._batch.set_const(ids)

    def _reset(self, q0_BN, omega0_B) -> None:
        n = self.n_runs
        self._batch.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
        if q0_BN is not None:
            q0 = np.asarray(q0_BN, float).reshape(n, 4)
            self._qpos[:, 3:7] = q0 / np.linalg.norm(q0, axis=1, keepdims=True)
        if omega0_B is not None:
            self._qvel[:, 3:6] = np.asarray(omega0_B, float).reshape(n, 3)
        self._batch.forward()

    def _check_warnings(
        self, failed: np.ndarray, reason: list[str], t0_s: float, t1_s: float
    ) -> None:
        """Fail the runs whose MuJoCo warning counters rose in ``[t0_s, t1_s]``.

        MuJoCo resets a diverged simulation and goes on; its warning counters (zeroed at
        reset) are the only trace (module docstring, "Failures").
        """
        for i, why in warning_reasons(self._warning, ~failed, t0_s, t1_s).items():
            failed[i] = True
            reason[i] = why

    def _step(
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
                "nwj,nsj->nsw", self._wrench, pieces.control() * self._level[:, None, :]
            )
            if control.shape[1] != self.n_sub:  # one on-fraction for all the cycle's steps
                control = np.repeat(control, self.n_sub, axis=1)
            control[:, :, 3:6] += torque[:, None, :]
            self._rollout(self.n_sub, control, alive, failed, reason)
        else:
            self._stretched = True
            wrench = np.einsum(
                "nwj,npj->npw", self._wrench, pieces.control() * self._level[:, None, :]
            )
            wrench[:, :, 3:6] += torque[:, None, :]
            for p in range(pieces.n_pieces):
                runs = alive & ~failed & (pieces.count > p)
                self._timestep[runs] = pieces.length_s[runs, p]
                self._rollout(1, wrench[:, p : p + 1], runs, failed, reason)
        self._check_warnings(failed, reason, t0_s, t1_s)
        if self._compiled and cycle_kernel.bounded_state(self._batch.state, self._qpos, self._qvel):
            return  # every run's state is finite (the test below, without its numpy passes)
        state_ok = np.isfinite(self._qvel.sum(axis=1) + self._qpos.sum(axis=1))
        if state_ok.all():
            return
        for i in np.flatnonzero(~state_ok & ~failed):
            failed[i] = True
            reason[i] = "non-finite state (diverged)"
        # Keep numbers finite so vectorized navigation/controllers stay warning-free.
        self._qpos[~state_ok] = np.nan_to_num(self._qpos[~state_ok])
        self._qvel[~state_ok] = 0.0

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
            self._batch.rollout(
                nstep,
                control=control if everyone else control[ids],
                control_spec=_CTRL,
                record=(),
                ids=None if everyone else ids,
            )
        except SimulationError as exc:
            for i in exc.ids:
                failed[i] = True
                reason[i] = f"MuJoCo error: {self._batch.error(int(i))}"


def simulate_batch(
    params: VehicleParams,
    controller: Controller,
    guidance: Guidance,
    duration_s: float,
    **kwargs,
) -> History:
    """One-call form of :class:`BatchSimulation` (``propulsion``, ``model``, ``nthread``,
    ``sensors``, ``sensor_streams``, ``timing``, ``faults``, ``profile``, ``tank`` go to the
    simulation,
    the rest to
    :meth:`BatchSimulation.run`)."""
    sim_keys = {
        "propulsion",
        "model",
        "nthread",
        "sensors",
        "sensor_streams",
        "timing",
        "faults",
        "profile",
        "tank",
    }
    sim_kw = {k: kwargs.pop(k) for k in list(kwargs) if k in sim_keys}
    return BatchSimulation(params, **sim_kw).run(controller, guidance, duration_s, **kwargs)
