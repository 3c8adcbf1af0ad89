"""The analyst's loop end to end: stage times and peak memory (issue 19; docs/performance.md).

Runs ``rcsim loop --runs-per-case N`` in a subprocess for each N asked (default 100 and 1,000),
and while it runs samples, twice a second:

* the memory of the loop's whole process tree (the CLI, its fork server and chunk workers):
  the sum of each process's proportional set size (PSS: a page shared by k processes, such
  as the libraries the fork server preloads, counts 1/k in each), the figure the "under 1 GB"
  target is about.  Summed RSS would count every shared library once per worker;
* foreign load: every other process that used more than 10 % of a CPU over the sample.  A
  run during which one was seen is marked ``watched_clean: false``; quote clean runs only.

Stage times come from the loop's own ``loop.json`` (each stage's wall seconds).  Beside the
seconds, the loop's wall time in units of its own first campaign (``campaign_before``: the 26
rate cases x N runs, lookup controller, Table 5 dispersions), measured in the same run: a
ratio that carries from one machine to another better than seconds do (quote it as "the loop =
5.1 campaigns of its size").

Usage::

    python benchmarks/loop.py                         # 100 and 1,000 runs per case
    python benchmarks/loop.py --runs-per-case 100 --json out.json

Linux only (reads ``/proc``).  Timings are wall-clock: run it on an idle machine.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.analysis.apps.loop.run import STAGES  # noqa: E402

SAMPLE_S = 0.5
FOREIGN_CPU = 0.10  # fraction of one CPU over a sample
TICKS = os.sysconf("SC_CLK_TCK")
PAGE = os.sysconf("SC_PAGE_SIZE")


def _pss_bytes(pid: int) -> int | None:
    """Proportional set size of ``pid`` [bytes], None when the kernel does not tell."""
    try:
        for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
            if line.startswith("Pss:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _processes() -> dict[int, tuple[int, int, int]]:
    """pid -> (parent pid, CPU ticks used, resident bytes), for every readable process."""
    table = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
            statm = Path(f"/proc/{entry}/statm").read_text().split()
        except OSError:  # gone between listdir and read
            continue
        fields = stat[stat.rindex(")") + 2 :].split()  # after "pid (comm) "
        table[int(entry)] = (
            int(fields[1]),
            int(fields[11]) + int(fields[12]),
            int(statm[1]) * PAGE,
        )
    return table


def _tree(root: int, table: dict) -> set[int]:
    """``root`` and all its descendants in ``table``."""
    children: dict[int, list[int]] = {}
    for pid, (ppid, _, _) in table.items():
        children.setdefault(ppid, []).append(pid)
    tree, todo = set(), [root]
    while todo:
        pid = todo.pop()
        if pid not in tree:
            tree.add(pid)
            todo.extend(children.get(pid, []))
    return tree


def run_loop(runs_per_case: int, folder: Path) -> dict:
    """One watched ``rcsim loop`` run; returns its stage times, peak memory and load record."""
    out = folder / f"loop-{runs_per_case}"
    cmd = [
        sys.executable,
        "-m",
        "rcsim",
        "loop",
        "--runs-per-case",
        str(runs_per_case),
        "--out",
        str(out),
    ]
    me = os.getpid()
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        cmd,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    # The loop prints "<stage>: done in ..." as each stage ends: the stage in progress is the
    # one after the last line seen, and each memory sample is charged to it.
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    stage_peak = dict.fromkeys(STAGES, 0)
    peak, foreign, before = 0, [], _processes()
    while proc.poll() is None:
        time.sleep(SAMPLE_S)
        now = _processes()
        ours = _tree(proc.pid, now)
        memory = sum(_pss_bytes(p) or now[p][2] for p in ours if p in now)
        peak = max(peak, memory)
        done = [st for st in STAGES if any(line.startswith(f"{st}: ") for line in lines)]
        current = STAGES[min(len(done), len(STAGES) - 1)]
        stage_peak[current] = max(stage_peak[current], memory)
        for pid, (_, ticks, _) in now.items():
            if pid in ours or pid == me or pid not in before:
                continue
            share = (ticks - before[pid][1]) / TICKS / SAMPLE_S
            if share > FOREIGN_CPU:
                foreign.append(round(time.perf_counter() - t0, 1))
                break
        before = now
    wall = time.perf_counter() - t0
    reader.join()
    log = "".join(lines)
    if proc.returncode != 0:
        raise SystemExit(f"rcsim loop failed ({proc.returncode}):\n{log}")
    state = json.loads((out / "loop.json").read_text())
    stage_s = {k: v["seconds"] for k, v in state["done"].items()}
    return {
        "runs_per_case": runs_per_case,
        "wall_s": round(wall, 1),
        "campaigns": round(wall / stage_s["campaign_before"], 2),
        "stage_s": stage_s,
        "peak_pss_mb": round(peak / 2**20),
        "stage_peak_pss_mb": {k: round(v / 2**20) for k, v in stage_peak.items()},
        "watched_clean": not foreign,
        "foreign_load_at_s": foreign[:20],
        "load_avg_1min_after": os.getloadavg()[0],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs-per-case", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--json", type=Path, help="also write the results here")
    args = ap.parse_args(argv)
    results = []
    with tempfile.TemporaryDirectory(prefix="rcsim-loop-bench-") as tmp:
        for n in args.runs_per_case:
            res = run_loop(n, Path(tmp))
            results.append(res)
            stages = ", ".join(f"{k} {v:.1f}" for k, v in res["stage_s"].items())
            load = (
                "no foreign load seen"
                if res["watched_clean"]
                else f"FOREIGN LOAD at {res['foreign_load_at_s']}"
            )
            print(
                f"{n} runs/case: {res['wall_s']:.1f} s wall = {res['campaigns']:.2f} campaigns "
                f"of 26 x {n} runs ({stages}); peak memory "
                f"(PSS) {res['peak_pss_mb']} MB (by stage: {res['stage_peak_pss_mb']}); {load}",
                flush=True,
            )
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
