"""A campaign directory on disk: chunk files, the assembled tables, the manifest.

Layout of ``DIR/``::

    manifest.json          spec (resolved), code version, times, counts, status
    runs.parquet           one row per run, sorted by run_id        (when complete)
    envelopes.parquet      per case and cycle: min / max / mean over runs (when complete)
    cases.csv              per-case summary: runs, failures, firings  (when complete)
    histories/run-NNNNNNN.parquet   kept per-run histories
    plots/                 Fig 9-14-like plots
    chunks/                results of finished chunks while the campaign runs
                           (runs-FIRST-LAST.parquet, envelope-FIRST-LAST.parquet)

A chunk is committed by the atomic rename of its ``runs-`` file, written last; everything a
chunk wrote before that (histories, envelope) is simply rewritten if the chunk is redone.
Everything is Parquet, CSV or JSON: readable with plain pandas or duckdb, no pickles.
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from rcsim.models.atomic import atomic_write

MANIFEST = "manifest.json"
RUNS = "runs.parquet"
ENVELOPES = "envelopes.parquet"
CASES = "cases.csv"
CHUNKS = "chunks"
HISTORIES = "histories"
PLOTS = "plots"


def now_utc() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def write_frame(frame: pd.DataFrame, path: Path) -> None:
    """Parquet without the pandas index, atomically."""
    table = pa.Table.from_pandas(frame, preserve_index=False)
    atomic_write(path, lambda tmp: pq.write_table(table, tmp))


def write_json(obj: dict, path: Path) -> None:
    atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(obj, indent=2) + "\n"))


def history_path(out: Path, run_id: int) -> Path:
    return out / HISTORIES / f"run-{run_id:07d}.parquet"


def commit_chunk(out: Path, result) -> None:
    """Write a finished chunk: histories, envelope, then its runs file (the commit)."""
    for run_id, frame in result.histories.items():
        write_frame(frame, history_path(out, run_id))
    name = result.chunk.name
    if not result.envelope.empty:
        write_frame(result.envelope, out / CHUNKS / f"envelope-{name}.parquet")
    write_frame(result.runs, out / CHUNKS / f"runs-{name}.parquet")


def done_chunks(out: Path) -> set[str]:
    """Names (``FIRST-LAST``) of the chunks already committed in ``out``."""
    folder = out / CHUNKS
    if not folder.is_dir():
        return set()
    return {p.name[len("runs-"):-len(".parquet")] for p in folder.glob("runs-*.parquet")}


def code_version() -> dict:
    """Versions of rcsim (package and git commit, if a work tree) and of its engines."""
    import importlib.metadata as md

    import mujoco

    info = {"python": platform.python_version(), "numpy": np.__version__,
            "mujoco": mujoco.__version__, "pandas": pd.__version__}
    try:
        info["rcsim"] = md.version("rcsim")
    except md.PackageNotFoundError:
        info["rcsim"] = "unknown"
    root = Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                                text=True, timeout=5)
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5)
        info["git_commit"] = commit.stdout.strip() if commit.returncode == 0 else "none"
        info["git_dirty"] = bool(dirty.stdout.strip()) if dirty.returncode == 0 else None
    except (OSError, subprocess.SubprocessError):
        info["git_commit"] = "unknown"
    return info


def default_lookup_table() -> dict:
    """Which file the lookup controller's "default" table is right now, and its SHA-256.

    The packaged default can change (a regenerated table); recording it lets a reader tell
    whether a later replay flies the same table.
    """
    import hashlib

    from rcsim.lookup.pattern_recognition import default_table_path

    path = default_table_path()
    return {"path": str(path), "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}


def assemble(out: Path, plan) -> dict:
    """Stream the committed chunks into ``runs.parquet`` / ``envelopes.parquet`` / ``cases.csv``.

    Chunks are contiguous run-id ranges, so writing them in plan order sorts by run_id.  Only one
    chunk is in memory at a time (peak memory does not grow with the number of runs).

    Returns
    -------
    dict
        Counts: ``runs``, ``failed``, ``sim_failed`` and per case ``by_case``.
    """
    writer = None
    counts: dict = {}
    cols = ["case", "case_index", "failed", "sim_failed", "firings_total",
            "firings_to_rate_roll", "firings_to_rate_pitch", "firings_to_rate_yaw",
            "final_rate_err_roll_deg_s", "final_rate_err_pitch_deg_s", "final_rate_err_yaw_deg_s"]
    per_case = []
    envelopes = []
    tmp = out / f".{RUNS}.tmp"
    try:
        for chunk in plan:
            table = pq.read_table(out / CHUNKS / f"runs-{chunk.name}.parquet")
            if writer is None:
                writer = pq.ParquetWriter(tmp, table.schema)
            writer.write_table(table.cast(writer.schema))
            per_case.append(table.select(cols).to_pandas())
            env = out / CHUNKS / f"envelope-{chunk.name}.parquet"
            if env.exists():
                envelopes.append(pd.read_parquet(env))
            if len(per_case) > 64:  # keep the small per-case table small too
                per_case = [_case_stats(pd.concat(per_case))]
        if writer is not None:
            writer.close()
            writer = None
        os.replace(tmp, out / RUNS)
    finally:
        if writer is not None:
            writer.close()
        if tmp.exists():
            tmp.unlink()
    cases = _case_stats(pd.concat(per_case)) if per_case else pd.DataFrame()
    cases = _finish_case_stats(cases)
    atomic_write(out / CASES, lambda t: cases.to_csv(t, index=False, float_format="%.6g"))
    if envelopes:
        from rcsim.analysis.campaign.chunk import _combine

        env = _combine(envelopes)
        for col in [c for c in env.columns if c.endswith("_sum") and not c.startswith("on_time")]:
            env[col[:-4] + "_mean"] = env[col] / env["n_runs"]
            env = env.drop(columns=col)
        write_frame(env, out / ENVELOPES)
    counts["runs"] = int(cases["runs"].sum()) if len(cases) else 0
    counts["failed"] = int(cases["failed"].sum()) if len(cases) else 0
    counts["sim_failed"] = int(cases["sim_failed"].sum()) if len(cases) else 0
    counts["by_case"] = {row.case: {"runs": int(row.runs), "failed": int(row.failed)}
                         for row in cases.itertuples()}
    return counts


def _case_stats(frame: pd.DataFrame) -> pd.DataFrame:
    """Additive per-case statistics (so partial results can be merged)."""
    if "runs" in frame.columns:  # already partial statistics: merge them
        g = frame.groupby(["case_index", "case"], as_index=False, sort=True)
        out = g[["runs", "failed", "sim_failed", "firings_sum", "firings_to_rate_sum",
                 "one_firing_runs"]].sum()
        out["firings_max"] = g["firings_max"].max()["firings_max"]
        out["max_abs_final_rate_err_deg_s"] = g["max_abs_final_rate_err_deg_s"].max()[
            "max_abs_final_rate_err_deg_s"]
        return out
    to_rate = frame[["firings_to_rate_roll", "firings_to_rate_pitch", "firings_to_rate_yaw"]]
    rate = frame[["final_rate_err_roll_deg_s", "final_rate_err_pitch_deg_s",
                  "final_rate_err_yaw_deg_s"]].abs().max(axis=1)
    work = pd.DataFrame({
        "case_index": frame["case_index"], "case": frame["case"], "runs": 1,
        "failed": frame["failed"].astype(int), "sim_failed": frame["sim_failed"].astype(int),
        "firings_sum": frame["firings_total"].fillna(0),
        "firings_max": frame["firings_total"],
        "firings_to_rate_sum": to_rate.max(axis=1).fillna(0),
        # "one firing reaches the rate" (Fig 10): no axis needed more than one firing event.
        "one_firing_runs": (to_rate.max(axis=1) <= 1).astype(int),
        "max_abs_final_rate_err_deg_s": rate,
    })
    return _case_stats(work)


def _finish_case_stats(stats: pd.DataFrame) -> pd.DataFrame:
    if stats.empty:
        return stats
    out = stats[["case_index", "case", "runs", "failed", "sim_failed"]].copy()
    out["failed_pct"] = 100.0 * stats["failed"] / stats["runs"]
    out["firings_per_run_mean"] = stats["firings_sum"] / stats["runs"]
    out["firings_per_run_max"] = stats["firings_max"]
    out["firings_to_rate_mean"] = stats["firings_to_rate_sum"] / stats["runs"]
    out["one_firing_pct"] = 100.0 * stats["one_firing_runs"] / stats["runs"]
    out["max_abs_final_rate_err_deg_s"] = stats["max_abs_final_rate_err_deg_s"]
    return out.sort_values("case_index").reset_index(drop=True)


def read_manifest(out: Path) -> dict | None:
    path = out / MANIFEST
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
