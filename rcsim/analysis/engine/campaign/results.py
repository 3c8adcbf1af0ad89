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
import sys
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from rcsim.analysis.engine.campaign.case_means import CASE_MEANS, mean_sums, means_with_intervals
from rcsim.analysis.engine.campaign.case_means import PREFIX as MEAN_PREFIX
from rcsim.analysis.engine.runs_table import (
    CASES,
    CHUNKS,
    ENVELOPES,
    HISTORIES,
    MANIFEST,
    PLOTS,
    RUNS,
    run_columns,
)
from rcsim.models.atomic import atomic_write, remove_temporaries
from rcsim.spacecraft.vehicle.model import AXES


def now_utc() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


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


def remove_temporaries_in(out: Path) -> list[Path]:
    """Remove the atomic-write temporaries a killed campaign left in ``out`` and its
    sub-directories (the campaign, run by this process, owns every file there)."""
    removed = []
    for folder in (out, out / CHUNKS, out / HISTORIES, out / PLOTS):
        removed += remove_temporaries(folder)
    return removed


def done_chunks(out: Path) -> set[str]:
    """Names (``FIRST-LAST``) of the chunks already committed in ``out``."""
    folder = out / CHUNKS
    if not folder.is_dir():
        return set()
    return {p.name[len("runs-") : -len(".parquet")] for p in folder.glob("runs-*.parquet")}


def code_version() -> dict:
    """Versions of rcsim (package and git commit, if a work tree) and of its engines."""
    import importlib.metadata as md

    import mujoco

    info = {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "mujoco": mujoco.__version__,
        "pandas": pd.__version__,
    }
    try:
        info["rcsim"] = md.version("rcsim")
    except md.PackageNotFoundError:
        info["rcsim"] = "unknown"
    root = Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5
        )
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
        )
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


# The runs.parquet columns the per-case statistics read (names from the schema).
_STAT_INPUTS = (
    "case",
    "case_index",
    "failed",
    "sim_failed",
    "firings_total",
    *(f"firings_to_rate_{a}" for a in AXES),
    *(f"final_rate_err_{a}_deg_s" for a in AXES),
    *CASE_MEANS,
)
assert set(_STAT_INPUTS) <= {c.name for c in run_columns(n_jets=1)}, (
    "per-case statistics read columns the schema lacks"
)
# Partial statistics are merged every this many chunks (and envelopes likewise): memory stays
# bounded by the number of cases, whatever the number of chunks.
MERGE_EVERY = 32
#: Columns renamed after campaigns were written with them (old name -> new name); read under
#: the new name on resume and by readers of older campaigns.
RENAMED_COLUMNS = {"settling_time_s": "rate_settled_time_s"}


def assemble(
    out: Path, plan: Iterable, *, n_chunks: int | None = None, progress: bool = False
) -> dict:
    """Stream the committed chunks into ``runs.parquet`` / ``envelopes.parquet`` / ``cases.csv``.

    Chunks are contiguous run-id ranges, so writing them in plan order sorts by run_id.  Only one
    chunk's rows are in memory at a time: each chunk is reduced to per-case statistics and its
    envelope as it is read, and those are merged every :data:`MERGE_EVERY` chunks, so peak
    memory grows with the number of cases, not of runs or chunks.

    Parameters
    ----------
    out : Path
        Campaign directory.
    plan : iterable of Chunk
        Every chunk of the campaign, in run-id order, all committed.
    n_chunks : int, optional
        Length of ``plan``, for the progress bar.
    progress : bool
        Progress bar on stderr.

    Returns
    -------
    dict
        Counts: ``runs``, ``failed``, ``sim_failed`` and per case ``by_case``.
    """
    from tqdm import tqdm

    from rcsim.analysis.engine.campaign.chunk import combine_envelopes

    writer = None
    stats: list[pd.DataFrame] = []
    envelopes: list[pd.DataFrame] = []
    rows = 0
    tmp = out / f".{RUNS}.tmp"
    try:
        for chunk in tqdm(
            plan,
            total=n_chunks,
            unit="chunk",
            desc="assembling",
            disable=not progress,
            file=sys.stderr,
            dynamic_ncols=True,
            leave=False,
        ):
            table = pq.read_table(out / CHUNKS / f"runs-{chunk.name}.parquet")
            table = _renamed(table)
            if writer is None:
                writer = pq.ParquetWriter(tmp, table.schema)
            writer.write_table(table.cast(writer.schema))
            rows += table.num_rows
            stats.append(case_stats(table.select(list(_STAT_INPUTS)).to_pandas()))
            env = out / CHUNKS / f"envelope-{chunk.name}.parquet"
            if env.exists():
                envelopes.append(pd.read_parquet(env))
            if len(stats) >= MERGE_EVERY:
                stats = [merge_case_stats(stats)]
            if len(envelopes) >= MERGE_EVERY:
                envelopes = [combine_envelopes(envelopes)]
        if writer is not None:
            writer.close()
            writer = None
        os.replace(tmp, out / RUNS)
    finally:
        if writer is not None:
            writer.close()
        if tmp.exists():
            tmp.unlink()
    cases = finish_case_stats(merge_case_stats(stats)) if stats else pd.DataFrame()
    if int(cases["runs"].sum() if len(cases) else 0) != rows:  # the bug this layout once had
        raise AssertionError(
            f"cases.csv counts {int(cases['runs'].sum())} runs, runs.parquet has {rows}"
        )
    atomic_write(out / CASES, lambda t: cases.to_csv(t, index=False, float_format="%.6g"))
    if envelopes:
        env = combine_envelopes(envelopes)
        for col in [c for c in env.columns if c.endswith("_sum") and not c.startswith("on_time")]:
            env[col[:-4] + "_mean"] = env[col] / env["n_runs"]
            env = env.drop(columns=col)
        write_frame(env, out / ENVELOPES)
    counts: dict = {"runs": rows}
    counts["failed"] = int(cases["failed"].sum()) if len(cases) else 0
    counts["sim_failed"] = int(cases["sim_failed"].sum()) if len(cases) else 0
    counts["by_case"] = {
        row.case: {"runs": int(row.runs), "failed": int(row.failed)} for row in cases.itertuples()
    }
    return counts


def _renamed(table: pa.Table) -> pa.Table:
    """A chunk written before a column's rename, under today's names (with its metadata)."""
    if not any(n in RENAMED_COLUMNS for n in table.column_names):
        return table
    meta = table.schema.metadata or {}
    for old, new in RENAMED_COLUMNS.items():
        meta = {k: v.replace(f'"{old}"'.encode(), f'"{new}"'.encode()) for k, v in meta.items()}
    table = table.rename_columns([RENAMED_COLUMNS.get(n, n) for n in table.column_names])
    return table.replace_schema_metadata(meta)


_ADDITIVE = (
    "runs",
    "failed",
    "sim_failed",
    "firings_sum",
    "firings_to_rate_sum",
    "one_firing_runs",
)


def case_stats(runs: pd.DataFrame) -> pd.DataFrame:
    """Additive per-case statistics of run rows (columns :data:`_STAT_INPUTS`), one row per
    case; partial statistics of disjoint runs merge with :func:`merge_case_stats`."""
    to_rate = runs[[f"firings_to_rate_{a}" for a in AXES]]
    rate = runs[[f"final_rate_err_{a}_deg_s" for a in AXES]].abs().max(axis=1)
    work = pd.DataFrame(
        {
            "case_index": runs["case_index"],
            "case": runs["case"],
            "runs": 1,
            "failed": runs["failed"].astype(int),
            "sim_failed": runs["sim_failed"].astype(int),
            "firings_sum": runs["firings_total"].fillna(0),
            "firings_max": runs["firings_total"],
            "firings_to_rate_sum": to_rate.max(axis=1).fillna(0),
            # "one firing reaches the rate" (Fig 10): no axis needed more than one firing event.
            "one_firing_runs": (to_rate.max(axis=1) <= 1).astype(int),
            "max_abs_final_rate_err_deg_s": rate,
        }
    )
    return merge_case_stats([pd.concat([work, mean_sums(runs)], axis=1)])


def merge_case_stats(parts: list[pd.DataFrame]) -> pd.DataFrame:
    """Merge per-case statistics (of :func:`case_stats`, or merged ones): sums of the additive
    columns, maxima of the maxima.  Every part must have the same columns."""
    frame = pd.concat(parts, ignore_index=True)
    g = frame.groupby(["case_index", "case"], as_index=False, sort=True)
    merged = g[list(_ADDITIVE) + [c for c in frame.columns if c.startswith(MEAN_PREFIX)]].sum()
    merged["firings_max"] = g["firings_max"].max()["firings_max"]
    merged["max_abs_final_rate_err_deg_s"] = g["max_abs_final_rate_err_deg_s"].max()[
        "max_abs_final_rate_err_deg_s"
    ]
    return merged


def finish_case_stats(stats: pd.DataFrame) -> pd.DataFrame:
    """The cases.csv table from merged per-case statistics."""
    if stats.empty:
        return stats
    out = stats[["case_index", "case", "runs", "failed", "sim_failed"]].copy()
    out["failed_pct"] = 100.0 * stats["failed"] / stats["runs"]
    out["firings_per_run_mean"] = stats["firings_sum"] / stats["runs"]
    out["firings_per_run_max"] = stats["firings_max"]
    out["firings_to_rate_mean"] = stats["firings_to_rate_sum"] / stats["runs"]
    out["one_firing_pct"] = 100.0 * stats["one_firing_runs"] / stats["runs"]
    out["max_abs_final_rate_err_deg_s"] = stats["max_abs_final_rate_err_deg_s"]
    out = pd.concat([out, means_with_intervals(stats)], axis=1)
    return out.sort_values("case_index").reset_index(drop=True)


def read_manifest(out: Path) -> dict | None:
    path = out / MANIFEST
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
