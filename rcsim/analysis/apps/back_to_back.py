"""Back-to-back testing: two controllers flown on the same dispersed runs, compared.

How a flight-software team shows that its code is its model: the model (say rcsim's lookup
controller) and the code (the team's C or Python flight software) fly the same inputs, and
every difference is found and explained.  Here the inputs are a campaign's runs: run *i*
draws its vehicle and effects from ``SeedSequence(seed, spawn_key=(i,))`` whichever controller
flies it, so the two flights of a run start identical and stay identical until the first
cycle the controllers command differently.  That cycle is each run's *first divergence*: its
cycle, time, the first jet that differs, the two on-times and the navigation state both
controllers saw there (the same, since every command before it was).

Then the outcomes: the failure verdicts paired run by run (exact McNemar, two-sided: the
discordant runs are fair coins when the controllers are equally good) and the propellant per
run (the paired mean difference with its t 95 % interval).

Written to the output directory: ``divergence.csv`` (one row per run), ``summary.json`` and
``summary.md``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from rcsim.analysis.engine.campaign.chunk import fly_runs, iter_chunks, tabulate
from rcsim.analysis.engine.campaign.results import code_version
from rcsim.analysis.engine.campaign.spec import CampaignSpec, check_plugin
from rcsim.analysis.results.proportions import mcnemar_exact
from rcsim.lookup.registry import TABLE_CONTROLLERS, is_plugin, make_controller
from rcsim.spacecraft.vehicle.model import AXES

#: On-times closer than this are the same command [s]: identical code gives identical
#: doubles; anything else is a difference, however small (a nanosecond is far below any jet).
SAME_S = 0.0


@dataclass(frozen=True)
class Side:
    """One controller of the comparison: its name and (a plug-in's) parameters."""

    name: str
    params: dict = dataclasses.field(default_factory=dict)

    def spec_for(self, spec: CampaignSpec) -> CampaignSpec:
        """``spec`` with this controller: same runs, same seed, same dispersions."""
        table = spec.table if self.name in TABLE_CONTROLLERS else None
        replaced = dataclasses.replace(
            spec, controller=self.name, controller_params=dict(self.params), table=table
        )
        resolved = {"name": self.name, "params": dict(self.params)}
        if is_plugin(self.name):
            check_plugin(resolved, spec.vehicle, spec.source)  # one line if it cannot build
        else:
            make_controller(self.name, spec.vehicle, table=table)
        return replaced


def compare(spec: CampaignSpec, a: Side, b: Side, *, progress=None) -> dict:
    """Fly every run of ``spec`` with ``a`` and ``b``; per-run divergence and outcomes.

    Returns
    -------
    dict
        ``runs`` (DataFrame, one row per run: ``run_id``, ``case``, ``diverged``,
        ``first_cycle``, ``first_t_s``, ``first_jet``, ``a_on_s``, ``b_on_s``,
        ``att_err_<axis>_deg``, ``rate_err_<axis>_deg_s`` at that cycle, ``cycles_differing``,
        ``max_abs_diff_s``, ``failed_a``, ``failed_b``, ``propellant_a_kg``,
        ``propellant_b_kg``) and ``summary`` (dict, what :func:`summary_lines` says).
    """
    spec_a, spec_b = a.spec_for(spec), b.spec_for(spec)
    rows = []
    for chunk in iter_chunks(spec):
        hist_a, disp = fly_runs(spec_a, chunk.run_ids)
        hist_b, _ = fly_runs(spec_b, chunk.run_ids)
        rows.append(_chunk_rows(spec, chunk.run_ids, hist_a, hist_b, disp, spec_a, spec_b))
        if progress is not None:
            progress(chunk.stop - chunk.first)
    runs = pd.concat(rows, ignore_index=True)
    return {"runs": runs, "summary": _summary(spec, a, b, runs)}


def compare_item(item: tuple) -> dict:
    """``(spec, a, b)`` compared: what a child process runs for C flight code."""
    spec, a, b = item
    return compare(spec, a, b)


def _chunk_rows(spec, run_ids, hist_a, hist_b, disp, spec_a, spec_b) -> pd.DataFrame:
    on_a, on_b = hist_a.on_time_s, hist_b.on_time_s  # (n, cycles, jets) [s]
    diff = np.abs(on_a - on_b) > SAME_S
    diff |= np.isnan(on_a) != np.isnan(on_b)
    per_cycle = diff.any(axis=2)  # (n, cycles)
    diverged = per_cycle.any(axis=1)
    first = np.where(diverged, per_cycle.argmax(axis=1), -1)
    n = run_ids.size
    idx = np.arange(n)
    cyc = np.maximum(first, 0)
    jet = diff[idx, cyc].argmax(axis=1)
    out = {
        "run_id": run_ids,
        "case": [spec.cases[c].name for c in run_ids // spec.runs_per_case],
        "diverged": diverged,
        "first_cycle": first,
        "first_t_s": np.where(diverged, hist_a.t_s[cyc], np.nan),
        "first_jet": np.where(diverged, jet + 1, 0),
        "a_on_s": np.where(diverged, on_a[idx, cyc, jet], np.nan),
        "b_on_s": np.where(diverged, on_b[idx, cyc, jet], np.nan),
    }
    for k, axis in enumerate(AXES):  # what both controllers saw at that cycle (the same)
        out[f"att_err_{axis}_deg"] = np.where(
            diverged, np.degrees(hist_a.att_err_B[idx, cyc, k]), np.nan
        )
    for k, axis in enumerate(AXES):
        out[f"rate_err_{axis}_deg_s"] = np.where(
            diverged, np.degrees(hist_a.rate_err_B[idx, cyc, k]), np.nan
        )
    out["cycles_differing"] = per_cycle.sum(axis=1)
    out["max_abs_diff_s"] = np.nan_to_num(np.abs(on_a - on_b), nan=np.inf).max(axis=(1, 2))
    rows_a = tabulate(spec_a, hist_a, disp)
    rows_b = tabulate(spec_b, hist_b, disp)
    out["failed_a"] = rows_a["failed"].to_numpy(bool)
    out["failed_b"] = rows_b["failed"].to_numpy(bool)
    out["propellant_a_kg"] = rows_a["propellant_kg"].to_numpy(float)
    out["propellant_b_kg"] = rows_b["propellant_kg"].to_numpy(float)
    return pd.DataFrame(out)


def _summary(spec: CampaignSpec, a: Side, b: Side, runs: pd.DataFrame) -> dict:
    n = len(runs)
    fa, fb = runs["failed_a"].to_numpy(), runs["failed_b"].to_numpy()
    only_a, only_b = int((fa & ~fb).sum()), int((fb & ~fa).sum())
    d = (runs["propellant_b_kg"] - runs["propellant_a_kg"]).to_numpy(float)
    d = d[np.isfinite(d)]
    if d.size > 1 and d.std(ddof=1) > 0:
        half = stats.t.ppf(0.975, d.size - 1) * d.std(ddof=1) / math.sqrt(d.size)
    else:
        half = 0.0
    first = runs[runs["diverged"]].sort_values(["first_t_s", "run_id"]).head(1)
    return {
        "spec": spec.source,
        "seed": spec.seed,
        "code_version": code_version(),
        "a": dataclasses.asdict(a),
        "b": dataclasses.asdict(b),
        "runs": n,
        "diverged": int(runs["diverged"].sum()),
        "earliest": None if first.empty else json.loads(first.to_json(orient="records"))[0],
        "failed_a": int(fa.sum()),
        "failed_b": int(fb.sum()),
        "failed_only_a": only_a,
        "failed_only_b": only_b,
        "mcnemar_p": float(mcnemar_exact(only_a, only_b)),
        "propellant_diff_kg": float(d.mean()) if d.size else float("nan"),
        "propellant_diff_ci_kg": [float(d.mean() - half), float(d.mean() + half)]
        if d.size
        else None,
    }


def summary_lines(s: dict) -> list[str]:
    """What the command prints (and ``summary.md`` holds), each figure from ``s``."""
    a, b = s["a"]["name"], s["b"]["name"]
    lines = [
        f"{a} (A) against {b} (B) on the {s['runs']} runs of {s['spec']} (seed {s['seed']}): "
        f"{s['diverged']} of {s['runs']} runs commanded differently"
        + (
            "; the two command the same on-times, bit for bit, in every run"
            if not s["diverged"]
            else ""
        )
    ]
    e = s["earliest"]
    if e is not None:
        lines.append(
            f"earliest divergence: run {e['run_id']} ({e['case']}) at cycle {e['first_cycle']} "
            f"(t = {e['first_t_s']:g} s), jet {e['first_jet']}: A {e['a_on_s']!r} s, "
            f"B {e['b_on_s']!r} s; attitude error "
            f"[{e['att_err_roll_deg']:.4g}, {e['att_err_pitch_deg']:.4g}, "
            f"{e['att_err_yaw_deg']:.4g}] deg, rate error [{e['rate_err_roll_deg_s']:.4g}, "
            f"{e['rate_err_pitch_deg_s']:.4g}, {e['rate_err_yaw_deg_s']:.4g}] deg/s"
        )
    lines.append(
        f"failures: A {s['failed_a']}, B {s['failed_b']} of {s['runs']}; "
        f"{s['failed_only_a']} fail with A only, {s['failed_only_b']} with B only "
        f"(exact McNemar, two-sided, p = {s['mcnemar_p']:.3g})"
    )
    if s["propellant_diff_ci_kg"] is not None:
        lo, hi = s["propellant_diff_ci_kg"]
        lines.append(
            f"propellant per run, B - A: {s['propellant_diff_kg']:.4g} kg "
            f"(t 95 % interval {lo:.4g} to {hi:.4g} kg)"
        )
    return lines


def write(result: dict, tmp: Path) -> None:
    """``divergence.csv``, ``summary.json``, ``summary.md`` into ``tmp``."""
    result["runs"].to_csv(tmp / "divergence.csv", index=False)
    (tmp / "summary.json").write_text(json.dumps(result["summary"], indent=2) + "\n")
    (tmp / "summary.md").write_text("\n\n".join(summary_lines(result["summary"])) + "\n")
