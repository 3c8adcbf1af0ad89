"""Benchmark: the noisy-sensor study, 6 architectures x 1000 runs (Pittella & Sands, Section 3).

Measures three things, each ``--repeat`` times, and prints median and range:

* ``study``: the library call :func:`rcsim.analysis.apps.studies.noisy_sensor.run_study` in this
  (already warm) process: random draws for N runs, six vectorized RK4 Monte Carlos of 100
  steps, the tables.  This is the figure to quote for "the study takes X s".
* ``write``: :func:`~rcsim.analysis.apps.studies.noisy_sensor.write_outputs` (summary.csv,
  percent.csv, runs.parquet, scatter.png) after one study.
* ``cli``: the wall time a user waits for ``rcsim study noisy-sensor --runs N --out DIR``, a
  fresh process each time (interpreter start, imports of numpy/pandas/matplotlib/pyarrow,
  study, outputs), and ``cli startup``: ``rcsim study noisy-sensor --help`` (the same start
  and argument parsing, no study), so the difference is the work itself.
* ``cli cold``: the same command as a first run after installing: every run gets an empty
  bytecode cache (``PYTHONPYCACHEPREFIX``) and an empty matplotlib config directory
  (``MPLCONFIGDIR``: the font cache is rebuilt), so every module is compiled again.

Prints the conditions (Python, numpy, CPU count) with the figures; docs/noisy-sensor.md
records the measured numbers.

Usage: ``python benchmarks/noisy_sensor.py [--runs N] [--repeat R] [--json FILE]``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rcsim.analysis.apps.studies.noisy_sensor import StudyConfig, run_study, write_outputs


def _rcsim_command() -> list[str]:
    """The installed ``rcsim`` entry point next to this interpreter (what a user runs)."""
    script = Path(sys.executable).with_name("rcsim")
    if script.is_file():
        return [str(script)]
    found = shutil.which("rcsim")
    if found is None:
        sys.exit(
            "benchmarks/noisy_sensor.py: no `rcsim` executable next to this Python or on "
            "PATH; install rcsim (make test) and run with its venv's python"
        )
    return [found]


def _timed_run(cmd: list[str], env: dict | None = None) -> float:
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
    return wall


def _stats(walls: list[float]) -> dict:
    return {
        "median_s": statistics.median(walls),
        "min_s": min(walls),
        "max_s": max(walls),
        "runs_s": walls,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1000, help="Monte Carlo runs per architecture")
    parser.add_argument("--repeat", type=int, default=5, help="timings of each measure")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = parser.parse_args()
    if args.runs < 2 or args.repeat < 1:
        parser.error("--runs must be >= 2 and --repeat >= 1")

    cfg = StudyConfig(runs=args.runs)
    run_study(StudyConfig(runs=2))  # warm-up: imports, BLAS initialisation
    study, result = [], None
    for _ in range(args.repeat):
        start = time.perf_counter()
        result = run_study(cfg)
        study.append(time.perf_counter() - start)

    write, cli, startup, cold = [], [], [], []
    rcsim = _rcsim_command()
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.repeat):
            start = time.perf_counter()
            write_outputs(result, Path(tmp) / f"lib{i}")
            write.append(time.perf_counter() - start)
        for i in range(args.repeat):
            startup.append(_timed_run(rcsim + ["study", "noisy-sensor", "--help"]))
            cli.append(
                _timed_run(
                    rcsim
                    + [
                        "study",
                        "noisy-sensor",
                        "--runs",
                        str(args.runs),
                        "--out",
                        str(Path(tmp) / f"cli{i}"),
                    ]
                )
            )
        for i in range(args.repeat):
            caches = Path(tmp) / f"caches{i}"
            env = dict(
                os.environ,
                PYTHONPYCACHEPREFIX=str(caches / "pycache"),
                MPLCONFIGDIR=str(caches / "matplotlib"),
            )
            cold.append(
                _timed_run(
                    rcsim
                    + [
                        "study",
                        "noisy-sensor",
                        "--runs",
                        str(args.runs),
                        "--out",
                        str(Path(tmp) / f"cold{i}"),
                    ],
                    env=env,
                )
            )

    figures = {
        "study": _stats(study),
        "write": _stats(write),
        "cli": _stats(cli),
        "cli_startup": _stats(startup),
        "cli_cold": _stats(cold),
        "conditions": {
            "runs": args.runs,
            "repeat": args.repeat,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "cpu_count": os.cpu_count(),
            "machine": platform.machine(),
        },
    }
    c = figures["conditions"]
    print(
        f"noisy-sensor study, 6 architectures x {args.runs} runs, {args.repeat} repeats "
        f"(Python {c['python']}, numpy {c['numpy']}, {c['cpu_count']} CPUs)"
    )
    for key, label in [
        ("study", "library run_study"),
        ("write", "library write_outputs"),
        ("cli", "CLI `rcsim study noisy-sensor` wall"),
        ("cli_startup", "CLI start only (--help)"),
        ("cli_cold", "CLI wall, first run (empty caches)"),
    ]:
        f = figures[key]
        print(
            f"  {label:<38s} median {f['median_s']:.3f} s  "
            f"(min {f['min_s']:.3f}, max {f['max_s']:.3f})"
        )
    print(f"  of the study, random draws: {result.draw_s:.3f} s (shared by all architectures)")
    for label, wall in zip(result.summary["architecture"], result.summary["wall_s"]):
        print(f"  {label:<38s} {wall:.4f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
