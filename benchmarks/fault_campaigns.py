"""Evidence for issue 11 through the real campaign command: failures and repeated firings with
sensors, delays and jet faults, for the static table, the adaptive controller and (jet faults)
the table regenerated without the failed jet; and the campaign's speed with noise and delays
on and off.

Every configuration is a campaign spec (written to ``OUT/specs/``) flown by ``rcsim campaign
run`` (in this process, :func:`rcsim.analysis.apps.cli.main`): the 26 rate cases of Table 3
commanded from rest, ``--runs-per-case`` runs each, Table 5 dispersions, seed 1, 20 s, the
default failure threshold (0.04 deg/s), histories not kept.  The regenerated table is made by
``rcsim lookup generate --jets-off 13``.  Per campaign it prints, from ``runs.parquet``: the
failed percentage, the mean firing events before the rate is reached (summed over the axes) and
the percentage of runs with a repeated firing (more than one event before the rate on some
axis).

``--speed``: CPU seconds of the same nominal and noise-and-delays campaigns flown with one
MuJoCo thread (best of ``--repeats``; CPU time, not wall time, because the machine is shared).

Usage: ``python benchmarks/fault_campaigns.py --out DIR [--runs-per-case 50] [--speed]``.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rcsim.analysis.apps.cli import main as rcsim  # noqa: E402

BASE = """seed = 1
runs_per_case = {runs}
[scenario]
kind = "rate-cases"
cases = "all"
duration_s = 20.0
[controller]
name = "{controller}"
table = "{table}"
[output]
histories = "none"
plots = false
"""
# Levels and their reasons: docs/faults.md ("Levels used as plausible").
SENSOR = """[dispersions.sensor]
att_noise_deg = 0.003
rate_noise_deg_s = 0.001
att_bias_sigma_deg = 0.003
rate_bias_sigma_deg_s = 0.003
rate_walk_deg_s_per_sqrt_s = 0.0005
"""
TIMING = """[dispersions.timing]
command_delay_s = 0.005
open_delay_s = 0.008
open_delay_sigma_s = 0.001
close_delay_s = 0.005
close_delay_sigma_s = 0.001
"""
ROTATION_JETS = "[1, 2, 3, 4, 9, 10, 11, 12, 13, 14, 15, 16]"  # jets 5-8 give no torque
DEGRADED = f"""[dispersions.fault]
mode = "degraded"
jets = {ROTATION_JETS}
thrust_factor = 0.8
"""
OFF_ANY = f"""[dispersions.fault]
mode = "off"
jets = {ROTATION_JETS}
time_s = 0.0
"""
OFF_13 = """[dispersions.fault]
mode = "off"
jets = [13]
time_s = 0.0
"""
STUCK = f"""[dispersions.fault]
mode = "stuck"
jets = {ROTATION_JETS}
time_s = [0.0, 10.0]
stuck_for_s = [0.1, 0.5]
"""

#: (name, extra spec text, controllers); "regenerated": lookup with the table made without
#: jet 13.
CONFIGS = [
    ("Table 5 only", "", ("lookup", "adaptive")),
    ("+ sensor noise and biases", SENSOR, ("lookup", "adaptive")),
    ("+ command and valve delays", TIMING, ("lookup", "adaptive")),
    ("+ noise and delays", SENSOR + TIMING, ("lookup", "adaptive")),
    ("+ one jet at 80 % thrust", DEGRADED, ("lookup", "adaptive")),
    ("+ one jet stuck on 0.1-0.5 s", STUCK, ("lookup", "adaptive")),
    ("+ one jet failed off", OFF_ANY, ("lookup", "adaptive")),
    ("+ jet 13 failed off", OFF_13, ("lookup", "adaptive", "regenerated")),
    (
        "+ jet 13 failed off, noise and delays",
        OFF_13 + SENSOR + TIMING,
        ("lookup", "adaptive", "regenerated"),
    ),
]


def score(runs: pd.DataFrame) -> dict:
    """Failed %, mean firing events to rate (summed over axes), repeated-firing runs %."""
    ev = runs[[f"firings_to_rate_{a}" for a in ("roll", "pitch", "yaw")]]
    return {
        "runs": len(runs),
        "failed_pct": 100 * runs["failed"].mean(),
        "firings": ev.sum(axis=1).mean(),
        "repeated_pct": 100 * (ev > 1).any(axis=1).mean(),
    }


def campaign(out: Path, name: str, text: str) -> pd.DataFrame:
    spec = out / "specs" / f"{name}.toml"
    spec.write_text(text)
    where = out / "campaigns" / name
    argv = ["campaign", "run", str(spec), "--out", str(where)]
    if where.exists():
        argv.append("--resume")
    code = rcsim(argv)
    if code != 0:
        raise SystemExit(f"rcsim campaign run {spec}: exit {code}")
    return pd.read_parquet(where / "runs.parquet")


def evidence(out: Path, runs: int) -> None:
    table = out / "table_no13.csv"
    if not table.exists():
        assert rcsim(["lookup", "generate", "--jets-off", "13", "--out", str(table)]) == 0
    rows = []
    for k, (config, extra, controllers) in enumerate(CONFIGS):
        for ctl in controllers:
            name = f"c{k}-{ctl}"
            text = (
                BASE.format(
                    runs=runs,
                    controller="lookup" if ctl == "regenerated" else ctl,
                    table=table if ctl == "regenerated" else "default",
                )
                + extra
            )
            t0 = time.perf_counter()
            r = score(campaign(out, name, text))
            rows.append(
                {
                    "configuration": config,
                    "controller": ctl,
                    **r,
                    "wall_s": time.perf_counter() - t0,
                    "dir": name,
                }
            )
    frame = pd.DataFrame(rows)
    frame.to_csv(out / "evidence.csv", index=False)
    print(
        "| configuration | controller | runs | failed % | firing events to rate | "
        "runs with a repeated firing % |"
    )
    print("|---|---|---|---|---|---|")
    for r in frame.itertuples():
        print(
            f"| {r.configuration} | {r.controller} | {r.runs} | {r.failed_pct:.1f} | "
            f"{r.firings:.2f} | {r.repeated_pct:.1f} |"
        )


def speed(out: Path, runs: int, repeats: int) -> None:
    from rcsim.analysis.engine.campaign.runner import run_campaign
    from rcsim.analysis.engine.campaign.spec import load_spec

    spec_dir = out / "specs"
    spec_dir.mkdir(parents=True, exist_ok=True)
    for label, extra in (("off", ""), ("noise and delays", SENSOR + TIMING)):
        path = spec_dir / f"speed-{label.replace(' ', '-')}.toml"
        path.write_text(BASE.format(runs=runs, controller="lookup", table="default") + extra)
        best = float("inf")
        for k in range(repeats):
            where = out / "speed" / f"{path.stem}-{k}"
            c0 = resource.getrusage(resource.RUSAGE_SELF)
            run_campaign(load_spec(path), where, local_workers=1, progress=False)
            c1 = resource.getrusage(resource.RUSAGE_SELF)
            best = min(best, (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime))
        n = 26 * runs
        print(
            f"{label}: {n} runs x 20 s in {best:.2f} CPU s (best of {repeats}): "
            f"{n * 20.0 / best:.0f} simulated s per CPU s",
            flush=True,
        )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path, help="working directory (created)")
    ap.add_argument("--runs-per-case", type=int, default=50)
    ap.add_argument("--speed", action="store_true", help="only the speed comparison")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    (args.out / "specs").mkdir(parents=True, exist_ok=True)
    if args.speed:
        speed(args.out, args.runs_per_case, args.repeats)
    else:
        evidence(args.out, args.runs_per_case)
    return 0


if __name__ == "__main__":
    sys.exit(main())
