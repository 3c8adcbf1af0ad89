"""The loop's cost against another code version's, interleaved on the same machine.

Runs the default ``rcsim loop`` (the paper's vehicle, Table 6, 100 runs per case, seeds 1 / 2)
with a baseline interpreter (another checkout's virtual environment, e.g. the main branch's)
and with this checkout's, alternately (baseline, ours, baseline, ours, ...), so that both see
the same machine and load; reports each run's wall and stage times, the ratio of the means,
and what each loop changed: the cells against the paper's Table 7 and the failed runs on the
held-out seed with the original and the refined table.

Usage::

    python benchmarks/loop_cost.py --baseline-python OTHER/.venv/bin/python [--rounds 1]

Timings are wall-clock; the 1-minute load average is recorded before every run.
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


def _one(python: str, out: Path, extra: list[str]) -> dict:
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    # Run outside any checkout: `python -m rcsim` imports the package from the working
    # directory first, so each interpreter must find its own installed (editable) copy.
    proc = subprocess.run(
        [python, "-m", "rcsim", "loop", "--out", str(out), *extra],
        cwd=out.parent,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{python}: rcsim loop failed ({proc.returncode}):\n{proc.stderr}")
    state = json.loads((out / "loop.json").read_text())
    return {
        "wall_s": round(wall, 1),
        "load_avg_1min_before": load,
        "stage_s": {k: v["seconds"] for k, v in state["done"].items()},
        **_outcome(out),
    }


def _outcome(out: Path) -> dict:
    """Cells changed against Table 7 and held-out failures, from the loop's files."""
    import pandas as pd

    from rcsim.analysis.apps.refinement.evidence import changed_cells
    from rcsim.models.tables import PAPER_CYCLE_S, load_lookup_table

    t6, t7 = load_lookup_table("table6"), load_lookup_table("table7")
    ours = changed_cells(t6, load_lookup_table(out / "refined_table.csv"), PAPER_CYCLE_S)
    paper = changed_cells(t6, t7, PAPER_CYCLE_S)
    key = ["case", "axis", "old_cycles", "new_cycles"]
    same = ours.merge(paper, on=key)
    log = pd.read_csv(out / "refined_table_changelog.csv")
    return {
        "cells_changed": len(ours),
        "cells_as_table7": len(same),
        "table7_cells": len(paper),
        "held_out_failed_before": int(log["failed_fresh_before"].sum()),
        "held_out_failed_after": int(log["failed_fresh_after"].sum()),
        "held_out_runs": int(log["fresh_runs"].sum()),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline-python", required=True, help="the other code version's python")
    ap.add_argument("--rounds", type=int, default=1, help="baseline/ours pairs (default 1)")
    ap.add_argument("--json", type=Path, help="also write the results here")
    ap.add_argument("loop_args", nargs="*", help="extra `rcsim loop` arguments")
    args = ap.parse_args(argv)
    runs: dict[str, list] = {"baseline": [], "ours": []}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for name, python in (("baseline", args.baseline_python), ("ours", sys.executable)):
                res = _one(python, Path(tmp) / f"{name}-{r}", args.loop_args)
                runs[name].append(res)
                print(name, json.dumps(res), flush=True)
    mean = {k: sum(x["wall_s"] for x in v) / len(v) for k, v in runs.items()}
    result = {**runs, "ratio_wall": round(mean["ours"] / mean["baseline"], 3)}
    print(f"wall: baseline {mean['baseline']:.1f} s, ours {mean['ours']:.1f} s, "
          f"ratio {result['ratio_wall']:.2f}")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
