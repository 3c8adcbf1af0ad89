"""`rcsim analyze` at 10^4, 10^5 and 10^6 runs: wall time and peak memory (issue 17).

Each size is a synthetic runs table (``rcsim.analysis.results.drivers.synthetic.planted_campaign``,
the one-sided scenario: failures from two inputs, the rest noise) with 60 inputs and 26 cases,
written as Parquet and analysed by the real command in a subprocess, so the peak resident memory
is the command's own (``RUSAGE_CHILDREN``).  The issue's target: 10^6 runs x 60 inputs within
4 GB and about 5 minutes on 2 cores.

Usage::

    python benchmarks/analyze_scale.py                 # 1e4 1e5 1e6
    python benchmarks/analyze_scale.py --runs 10000 100000
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def table(n_runs: int, n_inputs: int, path: Path) -> None:
    import numpy as np

    from rcsim.analysis.results.drivers.synthetic import planted_campaign

    X, failed = planted_campaign("one-sided", seed=1, n_runs=n_runs, n_noise=n_inputs - 2)
    X.insert(0, "run_id", np.arange(n_runs))
    X["case"] = [f"rate-{c % 26 + 1:02d}" for c in range(n_runs)]
    X["failed"] = failed
    X.to_parquet(path)


def measure(n_runs: int, n_inputs: int, folder: Path) -> dict:
    data = folder / f"runs-{n_runs}.parquet"
    table(n_runs, n_inputs, data)
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "rcsim", "analyze", str(data), "--out", str(folder / f"a-{n_runs}")],
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return {
        "runs": n_runs,
        "inputs": n_inputs,
        "wall_s": round(wall, 1),
        # ru_maxrss of children is the largest child so far: meaningful when it grew.
        "peak_rss_mb": round(max(peak, before) / 1024),
        "exit": done.returncode,
        "last_line": (done.stderr.strip() or done.stdout.strip()).splitlines()[-1:],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--inputs", type=int, default=60)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="rcsim-analyze-bench-") as tmp:
        for n in sorted(args.runs):
            print(measure(n, args.inputs, Path(tmp)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
