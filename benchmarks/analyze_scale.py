"""`rcsim analyze` at 10^4, 10^5 and 10^6 runs: wall time and peak memory (issues 17 and 31).

Two shapes of input, each analysed by the real command in a subprocess whose own peak resident
memory is read from ``os.wait4`` (what ``/usr/bin/time -v`` calls "Maximum resident set size"):

``campaign``
    A campaign directory as ``rcsim campaign run`` writes it (``manifest.json`` and a
    ``runs.parquet`` of the whole runs-table schema, 16 jets, the 26 rate cases; one row group
    per block of :data:`BLOCK_RUNS` runs, as the campaign's chunks make them), whose inputs are
    the Table 5 dispersions drawn by the simulator's own code (``draw_runs``, one seed stream
    per run) and whose outcomes are planted: in the cases that command a yaw rate, a run fails
    when the yaw authority of its firing group is high (over-rotation with fixed firing times),
    ``z + 0.3 e > 1.8``.  The analysis derives the physics-aware factors (86 inputs), the
    per-axis outcomes and the mechanism text from it, as from a real campaign.  Issue 31's
    10^6-run measurement (21 min, 4.5 GB; a traceback in ``vehicles_from_runs`` under a 4 GiB
    limit) was of a table with these recorded vehicle inputs.
``synthetic``
    A runs table (``planted_campaign``, the one-sided scenario) with 60 inputs and 26 cases and
    nothing else: the analysis alone, no factors (issue 17's benchmark).

The issue's target: 10^6 runs within 4 GB and 5 minutes on 2 cores.  The machine is shared:
the load average before and after each measurement is printed beside it.

Usage::

    python benchmarks/analyze_scale.py                        # both shapes, 1e4 1e5 1e6
    python benchmarks/analyze_scale.py --shape campaign --runs 1000000 --keep DIR
    python benchmarks/analyze_scale.py --shape campaign --runs 1000000 --keep DIR --table-only

``--keep DIR`` keeps (and reuses) the generated inputs in DIR; ``--table-only`` writes them
and stops (to time the command by hand, e.g. under ``/usr/bin/time -v``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: Runs drawn and written at a time by the campaign-shaped generator (one Parquet row group).
BLOCK_RUNS = 8_192
#: Cases of the campaign shape: the 26 rate cases of Table 3.
N_CASES = 26
#: The planted campaign's failure threshold [deg/s] (the spec's failure.rate_error_deg_s).
THRESHOLD_DEG_S = 0.04
#: The planted runs' duration [s] (the spec's scenario.duration_s).
DURATION_S = 20.0


def synthetic_table(n_runs: int, n_inputs: int, path: Path) -> Path:
    """Issue 17's table: ``n_runs`` rows of ``n_inputs`` planted inputs, 26 cases."""
    import numpy as np

    from rcsim.analysis.results.drivers.synthetic import planted_campaign

    X, failed = planted_campaign("one-sided", seed=1, n_runs=n_runs, n_noise=n_inputs - 2)
    X.insert(0, "run_id", np.arange(n_runs))
    X["case"] = [f"rate-{c % N_CASES + 1:02d}" for c in range(n_runs)]
    X["failed"] = failed
    X.to_parquet(path)
    return path


def _planted_outcomes(frame, case_names, rng, nominal: float, spread: float):
    """Outcome columns of one block, planted: fail on yaw over-authority.  Every column of the
    schema is filled and the frame is built by the schema's own ``outcome_frame``, so an
    outcome added to the runs table fails here (and in the smoke test) at once."""
    import numpy as np

    from rcsim.analysis.engine.runs_table import outcome_frame
    from rcsim.analysis.results.drivers.factors import fire_signs, physics_factors
    from rcsim.spacecraft.vehicle import Vehicle

    signs = fire_signs(case_names)
    auth = physics_factors(frame, Vehicle.load(), signs)["authority_yaw_fire_rad_s2"].to_numpy()
    n = len(frame)
    yaw_cmd = signs[:, 2] != 0
    z = (auth / nominal - 1.0) / spread
    failed = yaw_cmd & (z + 0.3 * rng.standard_normal(n) > 1.8)
    sign = rng.choice([-1.0, 1.0], (n, 3))
    err = 0.004 * rng.standard_normal((n, 3))
    err[:, 2] = np.where(failed, sign[:, 2] * (0.05 + 0.01 * rng.random(n)), err[:, 2])
    axes = ("roll", "pitch", "yaw")
    cols = {f"final_rate_err_{a}_deg_s": err[:, k] for k, a in enumerate(axes)}
    att = 0.05 * rng.standard_normal((n, 3))
    cols.update({f"final_att_err_{a}_deg": att[:, k] for k, a in enumerate(axes)})
    cols["final_att_err_deg"] = np.linalg.norm(att, axis=1)
    fires = rng.integers(1, 4, (n, 3)).astype(float)
    for k, a in enumerate(axes):
        cols[f"firings_to_rate_{a}"] = fires[:, k] + (failed if a == "yaw" else 0)
        cols[f"time_to_rate_{a}_s"] = 0.04 * fires[:, k] * (1 + 0.1 * rng.random(n))
        cols[f"firings_{a}"] = fires[:, k] + 1
    cols["firings_total"] = 2 * (fires.sum(axis=1) + 3)
    on = 0.08 * rng.random((n, 16))
    jet_kg = on * 22.24 / (280.0 * 9.80665)  # impulse / (Isp g0), Table 1 thrust and Isp
    cols.update({f"jet_{j + 1:02d}_on_time_s": on[:, j] for j in range(16)})
    cols["propellant_kg"] = jet_kg.sum(axis=1)
    cols["rate_settled_time_s"] = np.where(failed, np.nan, 2.0 + rng.random(n))
    cols["sim_failed"] = np.zeros(n, bool)
    cols["failed"] = failed
    cols["reason"] = np.where(failed, "yaw rate error", "")
    dv = 1e-4 * rng.standard_normal((n, 2, 3))  # translation left by imperfect pairs [m/s]
    for f, frame_name in enumerate("NB"):
        for k, a in enumerate("xyz"):
            cols[f"delta_v_{a}_{frame_name}_m_s"] = dv[:, f, k]
        cols[f"delta_v_{frame_name}_m_s"] = np.linalg.norm(dv[:, f], axis=1)
    cols["pulses"] = cols["firings_total"]
    cols["min_pulses"] = np.zeros(n)
    cols["pulses_per_min"] = cols["pulses"] / (DURATION_S / 60.0)
    cols.update({f"jet_{j + 1:02d}_propellant_kg": jet_kg[:, j] for j in range(16)})
    cols.update({f"jet_{j + 1:02d}_duty": on[:, j] / DURATION_S for j in range(16)})
    cols["failed_by"] = np.where(failed, "rate", "")
    worst = np.abs(err).max(axis=1)
    margin = (THRESHOLD_DEG_S - worst) / THRESHOLD_DEG_S
    cols["margin"] = np.where(failed, np.minimum(margin, -np.finfo(float).tiny), margin)
    return outcome_frame(cols, n_jets=16).set_axis(frame.index)


def campaign_dir(n_runs: int, folder: Path, seed: int = 7) -> Path:
    """A campaign directory of ``N_CASES x ceil(n_runs / N_CASES)`` runs (module docstring)."""
    import numpy as np
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    from rcsim.analysis.engine.runs_table import check_run_frame, input_frame
    from rcsim.analysis.results.drivers.factors import fire_signs, physics_factors
    from rcsim.models.tables import load_dispersions
    from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs
    from rcsim.spacecraft.vehicle import Vehicle

    per_case = -(-n_runs // N_CASES)
    total = per_case * N_CASES
    folder.mkdir(parents=True, exist_ok=True)
    paper = Vehicle.load()  # the campaign's (its manifest names none: the paper's)
    nominal = paper.nominal(1)
    sigmas = DispersionSigmas.from_table(load_dispersions(), scale=1.0)
    # The nominal yaw authority of each firing direction, and the spread of its ratio on the
    # first block: the planted threshold's scale (fixed for the whole campaign).
    straight = input_frame(
        draw_runs(nominal, DispersionSigmas.from_table(load_dispersions(), 0.0), 0, [0])
    )
    yaw_nom = physics_factors(straight, paper, fire_signs(["rate-01"]))["authority_yaw_fire_rad_s2"]
    nominal_yaw = float(yaw_nom.iloc[0])
    names = [f"rate-{c + 1:02d}" for c in range(N_CASES)]
    writer = None
    spread = None
    try:
        for b, start in enumerate(range(0, total, BLOCK_RUNS)):
            ids = np.arange(start, min(start + BLOCK_RUNS, total))
            frame = input_frame(draw_runs(nominal, sigmas, seed, ids))
            index = ids // per_case
            case = np.asarray(names, dtype=object)[index]
            if spread is None:
                auth = physics_factors(frame, paper, fire_signs(case))["authority_yaw_fire_rad_s2"]
                spread = float(np.std(auth.to_numpy() / nominal_yaw))
            rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(b,)))
            runs = pd.concat(
                [
                    pd.DataFrame({"run_id": ids, "case": case, "case_index": index, "seed": seed}),
                    frame,
                    _planted_outcomes(frame, case, rng, nominal_yaw, spread),
                ],
                axis=1,
            )
            runs = check_run_frame(runs, n_jets=16)
            table = pa.Table.from_pandas(runs, preserve_index=False)
            if writer is None:
                writer = pq.ParquetWriter(folder / "runs.parquet", table.schema)
            writer.write_table(table)
    finally:
        if writer is not None:
            writer.close()
    manifest = {
        "format": "rcsim-campaign/1",
        "spec": {
            "seed": seed,
            "runs_per_case": per_case,
            "scenario": {"kind": "rate-cases", "mode": "command", "duration_s": DURATION_S},
            "controller": {"name": "lookup", "table": "table6"},
            "dispersions": {"table": "default", "scale": 1.0},
        },
        "thresholds": {"rate_error_deg_s": THRESHOLD_DEG_S, "attitude_error_deg": None},
        "counts": {"runs": total},
        "note": "planted outcomes (benchmarks/analyze_scale.py), not a flight",
    }
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=1))
    return folder


def inputs_for(shape: str, n_runs: int, n_inputs: int, folder: Path) -> Path:
    """The generated input of ``shape`` at ``n_runs`` runs (reused when already in ``folder``)."""
    if shape == "campaign":
        path = folder / f"campaign-{n_runs}"
        if not (path / "manifest.json").is_file():
            campaign_dir(n_runs, path)
        return path
    path = folder / f"runs-{n_runs}-{n_inputs}.parquet"
    if not path.is_file():
        synthetic_table(n_runs, n_inputs, path)
    return path


def measure(data: Path, out: Path) -> dict:
    """Run ``rcsim analyze data --out out``: wall time, the command's own peak RSS, exit."""
    load_before = os.getloadavg()[0]
    log_out, log_err = out.with_suffix(".stdout"), out.with_suffix(".stderr")
    t0 = time.perf_counter()
    with open(log_out, "w") as fo, open(log_err, "w") as fe:
        proc = subprocess.Popen(
            [sys.executable, "-m", "rcsim", "analyze", str(data), "--out", str(out), "--overwrite"],
            stdout=fo,
            stderr=fe,
        )
        # wait4, not proc.wait: the rusage of this child alone (ru_maxrss, kB on Linux).
        _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    stdout, stderr = log_out.read_text(), log_err.read_text()
    return {
        "wall_s": round(wall, 1),
        "peak_rss_mb": round(usage.ru_maxrss / 1024),
        "exit": proc.returncode,
        "load_before": round(load_before, 2),
        "load_after": round(os.getloadavg()[0], 2),
        "last_line": (stderr.strip() or stdout.strip()).splitlines()[-1:],
        "notes": [line for line in stdout.splitlines() if line.startswith("note: analysed")],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument(
        "--shape", choices=("campaign", "synthetic"), nargs="+", default=["campaign", "synthetic"]
    )
    ap.add_argument("--inputs", type=int, default=60, help="inputs of the synthetic shape")
    ap.add_argument("--keep", type=Path, help="keep (and reuse) the generated inputs here")
    ap.add_argument("--table-only", action="store_true", help="write the inputs and stop")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="rcsim-analyze-bench-") as tmp:
        folder = args.keep or Path(tmp)
        for shape in args.shape:
            for n in sorted(args.runs):
                t0 = time.perf_counter()
                data = inputs_for(shape, n, args.inputs, folder)
                made = time.perf_counter() - t0
                if args.table_only:
                    print({"shape": shape, "runs": n, "input": str(data), "made_s": round(made, 1)})
                    continue
                row = {"shape": shape, "runs": n, "cpus": os.cpu_count()}
                row.update(measure(data, Path(tmp) / f"out-{shape}-{n}"))
                print(row, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
