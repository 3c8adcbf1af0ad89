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
(:func:`rcsim.spacecraft.vehicle.model.route_mujoco_warnings`), never to a ``MUJOCO_LOG.TXT``.

The vehicle
-----------
A simulation flies one :class:`~rcsim.spacecraft.vehicle.Vehicle`: its compiled model, its
profile's control cycle (the one owner of the cycle: controllers are built from the same
profile), its valve limits, its nominal valve timing and its propellant tank, unless a flight
gives per-run timing or a per-run tank.  ``params`` are the runs' (dispersed) parameters of
that vehicle.

Refusals
--------
:meth:`BatchSimulation.run` refuses, before allocating anything, a controller whose control
cycle is not the vehicle's, and a history that would not fit in memory
(:func:`rcsim.spacecraft.guards.memory_budget_bytes`).  The constructor refuses invalid sensor,
timing, fault and thrust-profile parameters (:class:`rcsim.models.errors.InputError`).

Compiled passes
---------------
When the optional extension is built, navigation's algebra, the valve limits and commands, the
no-switch test, the propulsion totals and the end of a cycle run as compiled passes
(:mod:`rcsim.spacecraft.cycle_kernel`), bit for bit the numpy forms, which stay the reference
(``RCSIM_NUMPY_CYCLE=1``); the choice is made once per :meth:`BatchSimulation.run`.

MuJoCo's side (the batch, per-run parameters, piecewise stepping, failures, mass properties) is
:class:`rcsim.spacecraft.batch_physics.BatchPhysics`; the pure parts are in
:mod:`rcsim.spacecraft.pieces`, :mod:`~rcsim.spacecraft.valves`, :mod:`~rcsim.spacecraft.sensors`,
:mod:`~rcsim.spacecraft.history`, :mod:`~rcsim.spacecraft.guards`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import mujoco
import numpy as np

from rcsim.models.errors import InputError
from rcsim.spacecraft import cycle_kernel
from rcsim.spacecraft.batch_physics import BatchPhysics
from rcsim.spacecraft.blowdown import Blowdown
from rcsim.spacecraft.controller import Controller
from rcsim.spacecraft.guards import (
    check_cycle,
    check_history_memory,
    invalid_runs,
)
from rcsim.spacecraft.history import History, history_buffers
from rcsim.spacecraft.modes.draws import ModeRuns
from rcsim.spacecraft.mujoco_timers import quiet_stage_timers
from rcsim.spacecraft.navigation import CommandBlocks, Guidance, NavState, navigate
from rcsim.spacecraft.pieces import Pieces, cycle_pieces, profile_pieces
from rcsim.spacecraft.propellant import (
    PropellantTank,
    exhaustion_time_s,
    mass_flow_kg_s,
)
from rcsim.spacecraft.propulsion import PropulsionState, apply_valve_limits
from rcsim.spacecraft.pulse_shape import (
    PulseShape,
    propellant_instant,
    shaped_pieces,
    table_intervals,
)
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
from rcsim.spacecraft.vehicle.model import jet_count, route_mujoco_warnings
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2, RunParameters

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle.vehicle import Vehicle

_CTRL = int(mujoco.mjtState.mjSTATE_CTRL)

__all__ = ["BatchSimulation", "Controller", "History", "simulate_batch"]


@dataclass
class _Flight:
    """What one :meth:`BatchSimulation.run` carries from cycle to cycle (arrays per run)."""

    controller: Controller
    guidance: Guidance
    commands: CommandBlocks
    disturbance_B: Any
    n_cycles: int
    state: Any
    prop: PropulsionState
    failed: np.ndarray
    reason: list
    rec: dict
    valves: ValveState
    thrust_n: np.ndarray
    torque_B: np.ndarray
    noise: SensorNoise | None
    sensor_state: SensorState | None
    delivered: bool
    # Pulse-mode Isp: steady Isp over each valve slot's pulse Isp, (n_runs, n_jets, slots).
    inv_isp: np.ndarray | None = None


class BatchSimulation:
    """``n_runs`` vehicles, each with its own parameters, stepped together.

    Parameters
    ----------
    params : RunParameters
        One entry per run, of ``vehicle``.  Runs with non-finite or non-physical values are
        flown with the nominal vehicle's values and reported failed ("invalid parameter ...").
        Its per-jet arrays must be as wide as the vehicle has jets; every per-jet array of the
        flight is that wide.
    vehicle : rcsim.spacecraft.vehicle.Vehicle
        The vehicle flown: its model (``opt.timestep``, integrator), its profile's control
        cycle, its valve limits, its nominal valve timing and its tank.  The timestep is the
        longest piece of a cycle (module docstring, "Exact in time").
    nthread : int
        MuJoCo worker threads (0: all CPUs).
    sensors : SensorParams, optional
        Sensor errors per run; default perfect sensors.
    sensor_streams : sequence of numpy.random.SeedSequence, optional
        One per run, the run's sensor-noise stream
        (:func:`rcsim.spacecraft.effect_draws.effect_streams`); required when ``sensors`` has
        noise or a random walk.
    timing : ValveTiming, optional
        Command (sensor-to-actuator) delay and valve latencies per run (per jet, or one
        column for every jet); default the vehicle's nominal timing (none when it has none).
    faults : JetFaults, optional
        Jet faults per run (per jet, or one column for every jet); default none.
    profile : ThrustProfile, optional
        Thrust transients at valve opening and closing; default none (instant thrust).
    pulse : PulseShape, None or "vehicle"
        Real pulses (thrust rise and tail-off, or an impulse-bit table, and a pulse-mode Isp;
        :mod:`rcsim.spacecraft.pulse_shape`); ``"vehicle"`` (default): the vehicle file's
        ``[pulse]`` (none without one: square pulses, exactly as before).  Not with
        ``profile``.
    blowdown : Blowdown, None or "vehicle"
        Tank pressure falling as the propellant is used, the jets' thrust and Isp with it
        (:mod:`rcsim.spacecraft.blowdown`; needs a tank); ``"vehicle"`` (default): the vehicle
        file's ``[propellant.blowdown]`` (none without one, or with ``tank`` None: the
        pulses of the wet vehicle at its initial pressure).
    tank : PropellantTank, None or "vehicle"
        Propellant tracked per run: the mass properties follow the propellant used and the
        jets stop when it runs out (:mod:`rcsim.spacecraft.propellant`).  ``"vehicle"``
        (default): the vehicle's (none when its file gives no propellant mass); None: not
        tracked (accounted only, the mass properties stay ``params``': a jet-response
        database's pulses from the wet vehicle).
    modes : ModeRuns, optional
        Each run's slosh masses, mode frequencies and damping ratios
        (:mod:`rcsim.spacecraft.modes.draws`); None (default): the vehicle file's modes as
        compiled, every run alike.

    Raises
    ------
    InputError
        Invalid sensor, timing or fault parameters (per-jet values for another jet count
        among them); noisy sensors without streams; ``params`` for another jet count than
        the vehicle's.
    """

    def __init__(
        self,
        params: RunParameters,
        vehicle: Vehicle,
        *,
        nthread: int = 0,
        sensors: SensorParams | None = None,
        sensor_streams=None,
        timing: ValveTiming | None = None,
        faults: JetFaults | None = None,
        profile: ThrustProfile | None = None,
        tank: PropellantTank | Literal["vehicle"] | None = "vehicle",
        pulse: PulseShape | Literal["vehicle"] | None = "vehicle",
        blowdown: Blowdown | Literal["vehicle"] | None = "vehicle",
        modes: ModeRuns | None = None,
    ):
        route_mujoco_warnings()
        quiet_stage_timers()
        n = params.n_runs
        self.vehicle = vehicle
        self.model = vehicle.model
        self.propulsion = propulsion = vehicle.propulsion()
        timing = vehicle.timing(n) if timing is None else timing
        tank = vehicle.tank(n) if isinstance(tank, str) else tank
        pulse = vehicle.pulse_shape(n) if isinstance(pulse, str) else pulse
        if isinstance(blowdown, str):  # the vehicle's, when its propellant is tracked
            blowdown = None if tank is None else vehicle.blowdown(n)
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
        ramps = (0.0, 0.0) if self.profile is None else (self.profile.rise_s, self.profile.fall_s)
        if max(ramps) >= propulsion.cycle_s:
            raise InputError(
                f"rise_s and fall_s must be shorter than the {propulsion.cycle_s:g} s control "
                f"cycle, got {self.profile}",
                parameter="profile",
                value=None,
            )
        self.pulse = pulse
        if pulse is not None and self.profile is not None:
            raise InputError(
                "a thrust profile and a pulse shape are two models of one pulse: give one",
                parameter="profile",
                value=None,
            )
        if blowdown is not None and tank is None:
            raise InputError(
                "needs a tracked propellant tank (the pressure follows the propellant used)",
                parameter="blowdown",
                value=None,
            )
        self.blowdown = blowdown
        # Thrust left after a valve closes, what end_cycle keeps an interval for (a table's
        # pulses carry their own end).
        self._tail_s = (
            0.0
            if pulse is None or pulse.model == "table"
            else float(np.max(pulse.tail_length_s(), initial=0.0))
        )
        self.params = params
        dt = float(self.model.opt.timestep)
        n_sub = int(round(propulsion.cycle_s / dt))
        if n_sub < 1 or abs(n_sub * dt - propulsion.cycle_s) > 1e-9 * propulsion.cycle_s:
            raise ValueError(
                f"physics step {dt} s does not divide the control cycle {propulsion.cycle_s} s"
            )
        self.dt_s, self.n_sub = dt, n_sub
        self.invalid = invalid_runs(params)
        self.physics = BatchPhysics(
            self.model,
            params,
            self.invalid,
            nthread=nthread,
            level=(
                np.ones((n, self.n_jets))
                if self.faults is None
                else self.faults.thrust_factor.copy()
            ),
            n_sub=n_sub,
            flight=self.vehicle.flight_model,
            modes=modes,
        )
        self.tank = tank
        self._base_level = self.physics.level.copy()  # faults' factors, before any blowdown
        self._isp_s: float | np.ndarray = params.isp_s
        if tank is not None:
            if tank.initial_kg.shape != (n,):
                raise InputError(
                    f"needs one value per run ({n}), got {tank.initial_kg.shape}",
                    parameter="tank",
                )
            self.physics.track_propellant(tank)

    @property
    def n_runs(self) -> int:
        return self.params.n_runs

    def flown_params(self) -> RunParameters:
        """The parameters each run is flown with, read back from MuJoCo's per-run model
        (:meth:`rcsim.spacecraft.batch_physics.BatchPhysics.flown_params`)."""
        return self.physics.flown_params()

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
            vehicle's; the history would not fit in memory
            (:func:`rcsim.spacecraft.guards.memory_budget_bytes`); the controller commands another
            number of jets than the vehicle has (at its first step).
        """
        flight = self._start(
            controller, guidance, duration_s, q0_BN, omega0_B, disturbance_B, ctrl_state
        )
        for k in range(flight.n_cycles):
            self._cycle(k, flight)
            if progress is not None:
                progress(k + 1)
        return self._finish(flight)

    def _start(
        self, controller, guidance, duration_s, q0_BN, omega0_B, disturbance_B, ctrl_state
    ) -> _Flight:
        """Checks, initial state and record buffers of a flight."""
        n, cycle = self.n_runs, self.propulsion.cycle_s
        if not np.isfinite(duration_s) or duration_s <= 0:
            raise InputError(
                f"must be > 0, got {duration_s}", parameter="duration_s", value=duration_s
            )
        check_cycle(controller, cycle)
        n_cycles = int(math.ceil(duration_s / cycle - 1e-9))
        delivered = not (
            self.timing.is_zero()
            and self.faults is None
            and self.profile is None
            and self.pulse is None
        )
        check_history_memory(
            n,
            n_cycles,
            duration_s,
            measured=self.sensors is not None,
            delivered=delivered,
            n_jets=self.n_jets,
            n_modes=len(self.physics.mode_names),
        )
        physics = self.physics
        physics.reset(q0_BN, omega0_B)
        if self.tank is not None:
            physics.used_kg[:] = 0.0
            physics.exhausted_s[:] = np.inf
            physics.write_mass_properties(np.arange(n))
        failed = np.array([bool(r) for r in self.invalid])
        reason = list(self.invalid)
        physics.check_warnings(failed, reason, 0.0, 0.0)  # the initial state itself
        if self.blowdown is not None:
            self._follow_pressure()
        self._v0_N = physics.cg_velocity_N()  # the start of the flight's delta-v
        sensors = self.sensors
        # The compiled per-cycle passes (rcsim/spacecraft/cycle_kernel.py), bit for bit the numpy
        # forms; decided once per flight.
        self._compiled = physics.compiled = cycle_kernel.kernel_available()
        flight = _Flight(
            controller=controller,
            guidance=guidance,
            commands=CommandBlocks(guidance, cycle),
            disturbance_B=disturbance_B,
            n_cycles=n_cycles,
            state=controller.initial_state(n) if ctrl_state is None else ctrl_state,
            prop=self._propulsion_state(),
            failed=failed,
            reason=reason,
            rec=history_buffers(
                n_cycles,
                n,
                self.n_jets,
                measured=sensors is not None,
                delivered=delivered,
                n_modes=len(physics.mode_names),
            ),
            valves=self._closed_valves(),
            thrust_n=self.params.thrust_n * physics.level,
            torque_B=np.zeros((n, 3)),
            noise=(
                SensorNoise(self.sensor_streams)
                if sensors is not None and sensors.is_random()
                else None
            ),
            sensor_state=None if sensors is None else SensorState(np.zeros((n, 3))),
            delivered=delivered,
            inv_isp=(
                None
                if self.pulse is None or self.pulse.isp is None
                else np.ones(self._closed_valves().start.shape)
            ),
        )
        self._flight_inv_isp = flight.inv_isp  # the cut reads it (BatchSimulation._cut)
        return flight

    def _propulsion_state(self) -> PropulsionState:
        """Nothing fired; keeping each jet's propellant when the Isp is not one number."""
        prop = PropulsionState.zeros(self.n_runs, self.n_jets)
        varying_isp = (self.pulse is not None and self.pulse.isp is not None) or (
            self.blowdown is not None and self.blowdown.isp_exponent != 0.0
        )
        if varying_isp:
            prop.used_kg = np.zeros(prop.impulse_ns.shape)
        return prop

    def _closed_valves(self) -> ValveState:
        """Every valve closed, with the slots the pulse shape's tails need."""
        n = self.n_runs
        if self.pulse is None:
            return ValveState.closed(n, self.n_jets)
        delay = float(
            np.max(self.timing.command_delay_s, initial=0.0)
            + np.max(self.timing.close_delay_s, initial=0.0)
        )
        slots = self.pulse.n_slots(self.propulsion.cycle_s, delay)
        shape = (n, self.n_jets, slots)
        return ValveState(np.full(shape, np.nan), np.full(shape, np.nan), np.zeros(shape[:2], bool))

    def _follow_pressure(self) -> None:
        """Thrust and Isp of the next cycle at the tank pressure of the propellant used so
        far (:mod:`rcsim.spacecraft.blowdown`: once per cycle, as the mass properties)."""
        blowdown = self.blowdown
        assert blowdown is not None
        used = self.physics.used_kg
        self.physics.level[:] = self._base_level * blowdown.thrust_factor(used)[:, None]
        self._isp_s = self.params.isp_s * blowdown.isp_factor(used)

    def _isp_column(self) -> float | np.ndarray:
        """The Isp flown [s]: the vehicle's, or each run's (n_runs, 1) under a blowdown."""
        return self._isp_s if np.ndim(self._isp_s) == 0 else np.reshape(self._isp_s, (-1, 1))

    def _cycle(self, k: int, f: _Flight) -> None:
        """Control cycle ``k``: sense, command, cut at the switch instants, integrate."""
        cycle = self.propulsion.cycle_s
        t0 = k * cycle  # integer tick count -> time: no accumulated float error
        nav, truth = self._sense(k, t0, f)
        # Firings so far: one commanded after the propellant ran out is taken back (_account).
        counted = None if self.tank is None else f.prop.firings.copy()
        on = self._command(k, nav, f)
        pieces = self._pieces(f.valves, t0)
        delivered = self._account(pieces, t0, f, counted)
        rec = f.rec
        rec["q_BN"][k] = truth.q_BN
        rec["omega_B"][k] = truth.omega_B
        rec["att_err_B"][k] = truth.att_err_B
        rec["rate_err_B"][k] = truth.rate_err_B
        rec["on_time_s"][k] = on
        if "mode_q" in rec:  # a vehicle with modes: their joints follow the free joint's
            rec["mode_q"][k] = self.physics.qpos[:, 7:]
            rec["mode_qd"][k] = self.physics.qvel[:, 6:]
        if f.delivered:
            rec["delivered_s"][k] = delivered
        if f.disturbance_B is not None:
            d = f.disturbance_B
            f.torque_B = np.asarray(d(t0) if callable(d) else d, float)
        self.physics.step(pieces, f.torque_B, f.failed, f.reason, t0, t0 + cycle)
        if self.tank is not None:
            self.physics.use_propellant(pieces, f.thrust_n, self._isp_s)
        if self.blowdown is not None:
            self._follow_pressure()
            f.thrust_n = self.params.thrust_n * self.physics.level
        tail = self._tail_s if self.profile is None else self.profile.fall_s
        if self._compiled:
            cycle_kernel.end_cycle(f.valves, cycle, tail)
        else:
            end_cycle(f.valves, cycle, tail)

    def _sense(self, k: int, t0: float, f: _Flight) -> tuple[NavState, NavState]:
        """What the controller sees in cycle ``k`` (through the sensors) and the truth."""
        q, w = self.physics.qpos[:, 3:7].copy(), self.physics.qvel[:, 3:6].copy()
        nav = truth = self._navigate(t0, q, w, f.guidance, f.commands, k)
        if self.sensors is not None:
            assert f.sensor_state is not None  # set up with the sensors
            q_m, w_m = measure(
                q,
                w,
                None if f.noise is None else f.noise.draw(k),
                self.sensors,
                f.sensor_state,
                self.propulsion.cycle_s,
            )
            nav = self._navigate(t0, q_m, w_m, f.guidance, f.commands, k)
            f.rec["meas_att_err_B"][k] = nav.att_err_B
            f.rec["meas_rate_err_B"][k] = nav.rate_err_B
        return nav, truth

    def _command(self, k: int, nav: NavState, f: _Flight) -> np.ndarray:
        """The controller's step, then the valve limits and the valves' commands: the
        on-times the jets are commanded this cycle, (n_runs, n_jets) [s]."""
        command, f.state = f.controller.step(nav, f.state)
        if k == 0:
            self._check_command(f.controller, command)
        before = None
        if self.pulse is not None:
            before = (np.isnan(f.valves.start), ~np.isfinite(f.valves.end))
        if self._compiled:
            on = cycle_kernel.command_valves(
                command, f.failed, f.prop, self.propulsion, f.valves, self.timing
            )
        else:
            command = np.where(f.failed[:, None], 0.0, command)
            on = apply_valve_limits(
                command, f.prop, self.propulsion, self.params.thrust_n, account=False
            )
            command_valves(f.valves, on, self.timing, self.propulsion.cycle_s)
        if before is not None:
            self._shape_pulses(f, *before)
        return on

    def _shape_pulses(self, f: _Flight, was_free: np.ndarray, was_open: np.ndarray) -> None:
        """The valve slots the cycle's commands opened or closed (``was_free``: empty before,
        ``was_open``: without a close before): a table's equivalent pulses, and each new
        pulse's Isp (:mod:`rcsim.spacecraft.pulse_shape`)."""
        pulse = self.pulse
        assert pulse is not None
        valves = f.valves
        new_start = was_free & ~np.isnan(valves.start)
        new_end = was_open & np.isfinite(valves.end)
        if f.inv_isp is not None and new_start.any():
            assert pulse.isp is not None
            u = np.where(new_end, valves.end - valves.start, np.inf)  # inf: a steady firing
            ratio = pulse.isp.steady_isp_s / pulse.isp.isp_at(u)
            f.inv_isp[new_start] = ratio[new_start]
        if pulse.model == "table":
            table_intervals(pulse, valves.start, valves.end, new_start, new_end)

    def _account(
        self, pieces: Pieces, t0: float, f: _Flight, counted: np.ndarray | None
    ) -> np.ndarray:
        """Firings, on-time and impulse of the cycle (a firing commanded after the propellant
        ran out is none: ``counted``, the firings before the cycle's commands, stand); returns
        the on-time each jet delivered, (n_runs, n_jets) [s]."""
        prop = f.prop
        if counted is not None:
            # A firing commanded at or after the propellant ran out is no firing: the jet
            # delivers nothing (rcsim.spacecraft.propellant, "Exhaustion").  Commands start at
            # the cycle's start, so a run whose exhaustion instant is <= t0 fired nothing.
            dead = self.physics.exhausted_s <= t0  # exhausted_before's rule, for this cycle
            prop.firings[dead] = counted[dead]
        if prop.used_kg is not None:
            prop.used_kg += pieces.flow_time_s() * f.thrust_n / (self._isp_column() * G0_M_S2)
        if self._compiled and pieces.uniform and pieces.n_pieces == 1:
            return cycle_kernel.account(pieces.on[:, 0], self.propulsion.cycle_s, f.thrust_n, prop)
        delivered = pieces.on_time_s()
        prop.on_time_s += delivered
        prop.impulse_ns += pieces.thrust_time_s() * f.thrust_n
        return delivered

    def _finish(self, f: _Flight) -> History:
        """The flight's history: the record as (n_runs, n_cycles, k) views, final errors."""
        cycle = self.propulsion.cycle_s
        physics = self.physics
        final = navigate(
            f.n_cycles * cycle, physics.qpos[:, 3:7].copy(), physics.qvel[:, 3:6].copy(), f.guidance
        )
        # (n_runs, n_cycles, k) views of the cycle-major buffers: a copy would double the peak
        # memory of a large batch and cost a tenth of its wall time.
        rec = {key: value.swapaxes(0, 1) for key, value in f.rec.items()}
        flown = self.flown_params()
        return History(
            cycle_s=cycle,
            t_s=np.arange(f.n_cycles) * cycle,
            final=final,
            propulsion=f.prop,
            failed=f.failed,
            reason=f.reason,
            flown_params=flown,
            propellant_exhausted_s=None if self.tank is None else physics.exhausted_s.copy(),
            delta_v_N=physics.cg_velocity_N() - self._v0_N,
            delta_v_B=np.einsum("nj,nja->na", f.prop.impulse_ns, physics.jet_directions_B())
            / (flown.mass_kg + physics.mode_mass_kg)[:, None],
            min_pulse_s=self.propulsion.min_pulse_s,
            mode_names=physics.mode_names,
            mode_kinds=physics.mode_kinds,
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

    def _pieces(self, valves: ValveState, t0_s: float) -> Pieces:
        """The cycle starting at ``t0_s`` cut at every run's switch instants (and on the
        physics grid), with the thrust profile's rise and fall when there is one."""
        intervals = cycle_intervals(valves, self.faults, t0_s)
        pieces = self._cut(*intervals)
        if self.tank is None:
            return pieces
        # Propellant running out in this cycle ends every jet's thrust at that instant.
        physics = self.physics
        thrust = self.params.thrust_n * physics.level
        level = pieces.flow_fraction()
        left = np.maximum(self.tank.initial_kg - physics.used_kg, 0.0)
        flow = mass_flow_kg_s(thrust, self._isp_column())
        t_out = exhaustion_time_s(pieces.length_s, level, flow, left)
        t_out = np.where(left <= 0.0, 0.0, t_out)
        if not np.isfinite(t_out).any():
            return pieces
        if self.pulse is not None:
            # The pieces' mean flow finds the cycle; the shapes' integrals, the instant.
            rows = np.flatnonzero(np.isfinite(t_out) & (left > 0.0))
            if rows.size:
                start, end = intervals
                inv_isp = self._slot_weights(start)
                t_out[rows] = propellant_instant(
                    self.pulse.take(rows),
                    start[rows],
                    end[rows],
                    flow[rows],
                    left[rows],
                    self.propulsion.cycle_s,
                    None if inv_isp is None else inv_isp[rows],
                )
        first = np.isfinite(t_out) & ~np.isfinite(physics.exhausted_s)
        physics.exhausted_s[first] = t0_s + t_out[first]
        start, end = intervals
        if self.pulse is not None:  # the thrust stops there, a closing valve's tail too
            return self._cut(start, end, stop_s=t_out)
        return self._cut(start, np.minimum(end, t_out[:, None, None]))

    def _slot_weights(self, start: np.ndarray) -> np.ndarray | None:
        """Each valve interval's Isp weight (pulse-mode Isp; a stuck-on window: steady),
        shaped as the cycle's intervals ``start``; None without a pulse-mode Isp."""
        inv_isp = self._flight_inv_isp
        if inv_isp is not None and inv_isp.shape != start.shape:  # a stuck-on window: steady
            inv_isp = np.concatenate([inv_isp, np.ones(start.shape[:2] + (1,))], axis=-1)
        return inv_isp

    def _cut(self, start: np.ndarray, end: np.ndarray, stop_s: np.ndarray | None = None) -> Pieces:
        """The cycle's pieces for on-intervals ``start``, ``end`` (n_runs, n_jets, k) [s];
        ``stop_s`` (n_runs,): no thrust from it on (a pulse shape's propellant running out)."""
        cycle = self.propulsion.cycle_s
        grid = self.dt_s if self.n_sub > 1 else None
        if self.profile is None and self.pulse is None and self._compiled:
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
        if self.pulse is not None:
            inv_isp = self._slot_weights(start)
            return shaped_pieces(start, end, cycle, grid, self.pulse, inv_isp, stop_s)
        if self.profile is None:
            return cycle_pieces(start, end, cycle, grid)
        return profile_pieces(
            start, end, cycle, grid, self.profile.rise_s, self.profile.fall_s, self.profile.segments
        )


def simulate_batch(
    params: RunParameters,
    controller: Controller,
    guidance: Guidance,
    duration_s: float,
    *,
    vehicle: Vehicle,
    **kwargs,
) -> History:
    """One-call form of :class:`BatchSimulation` (``vehicle``, ``nthread``, ``sensors``,
    ``sensor_streams``, ``timing``, ``faults``, ``profile``, ``tank``, ``pulse``, ``blowdown``,
    ``modes`` go to the simulation, the
    rest to :meth:`BatchSimulation.run`)."""
    sim_keys = {
        "nthread",
        "sensors",
        "sensor_streams",
        "timing",
        "faults",
        "profile",
        "tank",
        "pulse",
        "blowdown",
        "modes",
    }
    sim_kw = {k: kwargs.pop(k) for k in list(kwargs) if k in sim_keys}
    return BatchSimulation(params, vehicle, **sim_kw).run(
        controller, guidance, duration_s, **kwargs
    )
