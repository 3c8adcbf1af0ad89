"""Vehicle loads per campaign chunk (issue 27): how often a worker parses the vehicle file and
compiles its MuJoCo model, and what that costs.

A worker receives the campaign spec pickled (as Dask and the local pool send it); this script
does the same: it pickles the spec, clears the process's model cache, unpickles it and flies
chunks, counting every vehicle-file parse (``parse_vehicle``) and every model compilation
(``mujoco.MjModel.from_xml_string`` / ``from_xml_path``) on the way, and timing one of each.

Usage::

    python benchmarks/vehicle_loads.py [--vehicle paper] [--chunks 3] [--runs-per-case 4]

Prints, for the first chunk a worker flies and for each later one, the parses and compilations
and the time they took (count x the measured cost of one).
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from pathlib import Path

import mujoco

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.analysis.engine.campaign import chunk as chunk_module  # noqa: E402
from rcsim.analysis.engine.campaign.spec import parse_dict  # noqa: E402
from rcsim.spacecraft.vehicle import file_schema  # noqa: E402
from rcsim.spacecraft.vehicle import vehicle as vehicle_module  # noqa: E402

COUNTS = {"parse": 0, "compile": 0}


def _counting(owner, name: str, key: str):
    original = getattr(owner, name)

    def wrapper(*args, **kwargs):
        COUNTS[key] += 1
        return original(*args, **kwargs)

    setattr(owner, name, wrapper)
    return original


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--vehicle", default="paper")
    p.add_argument("--chunks", type=int, default=3)
    p.add_argument("--runs-per-case", type=int, default=4)
    args = p.parse_args(argv)
    spec = parse_dict(
        {
            "vehicle": args.vehicle,
            "seed": 1,
            "runs_per_case": args.runs_per_case,
            "chunk_size": 26,
            "scenario": {"kind": "rate-cases", "duration_s": 2.0},
            "controller": {"name": "allocator"},
            "output": {"histories": "none", "plots": False},
        },
        source="benchmark",
        base_dir=None,
    )
    blob = pickle.dumps(spec)
    # One parse and one compilation, timed alone (the cost each count below stands for).
    t0 = time.perf_counter()
    parsed = vehicle_module.Vehicle.load(args.vehicle)
    parse_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    mujoco.MjModel.from_xml_string(vehicle_module.to_mjcf(parsed.definition))
    compile_s = time.perf_counter() - t0

    _counting(file_schema, "parse_vehicle", "parse")
    _counting(vehicle_module, "parse_vehicle", "parse")
    _counting(mujoco.MjModel, "from_xml_string", "compile")
    _counting(mujoco.MjModel, "from_xml_path", "compile")
    vehicle_module._MODELS.clear()  # a fresh worker: nothing compiled yet
    worker_spec = pickle.loads(blob)
    print(f"spec pickled: {len(blob):,} bytes; one parse {parse_s * 1e3:.1f} ms, one "
          f"compilation {compile_s * 1e3:.1f} ms ({args.vehicle})")  # fmt: skip
    print("| chunk on a fresh worker | parses | compilations | their time [ms] |")
    print("|---|---|---|---|")
    for k, chunk in enumerate(chunk_module.plan_chunks(worker_spec)[: args.chunks]):
        COUNTS.update(parse=0, compile=0)
        chunk_module.simulate_chunk(worker_spec, chunk)
        cost = COUNTS["parse"] * parse_s + COUNTS["compile"] * compile_s
        print(f"| {k + 1} | {COUNTS['parse']} | {COUNTS['compile']} | {cost * 1e3:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
