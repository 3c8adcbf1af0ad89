"""Run a campaign: plan chunks, fly them locally or on Dask, stream results to disk, resume.

Execution modes (same results in all; only speed differs):

* local (default): ``local_workers`` chunks in flight (default one per CPU), each in its own
  worker process with one MuJoCo thread (:mod:`~rcsim.analysis.engine.campaign.local`: the
  control cycle's numpy work of one chunk then never waits for another's); with one worker,
  in this process on MuJoCo's own thread pool.
* ``workers=N``: a local Dask cluster, ``LocalCluster(n_workers=N, threads_per_worker=1)``.
* ``scheduler=ADDRESS``: an existing Dask cluster (workers must see the same files: the
  lookup table path, and rcsim installed).  Dask mode lives in
  :mod:`~rcsim.analysis.engine.campaign.cluster`.

Tasks return DataFrames; only this process writes to ``DIR``.  At most a bounded number of
chunks is in flight, and the plan is generated lazily, so memory does not grow with the
campaign.

Interrupts.  KeyboardInterrupt (Ctrl-C) -- and SIGTERM, which is turned into one (its
subclass :class:`~rcsim.analysis.engine.interrupts.Terminated`, so that a caller can tell them
apart) while a campaign runs in the main thread -- stops the campaign promptly: chunks in flight are
abandoned (local: at their next control cycle; Dask: cancelled), nothing is waited for, the
Dask cluster is closed with its loggers silenced, and the KeyboardInterrupt propagates for the
caller to report in one line.  Chunks commit atomically, so the directory is left resumable.
Local Dask workers are started with SIGINT ignored: a terminal's Ctrl-C reaches the whole
process group, and it is this process that stops them.
"""

from __future__ import annotations

import os
import shutil
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from rcsim.analysis.engine import runs_table
from rcsim.analysis.engine.campaign import results as R
from rcsim.analysis.engine.campaign.chunk import add_counts, iter_chunks
from rcsim.analysis.engine.campaign.cluster import (
    check_workers_controller,
    close,
    connect,
    dask_results,
)
from rcsim.analysis.engine.campaign.effects import describe
from rcsim.analysis.engine.campaign.gate import GateResult, judge
from rcsim.analysis.engine.campaign.local import local_results
from rcsim.analysis.engine.campaign.motion import budget_thresholds
from rcsim.analysis.engine.campaign.spec import CampaignSpec, failure_note
from rcsim.analysis.engine.interrupts import raise_if_interrupted, sigterm_interrupts
from rcsim.analysis.engine.output import check_out_dir, output_lock, write_marker
from rcsim.analysis.engine.runs_table import all_columns
from rcsim.lookup.registry import is_plugin
from rcsim.models.errors import InputError

COMMAND = "campaign run"  # recorded in the directory's marker (rcsim.analysis.engine.output)


@dataclass
class CampaignReport:
    """What :func:`run_campaign` did.

    ``wall_s`` is the whole session; ``fly_s`` the part spent flying chunks (what a runs/s
    rate means), the rest is start-up, assembly and plots.  ``gate`` is the failure gate's
    verdict (None: the spec has no ``max_failed_pct``).
    """

    out: Path
    counts: dict
    wall_s: float
    runs_flown: int
    simulated_s: float
    resumed_chunks: int = 0
    mode: str = "local"
    notes: list = field(default_factory=list)
    fly_s: float = 0.0
    gate: GateResult | None = None


def _row_bytes(n_jets: int) -> int:
    """Bytes a run's row takes in runs.parquet, at most: 8 per column (numbers are float64 or
    int64 and do not compress; the reason strings are mostly empty), with every optional
    effect column (an upper bound), for a vehicle of ``n_jets`` jets."""
    return 8 * len(all_columns(n_jets))


def _history_row_bytes(n_jets: int) -> int:
    """Per kept history, per control cycle: the history frame's columns
    (:func:`rcsim.analysis.engine.flight.history_frame`: time, 12 per-axis columns, 6 measured
    ones, an on-time and a delivered time per jet), float64: an upper bound."""
    return 8 * (1 + 12 + 6 + 2 * n_jets)


def check_fits(spec: CampaignSpec, out: Path) -> None:
    """Refuse, before anything is written, a campaign whose results cannot fit on the disk of
    ``out`` (runs.parquet, and per-run histories when the spec keeps them all).

    Raises
    ------
    InputError
        Naming the spec's ``runs_per_case``, the estimate and the free space.
    """
    from rcsim.spacecraft.guards import human_bytes

    row = _row_bytes(spec.n_jets)
    need = spec.n_runs * row
    if spec.histories in ("all", "first"):
        cycle_s = spec.cycle_s
        per_case = (
            spec.runs_per_case if spec.histories == "all" else min(spec.first_k, spec.runs_per_case)
        )
        need += sum(
            per_case * int(case.duration_s / cycle_s + 1) * _history_row_bytes(spec.n_jets)
            for case in spec.cases
        )
    ancestor = out
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    try:
        free = shutil.disk_usage(ancestor).free
    except OSError:
        return  # unknown: the write itself will report a full disk
    if need > free:
        kept = ", plus kept histories" if spec.histories in ("all", "first") else ""
        raise InputError(
            f"{spec.source}: runs_per_case = {spec.runs_per_case}: the campaign's "
            f"{spec.n_runs:,} runs need about {human_bytes(need)} of results "
            f"({row} bytes per run{kept}), "
            f"but only {human_bytes(free)} is free where {out} would be written"
        )


def _prepare_dir(spec: CampaignSpec, out: Path, resume: bool) -> tuple[dict | None, bool]:
    """Check ``out`` before any work; return (existing manifest, already complete)."""
    # overwrite=True lets an earlier campaign's directory through; it is resumed or refused
    # below, never replaced.
    check_out_dir(out, COMMAND, overwrite=True)
    if not out.exists() or not any(out.iterdir()) or _killed_before_its_manifest(out):
        check_fits(spec, out)
        return None, False
    manifest = R.read_manifest(out)
    if manifest is None:
        raise InputError(
            f"{out}: exists and is not a campaign directory (no readable "
            f"{runs_table.MANIFEST}); choose a new directory",
            parameter="out",
            value=str(out),
        )
    if not resume:
        raise InputError(
            f"{out}: holds a campaign ({manifest.get('status', 'unknown')}); "
            "resume it to finish it, or choose a new directory",
            parameter="out",
            value=str(out),
        )
    if manifest.get("spec_sha256") != spec.digest():
        diff = _first_difference(manifest.get("spec"), spec.resolved)
        raise InputError(
            f"{out}: the spec differs from the one this directory was started with"
            + (f" ({diff})" if diff else " (compare its manifest.json 'spec')")
            + "; resume with that spec, or choose a new directory",
            parameter="out",
            value=str(out),
        )
    return manifest, manifest.get("status") == "complete"


def _killed_before_its_manifest(out: Path) -> bool:
    """A campaign stopped before its manifest: its marker and empty folders, nothing flown
    (the manifest is written before the first chunk): it starts again from nothing."""
    from rcsim.analysis.engine.output import MARKER, directory_owner
    from rcsim.models.atomic import TEMP_GLOB

    if directory_owner(out) != COMMAND or (out / runs_table.MANIFEST).exists():
        return False
    temporaries = set(out.glob(TEMP_GLOB))
    for entry in out.iterdir():
        if entry.name in (runs_table.CHUNKS, runs_table.HISTORIES) and entry.is_dir():
            if any(entry.iterdir()):
                return False
        elif entry.name != MARKER and entry not in temporaries:
            return False
    return True


def _first_difference(stored, current, path: str = "") -> str:
    """The first setting that differs between two resolved specs, as ``key: A there, B
    here`` (``""`` when none is found, e.g. only the code version changed the digest)."""
    if isinstance(stored, dict) and isinstance(current, dict):
        for key in list(current) + [k for k in stored if k not in current]:
            found = _first_difference(stored.get(key), current.get(key), f"{path}{key}.")
            if found:
                return found
        return ""
    if stored != current:
        return f"{path.rstrip('.')}: {stored!r} there, {current!r} here"
    return ""


def _new_manifest(spec: CampaignSpec, spec_file: str | None) -> dict:
    return {
        "format": "rcsim-campaign/1",
        "spec_file": None if spec_file is None else str(Path(spec_file).absolute()),
        "spec": spec.resolved,
        "spec_sha256": spec.digest(),
        "run_id_scheme": "run_id = case_index * runs_per_case + k, k = 0..runs_per_case-1; "
        "run i draws from SeedSequence(seed, spawn_key=(i,)).spawn(2)"
        "[0] (dispersions)",
        "thresholds": {
            "rate_error_deg_s": spec.resolved["failure"]["rate_error_deg_s"],
            "attitude_error_deg": spec.resolved["failure"].get("attitude_error_deg"),
            **budget_thresholds(spec.resolved["failure"]),
            "source": spec.failure_source,
        },
        "cases": [c.name for c in spec.cases],
        "started_utc": R.now_utc(),
        "status": "running",
    }


def run_campaign(
    spec: CampaignSpec,
    out: str | os.PathLike,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    local_workers: int | None = None,
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
    local_workers : int, optional
        Local mode: chunks in flight, each in a worker process when more than one (default:
        the CPU count).
    progress : bool, optional
        Progress bars (flying, assembling) and a status line for plotting, on stderr; default
        only when stderr is a terminal.

    Returns
    -------
    CampaignReport
        With ``gate`` (:class:`~rcsim.analysis.engine.campaign.gate.GateResult`) when the spec has a
        failure gate (``spec.max_failed_pct``), also for an already complete campaign; the
        gate is recorded in ``manifest.json`` when this call completes the campaign.

    Raises
    ------
    KeyboardInterrupt
        Ctrl-C or SIGTERM (:class:`rcsim.analysis.engine.interrupts.Terminated`): the campaign
        stopped promptly; ``out`` is resumable.
    """
    out = Path(out)
    if progress is None:
        progress = sys.stderr.isatty()
    # One writer at a time: a second `campaign run` (or --resume) on the same directory
    # is refused before it reads the manifest, not after both have flown.
    check_out_dir(out, COMMAND, overwrite=True)  # an impossible path: its own error, first
    with output_lock(out, COMMAND):
        manifest, complete = _prepare_dir(spec, out, resume)
        if complete and manifest is not None:
            R.remove_temporaries_in(out)
            counts = manifest.get("counts", {})
            return CampaignReport(
                out,
                counts,
                0.0,
                0,
                0.0,
                notes=["campaign already complete; nothing to do"],
                gate=_gate(spec, counts),
            )
        with sigterm_interrupts():
            client, cluster = connect(workers, scheduler)  # before creating DIR: no debris
            try:
                if client is not None and is_plugin(spec.controller):
                    check_workers_controller(client, spec)
                report = _run(
                    spec,
                    out,
                    manifest,
                    resume,
                    client,
                    cluster,
                    workers,
                    local_workers,
                    progress,
                    spec_file,
                )
            except KeyboardInterrupt:
                close(client, cluster, kill=True)  # interrupted: no worker is waited for
                raise
            except BaseException:
                close(client, cluster)
                raise
            close(client, cluster)
            return report


def _run(
    spec: CampaignSpec,
    out,
    manifest,
    resume,
    client,
    cluster,
    workers,
    local_workers,
    progress,
    spec_file,
) -> CampaignReport:
    t0 = time.perf_counter()
    # The marker first, before anything else is in the directory: killed at any later point,
    # it is a campaign's, which no other command replaces (rcsim.analysis.engine.output).
    out.mkdir(parents=True, exist_ok=True)
    write_marker(out, COMMAND)
    for sub in (runs_table.CHUNKS, runs_table.HISTORIES):
        (out / sub).mkdir(exist_ok=True)
    # A campaign killed mid-write (SIGKILL) left its temporaries: this process owns them now.
    R.remove_temporaries_in(out)
    manifest = manifest or _new_manifest(spec, spec_file)
    manifest["code_version"] = R.code_version()
    manifest["control_cycle_s"] = spec.cycle_s  # the cycle every chunk's History flies
    if spec.controller in ("lookup", "adaptive") and spec.table is None:
        manifest["lookup_default_table"] = R.default_lookup_table()
    # In words, beside the spec (whose resolved form stays as it was: its digest is what a
    # resume compares): which table "default" meant, and the vehicle file's own name.
    manifest["dispersions_source"] = runs_table.dispersions_source(spec.resolved)
    # The vehicle flown and its flight-software profile, named (the spec resolves the vehicle
    # file and its sha256 only when it names one; the profile is what every controller flew).
    manifest["vehicle_name"] = spec.vehicle.name
    manifest["vehicle_ref"] = spec.vehicle.ref
    manifest["vehicle_sha256"] = spec.vehicle.sha256
    manifest["control_profile"] = spec.vehicle.control.record()
    if resume and manifest.get("status") == "running":
        manifest.setdefault("resumed_utc", []).append(R.now_utc())
    R.write_json(manifest, out / runs_table.MANIFEST)

    done = R.done_chunks(out)
    n_chunks = n_done = n_done_chunks = 0
    for c in iter_chunks(spec):  # one pass, nothing kept: the plan may be millions of chunks
        n_chunks += 1
        if c.name in done:
            n_done += c.stop - c.first
            n_done_chunks += 1
    todo = (c for c in iter_chunks(spec) if c.name not in done)
    mode = "local" if client is None else ("dask-local" if cluster is not None else "dask")
    cancel = threading.Event()
    if client is None:
        results = local_results(
            spec, todo, local_workers or os.cpu_count() or 1, n_chunks - n_done_chunks, cancel
        )
    else:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})) or (workers or 1))
        results = dask_results(spec, todo, client, in_flight=2 * n_workers)
    try:
        flown, simulated, fly_s, solver = _drain(results, out, spec, n_done, progress)
    finally:
        cancel.set()  # stop local chunks in flight (none are, after a normal finish)
        results.close()  # an interrupt inside _drain: the generator cancels what it started
    counts = R.assemble(out, iter_chunks(spec), n_chunks=n_chunks, progress=progress)
    if spec.plots:
        from rcsim.analysis.engine.campaign.plots import plot_campaign

        if progress:
            print("campaign: plotting ...", file=sys.stderr, flush=True)
        plot_campaign(out, spec)
    wall = time.perf_counter() - t0
    manifest.update(
        status="complete",
        finished_utc=R.now_utc(),
        counts=counts,
        histories_kept=sum(1 for _ in (out / runs_table.HISTORIES).glob("run-*.parquet")),
    )
    manifest["last_session"] = {
        "mode": mode,
        "runs_flown": flown,
        "fly_s": round(fly_s, 3),
        "wall_s": round(wall, 3),
    }
    if solver:
        # The controller's solver work (the allocator's LPs, searches and exact solves),
        # summed over this session's chunks and added to earlier sessions' (a resume).
        manifest["last_session"]["solver_counts"] = solver
        manifest["solver_counts"] = add_counts([manifest.get("solver_counts", {}), solver])
    gate = _gate(spec, counts)
    if gate is not None:
        manifest["gate"] = gate.to_json()
    else:
        manifest.pop("gate", None)  # an earlier session's verdict is not this one's
    R.write_json(manifest, out / runs_table.MANIFEST)
    shutil.rmtree(out / runs_table.CHUNKS, ignore_errors=True)
    R.remove_temporaries_in(out)
    return CampaignReport(
        out, counts, wall, flown, simulated, n_done_chunks, mode, fly_s=fly_s, gate=gate
    )


def _gate(spec: CampaignSpec, counts: dict) -> GateResult | None:
    return None if spec.max_failed_pct is None else judge(counts, spec.max_failed_pct)


def _drain(
    results, out: Path, spec: CampaignSpec, n_done: int, progress: bool
) -> tuple[int, float, float, dict]:
    """Commit each finished chunk; progress bar with runs done, runs/s and ETA.

    Returns
    -------
    (runs flown, simulated seconds, wall seconds spent flying, the chunks' solver counts
    summed)
    """
    from tqdm import tqdm

    t0 = time.perf_counter()
    flown, simulated = 0, 0.0
    solver: dict = {}
    with tqdm(
        total=spec.n_runs,
        initial=n_done,
        unit="run",
        disable=not progress,
        file=sys.stderr,
        dynamic_ncols=True,
        smoothing=0.1,
        desc="flying",
    ) as bar:
        for result in results:
            R.commit_chunk(out, result)
            solver = add_counts([solver, result.solver])
            for line in result.crashes:  # flight software that crashed its process
                bar.write(f"rcsim: warning: {line}", file=sys.stderr)
            # An interrupt a library swallowed (rcsim.analysis.engine.interrupts) stops it here.
            raise_if_interrupted()
            n = result.chunk.stop - result.chunk.first
            flown += n
            # A chunk's runs all last equally long (plan_chunks).
            simulated += n * spec.cases[spec.case_of(result.chunk.first)].duration_s
            bar.update(n)
    return flown, simulated, time.perf_counter() - t0, solver


def failure_words(spec: CampaignSpec) -> str:
    """Every criterion that fails a run of ``spec`` (those of
    :func:`rcsim.analysis.engine.campaign.outcomes.outcomes`), in words with its threshold."""
    failure = spec.resolved["failure"]
    words = [f"final |rate error| >= {failure['rate_error_deg_s']} deg/s"]
    if "attitude_error_deg" in failure:
        words.append(f"final attitude error > {failure['attitude_error_deg']:g} deg")
    loaded = spec.vehicle.definition.propellant_kg
    if loaded is not None:  # the vehicle's tank is tracked: running dry fails the run
        words.append(f"propellant exhausted ({loaded:g} kg loaded)")
    words += [
        f"{failure[k]:g} {unit} exceeded ({k})"
        for k, unit in (("max_propellant_kg", "kg"), ("max_delta_v_m_s", "m/s"))
        if k in failure
    ]
    return ", or ".join(words)


def summary_text(report: CampaignReport, spec: CampaignSpec) -> str:
    """The end-of-campaign summary: runs, failures by case, time."""
    import pandas as pd

    lines = []
    c = report.counts
    lines.extend(report.notes)
    if report.runs_flown:
        fly = report.fly_s if report.fly_s > 0 else report.wall_s
        rate = report.runs_flown / fly if fly > 0 else float("nan")
        lines.append(
            f"flew {report.runs_flown} runs in {fly:.1f} s ({rate:.1f} runs/s, "
            f"{report.simulated_s / max(fly, 1e-9):.0f} simulated s per s, "
            f"{report.mode})"
            + (
                f"; {report.resumed_chunks} chunks were already done"
                if report.resumed_chunks
                else ""
            )
            + f"; {report.wall_s:.1f} s in all with start-up, assembly and plots"
        )
    lines.append(
        f"{c.get('runs', 0)} runs, {c.get('failed', 0)} failed "
        f"({c.get('sim_failed', 0)} simulation failures); controller {spec.controller}, "
        f"failure: {failure_words(spec)}" + (f" ({note})" if (note := failure_note(spec)) else "")
    )
    effects = describe(spec.effects)
    if effects:
        lines.append(f"with {effects}")
    cases_csv = report.out / runs_table.CASES
    if cases_csv.exists():
        cases = pd.read_csv(cases_csv)
        lines.append("case        runs  failed  firings/run  one-firing %")
        for row in cases.itertuples():
            lines.append(
                f"{row.case:<10} {row.runs:5d}  {row.failed:6d}  "
                f"{row.firings_per_run_mean:11.2f}  {row.one_firing_pct:12.1f}"
            )
    lines.append(f"results in {report.out}/")
    return "\n".join(lines)
