"""The allocator's campaign cost against the lookup controller's, interleaved in one process.

A dispersed campaign (the 26 rate cases x N runs, 20 s each, the vehicle file's dispersions,
summary only, one local worker: in this process) is flown with the lookup controller (on a
generated table: ``rcsim lookup generate --vehicle V``, not timed) and with the allocator,
alternately, ``--repeats`` times.  Measured per campaign: this process's CPU time
(``time.process_time``, every thread of it; the machine's other load does not count, though it
slows the CPU), and the allocator's solver counts from the campaign manifest (LP relaxations,
branch-and-bound searches and nodes, exact MILP solves) -- or, for code that does not record
them, its allocators' ``n_milp`` counters.  Target: allocator / lookup CPU <= 1.5.

Usage::

    python benchmarks/allocator_vs_lookup.py [--vehicles canted16,docs/examples/service16.toml]
        [--runs-per-case 20] [--repeats 1]
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

from rcsim.analysis.engine.campaign.runner import run_campaign  # noqa: E402
from rcsim.analysis.engine.campaign.spec import parse_dict  # noqa: E402


def _spec(controller: str, runs: int, vehicle: str, table: str | None):
    data: dict = {
        "seed": 39,
        "runs_per_case": runs,
        "vehicle": vehicle,
        "scenario": {"kind": "rate-cases", "cases": "all", "duration_s": 20.0},
        "controller": {"name": controller},
        "output": {"histories": "none", "plots": False},
    }
    if table is not None:
        data["controller"]["table"] = table
    return parse_dict(data, source=f"benchmark {controller}")


def _table(vehicle: str, tmp: Path) -> str:
    out = tmp / (Path(vehicle).stem + ".csv")
    subprocess.run(
        [sys.executable, "-m", "rcsim", "lookup", "generate", "--vehicle", vehicle,
         "--out", str(out)],
        check=True, capture_output=True,
    )  # fmt: skip
    return str(out)


def _milp_counter():
    """Every Allocator made from now on, to read its counters (older code: no manifest)."""
    from rcsim.lookup import allocator as module

    made: list = []
    init = module.Allocator.__init__

    def recording(self, *args, **kw):
        init(self, *args, **kw)
        made.append(self)

    module.Allocator.__init__ = recording  # type: ignore[method-assign]
    return made


def campaign(controller: str, runs: int, vehicle: str, table: str | None, made: list):
    made.clear()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "c"
        t0 = time.process_time()
        run_campaign(_spec(controller, runs, vehicle, table), out, progress=False, local_workers=1)
        cpu = time.process_time() - t0
        manifest = json.loads((out / "manifest.json").read_text())
    counts = manifest.get("solver_counts")
    if counts is None and made:
        counts = {"exact": sum(a.n_milp for a in made)}
    return cpu, counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--vehicles", default="canted16,docs/examples/service16.toml")
    parser.add_argument("--runs-per-case", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    made = _milp_counter()
    print(f"load average before: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.vehicles.split(","):
            vehicle = str(ROOT / name) if name.endswith(".toml") else name
            table = _table(vehicle, Path(tmp))
            ratios = []
            for r in range(args.repeats):
                order = ("lookup", "allocator") if r % 2 == 0 else ("allocator", "lookup")
                cpu: dict = {}
                for controller in order:
                    cpu[controller], counts = campaign(
                        controller, args.runs_per_case, vehicle,
                        table if controller == "lookup" else None, made,
                    )  # fmt: skip
                    if controller == "allocator":
                        solver = counts
                ratios.append(cpu["allocator"] / cpu["lookup"])
                print(
                    f"{Path(name).stem}, 26 x {args.runs_per_case}, repeat {r + 1}: lookup "
                    f"{cpu['lookup']:.2f} s CPU, allocator {cpu['allocator']:.2f} s CPU, "
                    f"allocator / lookup {ratios[-1]:.2f}; allocator solver counts {solver}"
                )
            per = [round(x, 2) for x in ratios]
            print(f"{Path(name).stem}: allocator / lookup CPU per repeat {per}")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
