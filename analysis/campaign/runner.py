"""Run a campaign: plan chunks, fly them locally or on Dask, stream results to disk, resume.

Execution modes (same results in all; only speed differs):

* local (default): one process; ``threads`` chunks in flight on a thread pool, each flown
  with one MuJoCo thread.  MuJoCo's batched rollout releases the GIL, so one chunk's physics
  overlaps another's numpy controller step (better than one chunk on MuJoCo's own pool, which
  idles during the Python part of each control cycle).
* ``workers=N``: a local Dask cluster, ``LocalCluster(n_workers=N, threads_per_worker=1)``.
* ``scheduler=ADDRESS``: an existing Dask cluster (workers must see the same files: the
  lookup table path, and rcsim installed).

Tasks return DataFrames; only this process writes to ``DIR``.  At most a bounded number of
chunks is in flight, so memory does not grow with the campaign.
"""
from __future__ import annotations

import os
import shutil
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path

from rcsim.analysis.campaign import results as R
from rcsim.analysis.campaign.chunk import plan_chunks, simulate_chunk
from rcsim.analysis.output import MARKER, check_out_dir
from rcsim.models.errors import InputError


@dataclass
class CampaignReport:
    """What :func:`run_campaign` did."""

    out: Path
    counts: dict
    wall_s: float
    runs_flown: int
    simulated_s: float
    resumed_chunks: int = 0
    mode: str = "local"
    notes: list = field(default_factory=list)


def _local_results(spec, chunks, threads: int):
    """Yield ChunkResults as chunks finish, up to ``threads`` chunks in flight.

    CPUs are shared out: with fewer chunks than threads, each chunk gets more MuJoCo threads.
    """
    cpus = os.cpu_count() or 1
    threads = max(1, min(threads, len(chunks)))
    nthread = max(1, cpus // threads)
    if threads == 1:
        for chunk in chunks:
            yield simulate_chunk(spec, chunk, nthread=nthread)
        return
    with ThreadPoolExecutor(max_workers=threads) as pool:
        pending, queue = set(), list(chunks)
        while queue or pending:
            while queue and len(pending) < threads:
                pending.add(pool.submit(simulate_chunk, spec, queue.pop(0), nthread))
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                yield fut.result()


def _dask_results(spec, chunks, client, in_flight: int):
    """Yield ChunkResults from a Dask client, at most ``in_flight`` tasks submitted."""
    from distributed import as_completed

    queue = list(chunks)
    submit = lambda c: client.submit(simulate_chunk, spec, c, 1, pure=False)  # noqa: E731
    futures = [submit(queue.pop(0)) for _ in range(min(in_flight, len(queue)))]
    pool = as_completed(futures)
    for fut in pool:
        result = fut.result()
        fut.release()
        if queue:
            pool.add(submit(queue.pop(0)))
        yield result


def connect(workers: int | None, scheduler: str | None):
    """A Dask client (and the cluster we started, to close), or (None, None) for local mode."""
    if workers is not None and scheduler is not None:
        raise InputError("--workers and --scheduler are exclusive: --workers starts a local cluster")
    if workers is None and scheduler is None:
        return None, None
    from distributed import Client, LocalCluster

    from rcsim.analysis.campaign.chunk import warm_up

    if workers is not None:
        if workers < 1:
            raise InputError(f"--workers must be >= 1, got {workers}")
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        cluster = None
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
    client.run(warm_up)
    return client, cluster


def _prepare_dir(spec, out: Path, resume: bool) -> tuple[dict | None, bool]:
    """Check ``out`` before any work; return (existing manifest, already complete)."""
    check_out_dir(out)
    if not out.exists() or not any(out.iterdir()):
        return None, False
    manifest = R.read_manifest(out)
    if not resume:
        raise InputError(f"--out {out}: exists and is not empty; use --resume to finish the "
                         "campaign in it, or choose a new directory")
    if manifest is None:
        raise InputError(f"--out {out}: not a campaign directory (no readable {R.MANIFEST})")
    if manifest.get("spec_sha256") != spec.digest():
        raise InputError(f"--resume {out}: the spec differs from the one this directory was "
                         "started with (compare its manifest.json 'spec')")
    return manifest, manifest.get("status") == "complete"


def run_campaign(
    spec,
    out: str | os.PathLike,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    threads: int | None = None,
    progress: bool | None = None,
    spec_file: str | None = None,
) -> CampaignReport:
    """Run (or finish) a campaign into directory ``out``.

    Parameters
    ----------
    spec : CampaignSpec
    out : path
        Campaign directory; must not exist (or be empty) unless ``resume``.
    workers, scheduler
        Dask execution (see the module docstring); default local.
    resume : bool
        Finish the campaign in ``out``: committed chunks are kept, the rest are flown.
    threads : int, optional
        Local mode: chunks in flight (default: CPU count).
    progress : bool, optional
        Progress bar on stderr; default only when stderr is a terminal.
    """
    out = Path(out)
    manifest, complete = _prepare_dir(spec, out, resume)
    if complete:
        return CampaignReport(out, manifest.get("counts", {}), 0.0, 0, 0.0,
                              notes=["campaign already complete; nothing to do"])
    client, cluster = connect(workers, scheduler)  # before creating DIR: a bad address leaves no debris
    t0 = time.perf_counter()
    try:
        for sub in (R.CHUNKS, R.HISTORIES):
            (out / sub).mkdir(parents=True, exist_ok=True)
        # analysis.output's marker: this directory is rcsim's (check_out_dir accepts it again).
        (out / MARKER).write_text("written by rcsim campaign run\n")
        manifest = manifest or {
            "format": "rcsim-campaign/1",
            "spec_file": None if spec_file is None else str(Path(spec_file).absolute()),
            "spec": spec.resolved,
            "spec_sha256": spec.digest(),
            "run_id_scheme": "run_id = case_index * runs_per_case + k, k = 0..runs_per_case-1; "
                             "run i draws from SeedSequence(seed, spawn_key=(i,)).spawn(2)"
                             "[0] (dispersions)",
            "thresholds": {"rate_error_deg_s": spec.resolved["failure"]["rate_error_deg_s"],
                           "attitude_error_deg": spec.resolved["failure"].get("attitude_error_deg")},
            "cases": [c.name for c in spec.cases],
            "started_utc": R.now_utc(),
            "status": "running",
        }
        manifest["code_version"] = R.code_version()
        if spec.controller == "lookup" and spec.table is None:
            manifest["lookup_default_table"] = R.default_lookup_table()
        if resume and manifest.get("status") == "running":
            manifest.setdefault("resumed_utc", []).append(R.now_utc())
        R.write_json(manifest, out / R.MANIFEST)

        plan = plan_chunks(spec)
        done = R.done_chunks(out)
        todo = [c for c in plan if c.name not in done]
        n_done = sum(c.stop - c.first for c in plan if c.name in done)
        mode = "local" if client is None else ("dask-local" if cluster is not None else "dask")
        if client is None:
            results = _local_results(spec, todo, threads or os.cpu_count() or 1)
        else:
            n_workers = max(1, len(client.scheduler_info().get("workers", {})) or (workers or 1))
            results = _dask_results(spec, todo, client, in_flight=2 * n_workers)
        flown, simulated = _drain(results, out, spec, n_done, progress)
        counts = R.assemble(out, plan)
        if spec.plots:
            from rcsim.analysis.campaign.plots import plot_campaign

            plot_campaign(out, spec)
        wall = time.perf_counter() - t0
        manifest.update(status="complete", finished_utc=R.now_utc(), counts=counts,
                        histories_kept=len(list((out / R.HISTORIES).glob("run-*.parquet"))))
        manifest["last_session"] = {"mode": mode, "runs_flown": flown, "wall_s": round(wall, 3)}
        R.write_json(manifest, out / R.MANIFEST)
        shutil.rmtree(out / R.CHUNKS, ignore_errors=True)
        return CampaignReport(out, counts, wall, flown, simulated, len(done), mode)
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


def _drain(results, out: Path, spec, n_done: int, progress: bool | None) -> tuple[int, float]:
    """Commit each finished chunk; progress bar with runs done, runs/s and ETA."""
    from tqdm import tqdm

    if progress is None:
        progress = sys.stderr.isatty()
    flown, simulated = 0, 0.0
    with tqdm(total=spec.n_runs, initial=n_done, unit="run", disable=not progress,
              file=sys.stderr, dynamic_ncols=True, smoothing=0.1, desc="campaign") as bar:
        for result in results:
            R.commit_chunk(out, result)
            n = result.chunk.stop - result.chunk.first
            flown += n
            # A chunk's runs all last equally long (plan_chunks).
            simulated += n * spec.cases[spec.case_of(result.chunk.first)].duration_s
            bar.update(n)
    return flown, simulated


def summary_text(report: CampaignReport, spec) -> str:
    """The end-of-campaign summary: runs, failures by case, time."""
    import pandas as pd

    lines = []
    c = report.counts
    lines.extend(report.notes)
    if report.runs_flown:
        rate = report.runs_flown / report.wall_s if report.wall_s > 0 else float("nan")
        lines.append(f"flew {report.runs_flown} runs in {report.wall_s:.1f} s ({rate:.1f} runs/s, "
                     f"{report.simulated_s / max(report.wall_s, 1e-9):.0f} simulated s per s, "
                     f"{report.mode})" + (f"; {report.resumed_chunks} chunks were already done"
                                          if report.resumed_chunks else ""))
    lines.append(f"{c.get('runs', 0)} runs, {c.get('failed', 0)} failed "
                 f"({c.get('sim_failed', 0)} simulation failures); controller {spec.controller}, "
                 f"failure: final |rate error| >= {spec.resolved['failure']['rate_error_deg_s']} deg/s")
    cases_csv = report.out / R.CASES
    if cases_csv.exists():
        cases = pd.read_csv(cases_csv)
        lines.append("case        runs  failed  firings/run  one-firing %")
        for row in cases.itertuples():
            lines.append(f"{row.case:<10} {row.runs:5d}  {row.failed:6d}  "
                         f"{row.firings_per_run_mean:11.2f}  {row.one_firing_pct:12.1f}")
    lines.append(f"results in {report.out}/")
    return "\n".join(lines)
