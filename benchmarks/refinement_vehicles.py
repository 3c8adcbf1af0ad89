"""The analyst's loop on several vehicles: is the refined table robust on each?

For each vehicle, ``rcsim loop --vehicle V --table generate --runs-per-case N --out DIR``
(a table generated for the vehicle, refined on the search seed, checked on the held-out seed),
then from the loop's own files:

* the generated table's nominal errors (``generated_table_settling.csv``: each case's error
  after its row's firing on the nominal vehicle, the cases that miss the target and why);
* held-out failures with the original and the refined table on the same runs
  (``campaign_check`` and ``campaign_after``), with exact (Clopper-Pearson) 95 % intervals;
* the cases significantly worse (the loop's per-case McNemar check, ``loop.json``);
* propellant per run, original and refined, on the held-out runs.

Usage::

    python benchmarks/refinement_vehicles.py --runs-per-case 100 [--json OUT.json]
    python benchmarks/refinement_vehicles.py --vehicles canted16 --runs-per-case 2   # smoke

Default vehicles: canted16, canted12, docs/examples/service16.toml and two of rcsim's own
designs in tests/lookup/vehicles/ (smallsat150: 150 kg, 0.5 N, 20 ms minimum on-time;
lander900: 900 kg, 2 N, 30 ms).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
VEHICLES = [
    "canted16",
    "canted12",
    str(ROOT / "docs/examples/service16.toml"),
    str(ROOT / "tests/lookup/vehicles/smallsat150.toml"),
    str(ROOT / "tests/lookup/vehicles/lander900.toml"),
]


def _interval(k: int, n: int) -> str:
    from rcsim.analysis.results.proportions import clopper_pearson

    lo, hi = clopper_pearson(k, n)
    return (
        f"{k} of {n} ({100 * k / n:.1f} %, 95 % CI {100 * float(lo):.1f}-{100 * float(hi):.1f} %)"
    )


def one(vehicle: str, runs: int, out: Path) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "rcsim", "loop", "--vehicle", vehicle, "--table", "generate",
         "--runs-per-case", str(runs), "--no-plots", "--out", str(out)],
        capture_output=True, text=True,
    )  # fmt: skip
    if proc.returncode != 0:
        raise SystemExit(f"rcsim loop --vehicle {vehicle} failed:\n{proc.stderr}")
    state = json.loads((out / "loop.json").read_text())
    settle = pd.read_csv(out / "generated_table_settling.csv")
    before = pd.read_parquet(out / "campaign_check" / "runs.parquet")
    after = pd.read_parquet(out / "campaign_after" / "runs.parquet")
    assert before["run_id"].tolist() == after["run_id"].tolist()  # the same held-out runs
    missed = settle.loc[~settle["nominal_met"].astype(bool)]
    reasons = sorted({str(r).split(":")[0] for r in missed.get("unmet_reason", []) if r == r})
    n = len(before)
    fb, fa = int(before["failed"].sum()), int(after["failed"].sum())
    return {
        "vehicle": Path(vehicle).stem,
        "loop_s": round(time.perf_counter() - t0, 1),
        "nominal_worst_err_deg_s": float(settle["nominal_err_deg_s"].max()),
        "nominal_target_deg_s": float(settle["nominal_target_deg_s"].iloc[0]),
        "nominal_met": int(settle["nominal_met"].astype(bool).sum()),
        "nominal_missed_cases": missed["case"].astype(int).tolist(),
        "nominal_missed_reasons": reasons,
        "cells_changed": state["done"]["refine"].get("cases_changed"),
        "held_out_seed": state["done"]["check"]["held_out_seed"],
        "held_out_runs": n,
        "failed_original": fb,
        "failed_refined": fa,
        "failed_original_text": _interval(fb, n),
        "failed_refined_text": _interval(fa, n),
        "regressions": state["done"]["check"]["regressions"],
        "propellant_original_kg": float(before["propellant_kg"].mean()),
        "propellant_refined_kg": float(after["propellant_kg"].mean()),
    }


def main(argv=None) -> list:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=100)
    ap.add_argument("--vehicles", help="comma-separated names or files (default: the five)")
    ap.add_argument("--json", type=Path, help="also write the rows here")
    args = ap.parse_args(argv)
    vehicles = args.vehicles.split(",") if args.vehicles else VEHICLES
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, v in enumerate(vehicles):
            row = one(v, args.runs_per_case, Path(tmp) / f"loop{i}")
            rows.append(row)
            print(json.dumps(row), flush=True)
    print()
    print(
        "| vehicle | nominal: cases within target (worst error) | held-out failed, original | "
        "refined | cases worse | propellant per run, original -> refined |"
    )
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['vehicle']} | {r['nominal_met']}/26 ({r['nominal_worst_err_deg_s']:.4f} deg/s; "
            f"target {r['nominal_target_deg_s']:.3f}) | {r['failed_original_text']} | "
            f"{r['failed_refined_text']} | {r['regressions']} | "
            f"{1000 * r['propellant_original_kg']:.2f} -> "
            f"{1000 * r['propellant_refined_kg']:.2f} g |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return rows


if __name__ == "__main__":
    main()
