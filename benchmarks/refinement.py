"""Refinement speed and where the time goes (issue 10; figures go to docs/refinement.md).

Refines the paper's Table 6 over all 26 rate cases (Table 5 dispersions, 20 s runs, the
campaign failure threshold) and reports, per phase, the runs flown, the wall time and the
simulated seconds per wall second:

* ``baseline``: the table as it is, on the search seed;
* ``round k candidates`` / ``round k re-fly``: the candidate entries of the non-robust cases,
  then the table with the accepted changes;
* ``fresh seed``: the old and the refined table on the held-out seed.

Target (issue 10): 26 cases at 200 runs per case in at most 5 minutes on 2 cores.

Usage::

    python benchmarks/refinement.py                    # 200 runs per case
    python benchmarks/refinement.py --runs-per-case 1000 --json out.json

Timings are wall-clock: run it on an idle machine for numbers to quote.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from rcsim.analysis.apps.refinement import evaluate as evaluate_module
from rcsim.analysis.apps.refinement import outputs, search
from rcsim.models.tables import load_lookup_table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--fresh-seed", type=int, default=2)
    ap.add_argument("--table", default="table6")
    ap.add_argument("--json", help="also write the figures to this JSON file")
    args = ap.parse_args()

    phases = []
    original = evaluate_module.evaluate

    def timed(spec, table, trials, **kw):
        t0 = time.perf_counter()
        runs = original(spec, table, trials, **kw)
        wall = time.perf_counter() - t0
        sim = len(runs) * spec.cases[0].duration_s
        phases.append(
            {
                "phase": kw.get("desc", "?").replace("refine: ", ""),
                "runs": len(runs),
                "wall_s": round(wall, 2),
                "sim_s_per_s": round(sim / wall),
            }
        )
        print(
            f"{phases[-1]['phase']:<28} {len(runs):7d} runs {wall:8.1f} s "
            f"{sim / wall:8.0f} sim-s/s",
            flush=True,
        )
        return runs

    # Time every batched evaluation without changing what is flown.
    search.evaluate = outputs.evaluate = timed
    t0 = time.perf_counter()
    ref = outputs.run_refinement(
        load_lookup_table(args.table),
        runs_per_case=args.runs_per_case,
        seed=args.seed,
        fresh_seed=args.fresh_seed,
        progress=False,
    )
    total = time.perf_counter() - t0
    log = ref.changelog
    summary = {
        "runs_per_case": args.runs_per_case,
        "total_wall_s": round(total, 1),
        "runs_flown": int(sum(p["runs"] for p in phases)),
        "cases_changed": int(log["changed"].sum()),
        "changed": [
            f"case {int(r.case)}: "
            + ", ".join(
                f"{a} {getattr(r, f'{a}_old_s'):.2f}->{getattr(r, f'{a}_new_s'):.2f}"
                for a in ("roll", "pitch", "yaw")
                if getattr(r, f"{a}_change_cycles")
            )
            for r in log[log["changed"]].itertuples()
        ],
        **{
            c: int(log[c].sum())
            for c in log.columns
            if c.startswith(("failed_", "repeated_")) and "_ci_" not in c
        },
        "phases": phases,
    }
    print(
        f"total {total:.1f} s for {summary['runs_flown']} runs; "
        f"{summary['cases_changed']} cases changed"
    )
    for key in ("failed", "repeated"):
        print(
            f"{key}: search seed {summary[f'{key}_search_before']} -> "
            f"{summary[f'{key}_search_after']}, fresh seed {summary[f'{key}_fresh_before']}"
            f" -> {summary[f'{key}_fresh_after']}"
        )
    print("\n".join(summary["changed"]))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(summary, fh, indent=2, default=lambda v: np.asarray(v).tolist())


if __name__ == "__main__":
    main()
