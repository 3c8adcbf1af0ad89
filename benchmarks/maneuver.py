"""Throughput of the closed loop against raw batched MuJoCo stepping and a naive loop.

Prints simulated seconds per wall second for

* ``closed loop``: 256 runs of the 5/5/5 deg three-axis phase-plane maneuver, 60 s each, through
  :func:`rcsim.spacecraft.simulation.simulate_batch` (vectorized controller every 40 ms cycle,
  MuJoCo batch rollout of the cycle's physics steps with the GIL released);
* ``raw``: the same number of physics steps of 256 runs in :meth:`mujoco.batch.Batch.rollout`
  with a precomputed control array and no controller (long rollouts of ``CHUNK_S`` of simulated
  time; one control chunk built from the closed loop's own duties of the first ``CHUNK_S`` is
  reused for every chunk, since the cost of a step does not depend on the control values);
* their ratio (target >= 0.7);
* ``naive``: a Python loop over runs, each its own ``mujoco.MjData`` stepped by ``mj_step``, with
  the same navigation, phase-plane controller, valve limits and duty profile called on one-row
  arrays every cycle (the obvious "one run at a time" implementation).  It is timed on
  ``--naive-runs`` runs (default 8): its rate per run does not depend on how many runs follow.

The physics step and integrator are the packaged model's defaults unless ``--timestep`` /
``--integrator`` say otherwise.  ``--profile`` also runs the
closed loop under cProfile and prints the top functions by cumulative and internal time.

Usage: ``python benchmarks/maneuver.py [--runs 256] [--threads 2] [--timestep S] [--profile]``.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
from mujoco.batch import Batch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.lookup.phase_plane import PhasePlaneController, PhasePlaneParams  # noqa: E402
from rcsim.spacecraft.flight_model import flight_model, jet_wrench_B  # noqa: E402
from rcsim.spacecraft.mujoco_timers import quiet_stage_timers  # noqa: E402
from rcsim.spacecraft.navigation import Guidance, navigate  # noqa: E402
from rcsim.spacecraft.propulsion import (  # noqa: E402
    PropulsionState,
    apply_valve_limits,
    duty_profile,
)
from rcsim.spacecraft.simulation import simulate_batch  # noqa: E402
from rcsim.spacecraft.vehicle import Vehicle  # noqa: E402
from rcsim.spacecraft.vehicle.model import jet_actuator_ids  # noqa: E402

# The raw ceiling steps MuJoCo as the closed loop does: stage timers on the zero clock.
quiet_stage_timers()

DURATION_S = 60.0
ATT_CMD_DEG = (5.0, 5.0, 5.0)
CHUNK_S = 6.0  # raw rollout length per call [s of simulated time]


def closed_loop(vehicle: Vehicle, controller, n_runs: int, nthread: int):
    guidance = Guidance.attitude(np.radians(np.tile(ATT_CMD_DEG, (n_runs, 1))))
    params = vehicle.nominal(n_runs)
    t0 = time.perf_counter()
    hist = simulate_batch(
        params, controller, guidance, DURATION_S, vehicle=vehicle, nthread=nthread
    )
    return time.perf_counter() - t0, hist


def raw(vehicle: Vehicle, hist, n_runs: int, nthread: int) -> float:
    model = vehicle.model
    dt = float(model.opt.timestep)
    n_sub = int(round(0.04 / dt))
    n_total = int(round(DURATION_S / dt))
    chunk = min(n_total, int(round(CHUNK_S / dt)))
    # Duties of the closed loop's first chunk, per run, as the flight model's wrench controls
    # (n_runs, chunk, 6): the steps the closed loop's MuJoCo takes
    # (rcsim/spacecraft/flight_model.py).
    n_cyc = chunk // n_sub
    duty = duty_profile(hist.on_time_s[:, :n_cyc].reshape(-1, 16), dt, n_sub)
    wrench = jet_wrench_B(vehicle.nominal(n_runs), model)
    control = np.einsum("nwj,nsj->nsw", wrench, duty.reshape(n_runs, n_cyc * n_sub, 16))
    spec = int(mujoco.mjtState.mjSTATE_CTRL)
    b = Batch(flight_model(model), n_runs, nthread)
    b.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
    b.forward()
    t0 = time.perf_counter()
    done = 0
    while done < n_total:
        k = min(chunk, n_total - done)
        b.rollout(k, control=control[:, :k], control_spec=spec, record=())
        done += k
    return time.perf_counter() - t0


def naive(vehicle: Vehicle, controller, n_runs: int) -> float:
    """One run at a time: MjData + mj_step, controller on one-row arrays."""
    model = vehicle.model
    dt = float(model.opt.timestep)
    prop_params = vehicle.propulsion()
    n_sub = int(round(prop_params.cycle_s / dt))
    n_cycles = int(np.ceil(DURATION_S / prop_params.cycle_s - 1e-9))
    jets = jet_actuator_ids(model)
    thrust = vehicle.nominal(1).thrust_n
    guidance = Guidance.attitude(np.radians([ATT_CMD_DEG]))
    t0 = time.perf_counter()
    for _ in range(n_runs):
        d = mujoco.MjData(model)
        mujoco.mj_forward(model, d)
        state = controller.initial_state(1)
        prop = PropulsionState.zeros(1, len(jets))
        for k in range(n_cycles):
            nav = navigate(
                k * prop_params.cycle_s,
                d.qpos[None, 3:7].copy(),
                d.qvel[None, 3:6].copy(),
                guidance,
            )
            command, state = controller.step(nav, state)
            on = apply_valve_limits(command, prop, prop_params, thrust)
            duty = duty_profile(on, dt, n_sub)[0]
            for s in range(n_sub):
                d.ctrl[jets] = duty[s]
                mujoco.mj_step(model, d)
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2, help="MuJoCo threads (default 2)")
    ap.add_argument("--naive-runs", type=int, default=8)
    ap.add_argument("--timestep", type=float, help="physics step [s] (default: the model's)")
    ap.add_argument("--integrator", help="MuJoCo integrator (default: the model's)")
    ap.add_argument("--profile", action="store_true", help="cProfile the closed loop too")
    args = ap.parse_args(argv)

    vehicle = Vehicle.load().with_physics(timestep_s=args.timestep, integrator=args.integrator)
    model = vehicle.model
    controller = PhasePlaneController(PhasePlaneParams.for_vehicle(vehicle))
    dt = float(model.opt.timestep)
    integ = mujoco.mjtIntegrator(model.opt.integrator).name
    print(
        f"model: {integ}, step {dt * 1e3:g} ms; {args.runs} runs x {DURATION_S:g} s of the "
        f"{ATT_CMD_DEG} deg phase-plane maneuver; {args.threads} MuJoCo threads"
    )

    closed_loop(vehicle, controller, min(args.runs, 8), args.threads)  # warm-up (imports, pools)
    t_closed, hist = closed_loop(vehicle, controller, args.runs, args.threads)
    assert not hist.failed.any(), hist.reason
    t_raw = raw(vehicle, hist, args.runs, args.threads)
    t_naive = naive(vehicle, controller, args.naive_runs)

    sim_s = args.runs * DURATION_S
    closed_rate, raw_rate = sim_s / t_closed, sim_s / t_raw
    naive_rate = args.naive_runs * DURATION_S / t_naive
    print(f"closed loop : {closed_rate:9.0f} sim-s per wall-s  ({t_closed:.2f} s wall)")
    print(f"raw stepping: {raw_rate:9.0f} sim-s per wall-s  ({t_raw:.2f} s wall)")
    print(f"ratio       : {closed_rate / raw_rate:9.2f}  (target >= 0.7)")
    print(
        f"naive loop  : {naive_rate:9.0f} sim-s per wall-s  ({args.naive_runs} runs one at a "
        f"time, MjData + mj_step, {t_naive:.2f} s wall)"
    )
    print(f"closed loop / naive: {closed_rate / naive_rate:.1f}x")

    if args.profile:
        prof = cProfile.Profile()
        prof.enable()
        closed_loop(vehicle, controller, args.runs, args.threads)
        prof.disable()
        for key in ("cumulative", "tottime"):
            out = io.StringIO()
            pstats.Stats(prof, stream=out).sort_stats(key).print_stats(18)
            print(out.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main())
