"""The C lookup example's cost per run-cycle against rcsim's built-in lookup controller.

Builds ``examples/c_fsw/lookup.c`` (needs a C compiler), then flies the same dispersed runs
(the 26 rate cases of Table 3, Table 5 dispersions) with each controller, interleaved, in
this process, and reports CPU microseconds per run-cycle of the whole closed loop and of the
controller's step alone (timed around each call), with a check that both fly the same
on-times bit for bit (docs/flight_software.md).

Usage::

    python benchmarks/c_lookup_cost.py                    # 26 x 20 runs, 20 s, 3 rounds
    python benchmarks/c_lookup_cost.py --runs-per-case 2 --rounds 1 --duration-s 4   # smoke
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rcsim.analysis.apps.back_to_back import Side
from rcsim.analysis.engine.campaign.chunk import fly_runs
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.lookup.pattern_recognition import default_table_path

ROOT = Path(__file__).resolve().parents[1]


class Timed:
    """A controller whose ``step`` calls are timed (CPU seconds in :attr:`step_s`)."""

    def __init__(self, inner):
        self.inner, self.step_s = inner, 0.0

    @property
    def cycle_s(self):
        return self.inner.cycle_s

    def initial_state(self, n):
        return self.inner.initial_state(n)

    def step(self, nav, state):
        t = time.process_time()
        out = self.inner.step(nav, state)
        self.step_s += time.process_time() - t
        return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs-per-case", type=int, default=20)
    ap.add_argument("--duration-s", type=float, default=20.0)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        lib = tmp / "liblookup.so"
        subprocess.run(
            ["sh", str(ROOT / "examples/c_fsw/build.sh"), str(ROOT / "examples/c_fsw/lookup.c"),
             str(lib)],
            check=True, capture_output=True, env={**os.environ, "PYTHON": sys.executable},
        )  # fmt: skip
        spec_file = tmp / "s.toml"
        spec_file.write_text(
            f"seed = 1\nruns_per_case = {args.runs_per_case}\n[scenario]\n"
            f'duration_s = {args.duration_s}\n[controller]\nname = "lookup"\n'
        )
        spec = load_spec(spec_file)
        sides = {
            "built-in": Side("lookup"),
            "C": Side(f"library:{lib}", {"table": str(default_table_path())}),
        }
        specs = {k: s.spec_for(spec) for k, s in sides.items()}
        ids = np.arange(spec.n_runs)
        total = {k: 0.0 for k in sides}
        step = {k: 0.0 for k in sides}
        cycles = 0
        for r in range(args.rounds):
            on = {}
            for k, sp in specs.items():
                ctl = Timed(sp.make_controller())
                t = time.process_time()
                hist, _ = fly_runs(_with(sp, ctl), ids)
                total[k] += time.process_time() - t
                step[k] += ctl.step_s
                on[k] = hist.on_time_s
                cycles = hist.on_time_s.shape[1]
            assert np.array_equal(on["built-in"], on["C"]), "the C lookup differs from rcsim's"
            print(f"round {r}: " + ", ".join(f"{k} {total[k]:.2f} s" for k in sides))
    run_cycles = args.rounds * spec.n_runs * cycles
    out = {}
    for k in sides:
        out[k] = (1e6 * total[k] / run_cycles, 1e6 * step[k] / run_cycles)
        print(
            f"{k}: {out[k][0]:.2f} us CPU per run-cycle in all, {out[k][1]:.3f} us of it in the "
            "controller's step"
        )
    print(f"C / built-in, controller step: {out['C'][1] / out['built-in'][1]:.2f}x")
    return out


def _with(spec, controller):
    """``spec`` whose chunks fly ``controller`` (an object, not a name)."""

    class _Spec(type(spec)):  # type: ignore[misc]
        def make_controller(self, **options):
            return controller

    import dataclasses

    return _Spec(**{f.name: getattr(spec, f.name) for f in dataclasses.fields(spec)})


if __name__ == "__main__":
    main()
