"""Benchmark: the whole noisy-sensor study, 6 architectures x 1000 runs (paper Section 3).

Times :func:`analysis.studies.noisy_sensor.run_study` (random draws for 1000 runs, six vectorized
RK4 Monte Carlos of 100 steps, the tables) and, separately, writing the four outputs.
Prints wall seconds; the target is under 2 s for the study.

Usage: ``.venv/bin/python benchmarks/noisy_sensor.py [--runs N] [--repeat R]``
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from rcsim.analysis.studies.noisy_sensor import StudyConfig, run_study, write_outputs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    cfg = StudyConfig(runs=args.runs)
    run_study(StudyConfig(runs=2))  # warm-up: imports, BLAS initialisation
    walls, result = [], None
    for _ in range(args.repeat):
        start = time.perf_counter()
        result = run_study(cfg)
        walls.append(time.perf_counter() - start)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        write_outputs(result, Path(tmp) / "out")
        write_s = time.perf_counter() - start
    print(f"noisy-sensor study, 6 architectures x {cfg.runs} runs, {args.repeat} repeats")
    print(f"  study wall s: median {statistics.median(walls):.3f}, best {min(walls):.3f}")
    print(f"  of which random draws: {result.draw_s:.3f} s (shared by all architectures)")
    for label, wall in zip(result.summary["architecture"], result.summary["wall_s"]):
        print(f"  {label:<20s} {wall:.4f} s")
    print(f"  writing csv + parquet + png: {write_s:.3f} s")


if __name__ == "__main__":
    main()
