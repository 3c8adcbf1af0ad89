"""What flying a controller through the plug-in path costs (``docs/flight_software.md``).

The same dispersed campaign (the 26 rate cases of Table 3, Table 5 dispersions, the packaged
lookup table) flown with the built-in lookup controller and with
``examples/plugins/wrapped_lookup.py`` (the same controller behind the plug-in path: import,
factory, the contract check of every cycle's on-times), interleaved, one process, CPU time of
each.  The two must fly the same runs to the bit (checked: every outcome column equal), so the
ratio is the plug-in path's cost alone.  Target: at most 1.2x.

Usage::

    python benchmarks/plugin_overhead.py                 # 26 x 20 runs, 3 interleaved rounds
    python benchmarks/plugin_overhead.py --runs-per-case 2 --rounds 1 --duration-s 4   # smoke
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import pandas as pd

from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "plugins" / "wrapped_lookup.py"
SPEC = """
seed = 3
runs_per_case = {runs}
[scenario]
duration_s = {duration}
[controller]
{controller}
[output]
histories = "none"
plots = false
"""


def fly(controller: str, runs: int, duration: float, tmp: Path, tag: str):
    """CPU seconds of one campaign and its runs table."""
    spec_file = tmp / f"{tag}.toml"
    spec_file.write_text(SPEC.format(runs=runs, duration=duration, controller=controller))
    spec = load_spec(spec_file)
    start = time.process_time()
    run_campaign(spec, tmp / tag, local_workers=1, progress=False)
    cpu = time.process_time() - start
    return cpu, pd.read_parquet(tmp / tag / "runs.parquet")


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=20)
    ap.add_argument("--duration-s", type=float, default=20.0)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    builtin, plugin = [], []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for r in range(args.rounds):
            a, ra = fly('name = "lookup"', args.runs_per_case, args.duration_s, tmp, f"b{r}")
            b, rb = fly(
                f'plugin = "{EXAMPLE}:make_controller"', args.runs_per_case, args.duration_s, tmp,
                f"p{r}",
            )  # fmt: skip
            cols = [c for c in ra.columns if c.startswith(("final_", "max_", "propellant"))]
            pd.testing.assert_frame_equal(ra[cols], rb[cols])  # the same runs, to the bit
            builtin.append(a)
            plugin.append(b)
            print(f"round {r}: built-in {a:.2f} s CPU, plug-in {b:.2f} s CPU ({b / a:.3f}x)")
    ratio = sum(plugin) / sum(builtin)
    runs = 26 * args.runs_per_case
    print(
        f"{runs} runs x {args.rounds} rounds: built-in {sum(builtin):.2f} s, plug-in "
        f"{sum(plugin):.2f} s CPU: the plug-in path costs {ratio:.3f}x (target <= 1.2x)"
    )
    return {"builtin_cpu_s": builtin, "plugin_cpu_s": plugin, "ratio": ratio}


if __name__ == "__main__":
    main()
