"""Fly scenarios and turn their histories into tables and plots.

:func:`fly` runs one or more runs of a scenario with a named controller;
:func:`history_frame` gives the per-cycle table users read (degrees and deg/s at this
boundary only); :func:`write_flight` writes ``history.parquet`` and the paper-style plots
(Figs 1-2: attitude error; rates with jet commands) atomically.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rcsim.lookup.registry import make_controller
from rcsim.models.errors import InputError
from rcsim.spacecraft.navigation import Guidance, euler321_deg, quat_from_rotvec
from rcsim.spacecraft.propellant import exhausted_text
from rcsim.spacecraft.simulation import Controller, History, simulate_batch
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.model import AXES, jet_name
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: What :func:`fly_batch` passes on to the simulation besides the vehicle and the scenarios.
EFFECT_KEYS = (
    "sensors",
    "sensor_streams",
    "timing",
    "faults",
    "profile",
    "pulse",
    "blowdown",
    "modes",
)


@dataclass(frozen=True)
class Scenario:
    """A flight to fly: commands, initial state, disturbance.  Angles in radians, SI inside.

    Attributes
    ----------
    name : str
    duration_s : float
    att_cmd_rad : ndarray, (3,)
        Commanded attitude as a rotation vector from the initial attitude [rad].
    rate_cmd_rad_s : ndarray, (3,)
        Commanded body rate [rad/s] (nonzero: rate command, attitude follows it).
    omega0_rad_s : ndarray, (3,)
        Initial body rate [rad/s].
    disturbance_n_m : ndarray, (3,)
        Constant external torque about the CG, body axes [N m].
    """

    name: str
    duration_s: float
    att_cmd_rad: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rate_cmd_rad_s: np.ndarray = field(default_factory=lambda: np.zeros(3))
    omega0_rad_s: np.ndarray = field(default_factory=lambda: np.zeros(3))
    disturbance_n_m: np.ndarray = field(default_factory=lambda: np.zeros(3))


def fly_batch(
    scenarios: Sequence[Scenario],
    params: RunParameters,
    controller: Controller,
    *,
    vehicle: Vehicle,
    nthread: int = 0,
    tank: Any = "vehicle",
    **effects,
) -> History:
    """Fly one batch: run ``i`` flies ``scenarios[i]`` with vehicle ``params`` entry ``i``.

    All scenarios must last equally long (one batched simulation).  The one place that turns
    scenarios into batched commands, initial rates and disturbances: single flights, the
    paper's scenarios and campaign chunks all fly through it.

    Parameters
    ----------
    vehicle : rcsim.spacecraft.vehicle.Vehicle
        The vehicle flown (model, cycle, valve limits, nominal timing, tank): ``params`` are
        its runs' parameters.
    tank : rcsim.spacecraft.propellant.PropellantTank, None or "vehicle"
        Propellant tracked per run (:class:`rcsim.spacecraft.simulation.BatchSimulation`);
        default the vehicle's.
    **effects
        Sensors, timing and faults of the runs, passed to
        :class:`rcsim.spacecraft.simulation.BatchSimulation`: ``sensors``
        (:class:`~rcsim.spacecraft.sensors.SensorParams`), ``sensor_streams`` (one
        ``SeedSequence`` per run), ``timing`` (:class:`~rcsim.spacecraft.valves.ValveTiming`),
        ``faults`` (:class:`~rcsim.spacecraft.valves.JetFaults`), ``profile``
        (:class:`~rcsim.spacecraft.valves.ThrustProfile`), ``pulse``
        (:class:`~rcsim.spacecraft.pulse_shape.PulseShape`), ``blowdown``
        (:class:`~rcsim.spacecraft.blowdown.Blowdown`), ``modes``
        (:class:`~rcsim.spacecraft.modes.draws.ModeRuns`); each entry ``(n_runs, ...)``.
        Absent or None: perfect sensors, the vehicle's nominal timing, no faults, instant
        thrust, the vehicle's own pulse and blowdown.

    Raises
    ------
    TypeError
        An effect other than those (a typo must not be silently ignored).
    """
    unknown = sorted(set(effects) - set(EFFECT_KEYS))
    if unknown:
        raise TypeError(
            f"fly_batch: unknown effect(s) {', '.join(unknown)}; known: {', '.join(EFFECT_KEYS)}"
        )
    durations = {s.duration_s for s in scenarios}
    if len(durations) != 1:
        raise ValueError(f"a batch must have one duration, got {sorted(durations)}")
    if params.n_runs != len(scenarios):
        raise ValueError(f"params has {params.n_runs} runs, the batch has {len(scenarios)}")
    stack = lambda name: np.array([np.asarray(getattr(s, name), float) for s in scenarios])  # noqa: E731
    guidance = Guidance(quat_from_rotvec(stack("att_cmd_rad")), stack("rate_cmd_rad_s"))
    disturbance = stack("disturbance_n_m")
    return simulate_batch(
        params,
        controller,
        guidance,
        durations.pop(),
        omega0_B=stack("omega0_rad_s"),
        disturbance_B=disturbance if np.any(disturbance) else None,
        vehicle=vehicle,
        nthread=nthread,
        tank=tank,
        **{k: v for k, v in effects.items() if v is not None},
    )


def fly(
    scenario: Scenario,
    controller: str = "phase-plane",
    *,
    vehicle: Vehicle | str | os.PathLike | None = None,
    table: str | os.PathLike | None = None,
    params: RunParameters | None = None,
    controller_obj: Controller | None = None,
    controller_params: dict | None = None,
) -> History:
    """Fly ``scenario`` for every run of ``params`` (default: one nominal vehicle).

    Parameters
    ----------
    scenario : Scenario
    controller : str
        A controller by name (:func:`rcsim.lookup.registry.make_controller`), built for the
        vehicle and tuned by its profile; ``controller_obj`` instead flies one already built.
    vehicle : Vehicle, str, path or None
        The vehicle flown: a :class:`~rcsim.spacecraft.vehicle.Vehicle`, a packaged
        vehicle's name (``"paper"``, ``"canted16"``), a vehicle file, or None (the paper's):
        its model, nominal parameters, valve limits, valve timing, propellant and profile.
    table : path, optional
        The lookup table (``"lookup"``, ``"adaptive"``).
    params : RunParameters, optional
        The runs' parameters (of ``vehicle``); default one nominal run.
    controller_params : dict, optional
        A plug-in controller's parameters (:mod:`rcsim.lookup.plugins`).

    Returns
    -------
    History
        Its :meth:`~rcsim.spacecraft.history.History.control_lost` says which runs lost
        control (the attitude error rose far above its start:
        :data:`~rcsim.spacecraft.history.CONTROL_LOST_DEG`), as :func:`flight_summary` does.

    Raises
    ------
    InputError
        The scenario's disturbance exceeds the jets' largest torque about an axis
        (:meth:`Vehicle.disturbance_problem`, the rule a campaign and ``rcsim scenario run``
        apply): no controller could hold it.
    """
    vehicle = Vehicle.load(vehicle)
    dist = np.asarray(scenario.disturbance_n_m, float)
    problem = vehicle.disturbance_problem(dist)
    if problem:
        raise InputError(
            f"Scenario {scenario.name!r}: disturbance_n_m: {problem} (got {dist.tolist()} N m)",
            value=dist.tolist(),
        )
    params = vehicle.nominal(1) if params is None else params
    ctl = controller_obj or make_controller(
        controller, vehicle, table=table, plugin_params=controller_params
    )
    return fly_batch([scenario] * params.n_runs, params, ctl, vehicle=vehicle)


def controller_record(name: str, controller: Controller) -> dict:
    """What a flight's summary records of its controller: the name, and for a plug-in
    (:mod:`rcsim.lookup.plugins`) its target, distribution, version and source SHA-256."""
    info = getattr(controller, "info", None)
    record: dict = {"controller": name}
    if info is not None and hasattr(info, "record"):
        record["plugin"] = info.record()
    return record


def history_frame(history: History, run: int = 0) -> pd.DataFrame:
    """Per-cycle table of one run: ``t_s``, attitude (deg), errors (deg, deg/s), jet on-times (s).

    ``att_err_<axis>_deg`` are the components of the attitude-error rotation vector;
    ``roll_deg`` etc. are 3-2-1 Euler angles of the attitude; ``rate_<axis>_deg_s`` the body
    rates; ``jet_NN_on_s`` the on-time commanded to jet NN in that cycle (one column per jet of
    the flown vehicle).  With imperfect sensors, ``meas_att_err_<axis>_deg`` and
    ``meas_rate_err_<axis>_deg_s`` are the errors the controller measured; with valve timing,
    jet faults or a thrust profile, ``jet_NN_delivered_s`` the time the jet thrust in that
    cycle (the command moved by the delays, plus stuck-on time, minus failed time;
    :class:`rcsim.spacecraft.history.History`).  A vehicle with slosh or appendages adds each
    mode coordinate and its rate at the cycle's start: ``<joint>_m``, ``<joint>_m_s`` for a
    slide (spring slosh), ``<joint>_deg``, ``<joint>_deg_s`` for a hinge (pendulum, panel).
    """
    cols: dict[str, np.ndarray] = {"t_s": history.t_s}
    euler = euler321_deg(history.q_BN[run])
    for a, axis in enumerate(AXES):
        cols[f"att_err_{axis}_deg"] = np.degrees(history.att_err_B[run, :, a])
    for a, axis in enumerate(AXES):
        cols[f"rate_{axis}_deg_s"] = np.degrees(history.omega_B[run, :, a])
    for a, axis in enumerate(AXES):
        cols[f"rate_err_{axis}_deg_s"] = np.degrees(history.rate_err_B[run, :, a])
    for a, axis in enumerate(AXES):
        cols[f"{axis}_deg"] = euler[:, a]
    names = [jet_name(j + 1) for j in range(history.n_jets)]  # the flown vehicle's jets
    for j, name in enumerate(names):
        cols[f"{name}_on_s"] = history.on_time_s[run, :, j]
    # What the controller saw (imperfect sensors) and what the jets delivered (valve timing,
    # faults, thrust profile): recorded only when they differ from the columns above.
    if history.meas_att_err_B is not None and history.meas_rate_err_B is not None:
        for a, axis in enumerate(AXES):
            cols[f"meas_att_err_{axis}_deg"] = np.degrees(history.meas_att_err_B[run, :, a])
        for a, axis in enumerate(AXES):
            cols[f"meas_rate_err_{axis}_deg_s"] = np.degrees(history.meas_rate_err_B[run, :, a])
    if history.delivered_s is not None:
        for j, name in enumerate(names):
            cols[f"{name}_delivered_s"] = history.delivered_s[run, :, j]
    if history.mode_q is not None and history.mode_qd is not None:
        for k, (name, kind) in enumerate(zip(history.mode_names, history.mode_kinds)):
            q, qd = history.mode_q[run, :, k], history.mode_qd[run, :, k]
            if kind == "slide":
                cols[f"{name}_m"], cols[f"{name}_m_s"] = q, qd
            else:
                cols[f"{name}_deg"], cols[f"{name}_deg_s"] = np.degrees(q), np.degrees(qd)
    return pd.DataFrame(cols)


def flight_summary(history: History, run: int = 0) -> dict:
    """Final errors, firings, propellant of one run (degrees at this boundary).

    ``propellant_exhausted_s``: when a vehicle file's tracked propellant ran out [s] (None:
    it did not, or is not tracked); the jets deliver nothing after it, and commands after it
    are not counted in ``firings`` (:mod:`rcsim.spacecraft.propellant`).  ``control_lost``:
    the total attitude error rose more than
    :data:`~rcsim.spacecraft.history.CONTROL_LOST_DEG` above its value at the start
    (:meth:`~rcsim.spacecraft.history.History.control_lost`).  ``reason``: the simulator's
    own when ``sim_failed``, else ``"propellant exhausted at t = ... s"`` when the propellant
    ran out (a campaign's failure reason), else the control loss when control was lost,
    else empty.
    """
    final = history.final
    exhausted = history.propellant_exhausted_s
    t_out = float(exhausted[run]) if exhausted is not None and np.isfinite(exhausted[run]) else None
    reason = history.reason[run]
    if not reason and t_out is not None:
        reason = exhausted_text(t_out)
    lost = history.control_lost_text(run)
    if not reason:
        reason = lost
    return {
        "final_att_err_deg": np.degrees(final.att_err_B[run]).round(6).tolist(),
        "final_rate_err_deg_s": np.degrees(final.rate_err_B[run]).round(6).tolist(),
        "firings": int(history.propulsion.firings[run].sum()),
        "on_time_s": float(history.propulsion.on_time_s[run].sum()),
        # The simulation itself failed (MuJoCo error or warning, diverged state): the numbers
        # above are then not a flight.
        "sim_failed": bool(history.failed[run]),
        "propellant_exhausted_s": t_out,
        "control_lost": bool(lost),
        "reason": reason,
    }


def write_flight(
    history: History,
    out_dir: str | os.PathLike,
    *,
    title: str,
    vehicle: Vehicle,
    run: int = 0,
    command: str | None = None,
    overwrite: bool = False,
    record: dict | None = None,
) -> dict[str, Path]:
    """Write ``history.parquet``, ``attitude_error.png``, ``rates_jets.png`` and
    ``summary.json`` for one run of ``vehicle`` into ``out_dir`` (atomically).

    ``command`` (e.g. ``"maneuver"``) is recorded in the directory's marker, and ``overwrite``
    allows replacing an earlier output of that command
    (:func:`rcsim.analysis.engine.output.atomic_dir`).  The plot draws each axis's jets by the
    vehicle's torque signs; the summary names the vehicle and the profile flown, plus
    ``record`` (e.g. :func:`controller_record`: which controller, a plug-in's source).
    """
    import json

    from rcsim.analysis.engine.output import atomic_dir
    from rcsim.analysis.engine.plots import plot_attitude_error, plot_rates_and_jets, signed_jets_of

    frame = history_frame(history, run)
    summary = flight_summary(history, run)
    summary["propellant_kg"] = float(history.propellant_kg[run])
    summary["title"] = title
    summary.update(vehicle.record())
    summary.update(record or {})
    with atomic_dir(out_dir, command, overwrite=overwrite) as tmp:
        frame.to_parquet(tmp / "history.parquet", index=False)
        plot_attitude_error(frame, tmp / "attitude_error.png", title=title)
        signed = signed_jets_of(vehicle.axis_signs)
        plot_rates_and_jets(frame, tmp / "rates_jets.png", title=title, signed=signed)
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    out = Path(out_dir)
    return {
        name: out / name
        for name in ("history.parquet", "attitude_error.png", "rates_jets.png", "summary.json")
    }
