"""Campaign throughput and memory benchmark (issue 4; figures go to docs/performance.md).

Measures, on this machine, in one process run:

1. ``campaign``: a summary-only campaign of the 26 rate cases x N runs (lookup controller,
   Table 5 dispersions) in local mode -- simulated seconds and runs per second of flying
   (``report.fly_s``; ``wall_s`` adds start-up, assembly and plots);
2. ``raw``: batched MuJoCo stepping of *the same steps* (same batch sizes, same physics step
   and integrator, open loop, no controller, no outcomes, no I/O) -- the ceiling the campaign is
   compared with (issue 19's target: campaign >= 0.8 x raw).  Two ceilings: vehicles at rest
   (the only one before issue 19's third round), and vehicles spinning at their case's
   commanded rate, the state the campaign's vehicles fly in: MuJoCo steps a body at rest 7-9 %
   faster than a spinning one (zero rates short-cut work in its step), so the ceiling at rest
   overstates what the campaign's steps cost.  Beside them, the floor of any closed loop
   through MuJoCo's batch API: the spinning steps in one call per control cycle (every run's
   state loaded into MuJoCo and saved back each cycle) with nothing between the calls
   (``per_cycle_calls``; issue 19's sixth round);
3. ``single-core``: one 256-run chunk against a raw rollout of its steps on one core (the
   closed loop's own efficiency, least disturbed by other load);
4. ``local modes``: the campaign with one chunk at a time in this process on MuJoCo's thread
   pool (``local_workers=1``) versus one chunk in flight per CPU, each in a worker process (the
   default);
5. ``dask``: the same campaign on a LocalCluster of 1 and 2 workers (target: 2 >= 1.7 x 1);
6. ``memory``: peak RSS of ``rcsim campaign run`` for a large summary-only campaign of short
   runs, at two sizes (target: < 1 GB at 100,000 runs, and no growth with the run count);
7. ``interrupt``: seconds from Ctrl-C (SIGINT to the process group, as a terminal sends it)
   to the exit of ``rcsim campaign run``, sent once its first chunk has committed, locally
   and with ``--workers 2`` (the chunks in flight must be abandoned, not finished).

Usage::

    python benchmarks/campaign.py                      # everything, default sizes
    python benchmarks/campaign.py --runs-per-case 20 --duration-s 20 --skip memory
    python benchmarks/campaign.py --only memory --memory-runs 100000
    python benchmarks/campaign.py --only interrupt --interrupt-repeats 5

Timings are wall-clock on a shared machine: run it on an idle one for numbers to quote.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.spacecraft.mujoco_timers import quiet_stage_timers  # noqa: E402

# The raw ceilings step MuJoCo as the campaign does: stage timers on the zero clock.
quiet_stage_timers()

SPEC = """
seed = 1
runs_per_case = {runs}
chunk_size = {chunk}
[scenario]
cases = "all"
duration_s = {duration}
[controller]
name = "{controller}"
[output]
histories = "none"
plots = {plots}
"""


def _spec_file(folder: Path, *, runs, chunk, duration, controller="lookup", plots=False) -> Path:
    path = folder / f"spec-{runs}-{chunk}-{duration}-{controller}.toml"
    path.write_text(
        SPEC.format(
            runs=runs,
            chunk=chunk,
            duration=duration,
            controller=controller,
            plots=str(plots).lower(),
        )
    )
    return path


def bench_campaign(folder: Path, spec_path: Path, name: str, **kw) -> dict:
    from rcsim.analysis.engine.campaign.runner import run_campaign
    from rcsim.analysis.engine.campaign.spec import load_spec

    spec = load_spec(spec_path)
    report = run_campaign(spec, folder / name, progress=False, **kw)
    return {
        "runs": report.runs_flown,
        "wall_s": report.wall_s,
        "fly_s": report.fly_s,
        # runs/s over the flying alone (start-up, assembly and plots are in wall_s).
        "runs_per_s": report.runs_flown / report.fly_s,
        "sim_s_per_s": report.simulated_s / report.fly_s,
    }


def bench_raw(spec_path: Path) -> dict:
    """Open-loop batched MuJoCo rollouts over the campaign's chunks (same runs, same steps).

    Two schedules, the better one is the ceiling: chunks one after another on MuJoCo's own
    thread pool (``nthread=0``), and the campaign's local schedule (``cpus`` chunks in flight
    on a thread pool, one MuJoCo thread each).  The closed-loop floor (``per_cycle_calls``)
    steps the spinning vehicles on the campaign's schedule in one call per control cycle.
    """
    from concurrent.futures import ThreadPoolExecutor

    import mujoco
    import numpy as np
    from mujoco.batch import Batch

    from rcsim.analysis.engine.campaign.chunk import plan_chunks
    from rcsim.analysis.engine.campaign.spec import load_spec

    spec = load_spec(spec_path)
    cycle = spec.vehicle.control.cycle_s
    chunks = plan_chunks(spec)

    def roll(chunk, nthread, spinning, per_cycle=False):
        model = spec.vehicle.flight_model  # the model the campaign's MuJoCo integrates
        n = chunk.stop - chunk.first
        duration = spec.cases[spec.case_of(chunk.first)].duration_s
        n_cycles = int(np.ceil(duration / cycle - 1e-9))
        n_sub = int(round(cycle / model.opt.timestep))
        batch = Batch(model, n, nthread)
        batch.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
        if spinning:
            batch.bind("qvel")[:, 3:6] = _commanded_rates(spec, chunk.first, chunk.stop)
        ctrl_spec = int(mujoco.mjtState.mjSTATE_CTRL)
        if per_cycle:  # one call per control cycle, as any closed loop must make
            control = np.zeros((n, n_sub, model.nu))
            for _ in range(n_cycles):
                batch.rollout(n_sub, control=control, control_spec=ctrl_spec, record=())
        else:
            control = np.zeros((n, n_cycles * n_sub, model.nu))
            batch.rollout(n_cycles * n_sub, control=control, control_spec=ctrl_spec, record=())
        return n * n_cycles * n_sub * model.opt.timestep

    out = {}
    cpus = os.cpu_count() or 1
    threads = max(1, min(cpus, len(chunks)))
    for state, spinning in (("at_rest", False), ("spinning", True)):
        t0 = time.perf_counter()
        simulated = sum(roll(c, 0, spinning) for c in chunks)
        sequential = simulated / (time.perf_counter() - t0)
        t0 = time.perf_counter()
        with ThreadPoolExecutor(threads) as pool:
            simulated = sum(
                pool.map(lambda c: roll(c, max(1, cpus // threads), spinning), chunks)  # noqa: B023
            )
        threaded = simulated / (time.perf_counter() - t0)
        out[f"{state}_sequential_mujoco_pool_sim_s_per_s"] = sequential
        out[f"{state}_threaded_chunks_sim_s_per_s"] = threaded
        out[f"{state}_sim_s_per_s"] = max(sequential, threaded)
    # The floor of any closed loop through this API: the same spinning steps, one call per
    # control cycle (each run's state loaded into MuJoCo and saved back every cycle), with no
    # controller between the calls; the campaign's schedule.
    t0 = time.perf_counter()
    with ThreadPoolExecutor(threads) as pool:
        simulated = sum(
            pool.map(lambda c: roll(c, max(1, cpus // threads), True, per_cycle=True), chunks)
        )
    out["per_cycle_calls_sim_s_per_s"] = simulated / (time.perf_counter() - t0)
    out["sim_s_per_s"] = out["spinning_sim_s_per_s"]
    return out


def _commanded_rates(spec, first: int, stop: int):
    """(stop - first, 3): each run's case's commanded body rate [rad/s]."""
    import numpy as np

    return np.array([spec.cases[spec.case_of(i)].rate_cmd_rad_s for i in range(first, stop)])


def bench_single_core(spec_path: Path, n: int = 256, repeats: int = 3) -> dict:
    """One chunk of ``n`` runs on one core: the closed-loop chunk (draws, controller, outcomes)
    against a raw open-loop rollout of the same steps, interleaved, best of ``repeats``.  Less
    sensitive to other load on the machine than the parallel figures."""
    import mujoco
    import numpy as np
    from mujoco.batch import Batch

    from rcsim.analysis.engine.campaign.chunk import Chunk, simulate_chunk, warm_up
    from rcsim.analysis.engine.campaign.spec import load_spec

    spec = load_spec(spec_path)
    warm_up()
    n = min(n, spec.n_runs)
    duration = spec.cases[0].duration_s
    model = spec.vehicle.flight_model  # the model the campaign's MuJoCo integrates
    nstep = int(round(duration / model.opt.timestep))
    best_chunk, best_raw, best_same = float("inf"), float("inf"), float("inf")
    best_spinning = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate_chunk(spec, Chunk(0, n), nthread=1)
        best_chunk = min(best_chunk, time.perf_counter() - t0)
        best_same = min(best_same, _replay_same_steps(spec, n))
        for spinning in (False, True):
            batch = Batch(model, n, 1)
            batch.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
            if spinning:
                batch.bind("qvel")[:, 3:6] = _commanded_rates(spec, 0, n)
            control = np.zeros((n, nstep, model.nu))
            t0 = time.perf_counter()
            batch.rollout(
                nstep, control=control, control_spec=int(mujoco.mjtState.mjSTATE_CTRL), record=()
            )
            took = time.perf_counter() - t0
            if spinning:
                best_spinning = min(best_spinning, took)
            else:
                best_raw = min(best_raw, took)
    return {
        "runs": n,
        "chunk_sim_s_per_s": n * duration / best_chunk,
        "raw_sim_s_per_s": n * duration / best_raw,
        "ratio": best_raw / best_chunk,
        "raw_spinning_sim_s_per_s": n * duration / best_spinning,
        "ratio_spinning": best_spinning / best_chunk,
        "raw_same_steps_sim_s_per_s": n * duration / best_same,
        "ratio_same_steps": best_same / best_chunk,
    }


def _replay_same_steps(spec, n: int) -> float:
    """Seconds MuJoCo alone takes for the closed loop's own steps, pieces included.

    The closed loop integrates a cycle in which a jet switches in pieces cut at each run's
    switch instants (exact in time, ``rcsim/spacecraft/pieces.py``), so it steps more often than a
    fixed-step rollout.  This records every ``rollout`` call of one closed-loop chunk (steps,
    controls, runs, per-run step lengths) and replays them, open loop, on a fresh batch: the
    ceiling for *this* physics, against which the controller's own overhead is measured.
    """
    import mujoco
    import numpy as np
    from mujoco.batch import Batch

    from rcsim.analysis.engine.campaign.chunk import Chunk, simulate_chunk
    from rcsim.spacecraft.batch_physics import BatchPhysics

    calls = []
    original = BatchPhysics._rollout

    def record(self, nstep, control, runs, failed, reason):
        ids = np.flatnonzero(runs)
        calls.append((nstep, control[ids].copy(), ids, self._timestep[ids].copy()))
        return original(self, nstep, control, runs, failed, reason)

    BatchPhysics._rollout = record
    try:
        simulate_chunk(spec, Chunk(0, n), nthread=1)
    finally:
        BatchPhysics._rollout = original
    batch = Batch(spec.vehicle.flight_model, n, 1)
    batch.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
    timestep = batch.expand("opt.timestep")
    ctrl_spec = int(mujoco.mjtState.mjSTATE_CTRL)
    t0 = time.perf_counter()
    for nstep, control, ids, dt in calls:
        timestep[ids] = dt
        everyone = ids.size == n
        batch.rollout(
            nstep,
            control=control,
            control_spec=ctrl_spec,
            record=(),
            ids=None if everyone else ids,
        )
    return time.perf_counter() - t0


def bench_memory(folder: Path, runs_total: int, duration: float, chunk: int) -> dict:
    """Peak RSS of a separate ``rcsim campaign run`` process (summary-only, short runs)."""
    runs = max(1, round(runs_total / 26))
    spec = _spec_file(
        folder, runs=runs, chunk=chunk, duration=duration, controller="lookup", plots=True
    )
    out = folder / f"mem-{runs_total}"
    code = (
        "import resource, sys; from rcsim.analysis.apps.cli import main; rc = main(sys.argv[1:]); "
        "print('MAXRSS_KB', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); sys.exit(rc)"
    )
    t0 = time.perf_counter()
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            code,
            "campaign",
            "run",
            str(spec),
            "--out",
            str(out),
            "--no-progress",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr)
    rss_kb = int(proc.stdout.split("MAXRSS_KB")[1].split()[0])
    return {
        "runs": runs * 26,
        "duration_s": duration,
        "wall_s": wall,
        "peak_rss_mb": rss_kb / 1024,
        "runs_per_s": runs * 26 / wall,
    }


def bench_interrupt(
    folder: Path,
    extra: list[str],
    repeats: int,
    *,
    runs: int = 8,
    chunk: int = 50,
    duration: float = 20.0,
) -> dict:
    """Seconds from Ctrl-C to the exit of ``rcsim campaign run`` (``extra``: its options).

    The 26 cases x ``runs`` runs of ``duration`` s in ``chunk``-run chunks: many chunks, each
    several seconds of flying, so that chunks are in flight when the signal comes.
    """
    spec = _spec_file(folder, runs=runs, chunk=chunk, duration=duration)
    seconds, codes = [], []
    for k in range(repeats):
        out = folder / f"interrupt-{'-'.join(extra) or 'local'}-{k}"
        cli = [
            sys.executable,
            "-m",
            "rcsim",
            "campaign",
            "run",
            str(spec),
            "--out",
            str(out),
            "--no-progress",
            *extra,
        ]
        proc = subprocess.Popen(
            cli,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
            cwd=ROOT,
        )
        try:
            deadline = time.monotonic() + 300
            while proc.poll() is None and time.monotonic() < deadline:
                if any((out / "chunks").glob("runs-*.parquet")):
                    break
                time.sleep(0.01)
            if proc.poll() is not None:
                raise RuntimeError(f"the campaign ended before the signal: {proc.stderr.read()}")
            t0 = time.perf_counter()
            os.killpg(proc.pid, signal.SIGINT)
            proc.communicate(timeout=120)
            seconds.append(time.perf_counter() - t0)
            codes.append(proc.returncode)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    return {
        "repeats": repeats,
        "exit_codes": sorted(set(codes)),
        "median_s": statistics.median(seconds),
        "max_s": max(seconds),
        "seconds": seconds,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--runs-per-case", type=int, default=40)
    p.add_argument("--duration-s", type=float, default=20.0)
    p.add_argument("--chunk-size", type=int, default=512)
    p.add_argument("--memory-runs", type=int, nargs="+", default=[10_000, 100_000])
    p.add_argument("--memory-duration-s", type=float, default=0.2)
    p.add_argument(
        "--only",
        nargs="+",
        default=None,
        choices=["campaign", "raw", "single-core", "local-modes", "dask", "memory", "interrupt"],
    )
    p.add_argument("--skip", nargs="+", default=[])
    p.add_argument("--interrupt-repeats", type=int, default=3)
    p.add_argument("--json", help="also write the figures to this JSON file")
    args = p.parse_args(argv)
    want = lambda k: (args.only is None or k in args.only) and k not in args.skip  # noqa: E731

    results: dict = {"machine": {"cpus": os.cpu_count(), "load_avg_at_start": os.getloadavg()}}
    with tempfile.TemporaryDirectory(prefix="rcsim-bench-") as tmp:
        folder = Path(tmp)
        spec = _spec_file(
            folder, runs=args.runs_per_case, chunk=args.chunk_size, duration=args.duration_s
        )
        label = f"26 cases x {args.runs_per_case} runs x {args.duration_s:g} s, lookup"
        if want("campaign"):
            results["campaign"] = bench_campaign(folder, spec, "local")
            print(f"campaign ({label}), local: {results['campaign']}", flush=True)
        if want("raw"):
            results["raw"] = bench_raw(spec)
            print(f"raw batched MuJoCo, same steps: {results['raw']}", flush=True)
            if "campaign" in results:
                fly = results["campaign"]["sim_s_per_s"]
                raw = results["raw"]
                ratio = fly / raw["spinning_sim_s_per_s"]
                results["campaign_over_raw"] = ratio
                results["campaign_over_raw_at_rest"] = fly / raw["at_rest_sim_s_per_s"]
                results["per_cycle_calls_over_raw"] = (
                    raw["per_cycle_calls_sim_s_per_s"] / raw["spinning_sim_s_per_s"]
                )
                results["campaign_over_per_cycle_calls"] = fly / raw["per_cycle_calls_sim_s_per_s"]
                print(
                    f"campaign / raw = {ratio:.2f} against vehicles spinning at their commanded "
                    f"rates, {results['campaign_over_raw_at_rest']:.2f} against vehicles at rest "
                    "(target >= 0.8, issue 19); the same steps in one call per cycle and no "
                    f"controller reach {results['per_cycle_calls_over_raw']:.2f} of raw",
                    flush=True,
                )
        if want("single-core"):
            results["single_core"] = bench_single_core(spec)
            print(f"one core, one chunk: {results['single_core']}", flush=True)
        if want("local-modes"):
            results["local_one_chunk_mujoco_pool"] = bench_campaign(
                folder, spec, "pool", local_workers=1
            )
            print(
                f"local, one chunk at a time on MuJoCo's pool: "
                f"{results['local_one_chunk_mujoco_pool']}",
                flush=True,
            )
        if want("dask"):
            for w in (1, 2):
                t0 = time.perf_counter()
                results[f"dask_{w}"] = bench_campaign(folder, spec, f"dask{w}", workers=w)
                results[f"dask_{w}"]["with_cluster_start_s"] = time.perf_counter() - t0
                print(f"dask LocalCluster {w} worker(s): {results[f'dask_{w}']}", flush=True)
            speedup = results["dask_2"]["sim_s_per_s"] / results["dask_1"]["sim_s_per_s"]
            results["dask_speedup_2_over_1"] = speedup
            print(f"dask 2 workers / 1 worker = {speedup:.2f}  (target >= 1.7)", flush=True)
        if want("memory"):
            for n in args.memory_runs:
                key = f"memory_{n}"
                results[key] = bench_memory(folder, n, args.memory_duration_s, 256)
                print(
                    f"summary-only campaign, {results[key]['runs']} runs of "
                    f"{args.memory_duration_s:g} s: {results[key]}",
                    flush=True,
                )
        if want("interrupt"):
            for name, extra in (("local", []), ("dask_2", ["--workers", "2"])):
                key = f"interrupt_{name}"
                results[key] = bench_interrupt(folder, extra, args.interrupt_repeats)
                print(f"Ctrl-C to exit, {name}: {results[key]}", flush=True)
    results["machine"]["load_avg_at_end"] = os.getloadavg()
    print(json.dumps(results, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
