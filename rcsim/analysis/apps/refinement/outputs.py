"""Refinement outputs: the refined table, its changelog on the search and a fresh seed, plots.

``OUT.csv`` is a lookup table in the rcsim layout (loadable by ``--table``).
``OUT_changelog.csv`` has one row per searched case: the firing time per axis before and
after (control cycles and seconds); the evidence of the change (the paired McNemar test on the
search seed and on the confirmation seed, :mod:`rcsim.analysis.apps.refinement.gate`), its decision
and its mirror case's; failures and repeated-firing runs before and after on the search seed
and on the held-out seed no decision used, with Clopper-Pearson 95 % intervals.
``OUT_heldout.csv`` compares the original, the refined and (refining Table 6) the paper's
Table 7 on the held-out seed, failures with Clopper-Pearson 95 % intervals.  ``OUT_plots/``
holds the before/after plots (Figs 9-10 style).

Three seeds: the search seed ``S`` (decisions), the confirmation seed (the second gate;
default :func:`confirmation_seed`) and the held-out seed (default ``S + 1``, the report's
figures).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.evaluate import Trials, evaluate
from rcsim.analysis.apps.refinement.parameters import (
    check_parameters,
    confirmation_seed,
    held_out_seed,
    refinement_spec,
    refinement_vehicle,
)
from rcsim.analysis.apps.refinement.plots import (
    most_improved_case,
    plot_case_before_after,
    plot_failures_by_case,
)
from rcsim.analysis.apps.refinement.propellant import MAX_RISE, case_propellant, propellant_check
from rcsim.analysis.apps.refinement.regressions import find_regressions, regression_columns
from rcsim.analysis.apps.refinement.result import Refinement
from rcsim.analysis.apps.refinement.search import (
    SEARCH_RUNS_PER_CASE,
    RefineResult,
    refine,
)
from rcsim.analysis.engine.commit import commit_files
from rcsim.analysis.engine.output import atomic_dir, check_out_dir, check_out_file
from rcsim.analysis.engine.output_places import refuse_own_inputs
from rcsim.analysis.results.proportions import clopper_pearson
from rcsim.analysis.results.scoring import trial_scores
from rcsim.lookup.table_edits import axis_cycles, jet_axes
from rcsim.lookup.table_plugins import TablePlugin
from rcsim.models.atomic import atomic_write
from rcsim.models.tables import AXES, LookupTable
from rcsim.spacecraft.vehicle import Vehicle


def run_refinement(
    table: LookupTable,
    *,
    runs_per_case: int,
    seed: int,
    fresh_seed: int | None = None,
    cases=None,
    duration_s: float = 20.0,
    max_iterations: int = 8,
    search_runs_per_case: int = SEARCH_RUNS_PER_CASE,
    threads: int | None = None,
    progress: bool | None = None,
    checkpoint: str | Path | None = None,
    confirm_seed: int | None = None,
    compare_table7: bool | None = None,
    vehicle: Vehicle | str | None = None,
    max_propellant_rise: float = MAX_RISE,
    plugin: TablePlugin | None = None,
) -> Refinement:
    """Refine ``table`` on ``seed`` and fly the old and new tables on ``fresh_seed``.

    Parameters
    ----------
    table : LookupTable
    runs_per_case : int
        Dispersed runs of each case, 1 .. :data:`MAX_RUNS_PER_CASE`.
    seed, fresh_seed : int
        The search seed and the held-out seed (must differ), >= 0; default
        :func:`held_out_seed` of ``seed``.
    cases : sequence of int, optional
        Table rows (0-based) to refine; default all.
    duration_s : float
        Simulated time of every run [s].
    max_iterations : int
        Most rounds of candidates, >= 1.
    search_runs_per_case : int
        Runs per case the search flies: the first ones of each case's ``runs_per_case``
        (:func:`~rcsim.analysis.apps.refinement.search.refine`); the confirmation and the held-out
        check fly them all.
    confirm_seed : int, optional
        The confirmation seed (the second gate); default :func:`confirmation_seed`.
    compare_table7 : bool, optional
        Fly the paper's Table 7 on the held-out seed too; default: when ``table`` is Table 6.
    vehicle : Vehicle, str or path, optional
        The vehicle flown; default the paper's for a jet table, the one a channel table's
        recipe was solved for (:func:`~rcsim.analysis.apps.refinement.parameters.
        refinement_vehicle`).
    max_propellant_rise : float
        Largest rise of a case's mean propellant (a fraction, default 0.10) judged on failures
        alone (:mod:`~rcsim.analysis.apps.refinement.propellant`).
    plugin : TablePlugin, optional
        A plug-in flies every table instead of the built-in lookup controller
        (:mod:`rcsim.lookup.table_plugins`).

    Raises
    ------
    InputError
        A parameter out of range (named by ``parameter``).
    """
    fresh_seed = held_out_seed(seed) if fresh_seed is None else fresh_seed
    confirm_seed = confirmation_seed(seed, fresh_seed) if confirm_seed is None else confirm_seed
    flown, table_file = refinement_vehicle(table, vehicle)
    check_parameters(
        runs_per_case=runs_per_case,
        seed=seed,
        fresh_seed=fresh_seed,
        duration_s=duration_s,
        max_iterations=max_iterations,
        search_runs_per_case=search_runs_per_case,
        confirm_seed=confirm_seed,
        vehicle=flown,
    )
    spec = refinement_spec(
        runs_per_case=runs_per_case,
        seed=seed,
        duration_s=duration_s,
        vehicle=flown,
        table=table_file,
    )
    result = refine(
        spec,
        table,
        cases,
        max_iterations=max_iterations,
        threads=threads,
        progress=progress,
        search_runs_per_case=search_runs_per_case,
        checkpoint=checkpoint,
        confirm_seed=confirm_seed,
        max_propellant_rise=max_propellant_rise,
        plugin=plugin,
    )
    return held_out_check(
        table,
        result,
        seed=seed,
        fresh_seed=fresh_seed,
        runs_per_case=runs_per_case,
        duration_s=duration_s,
        threads=threads,
        progress=progress,
        compare_table7=compare_table7,
        confirm_seed=confirm_seed,
        vehicle=flown,
        table_file=table_file,
        max_propellant_rise=max_propellant_rise,
        plugin=plugin,
    )


def held_out_check(
    table: LookupTable,
    result: RefineResult,
    *,
    seed: int,
    fresh_seed: int,
    runs_per_case: int,
    duration_s: float = 20.0,
    fresh_after_runs: pd.DataFrame | None = None,
    threads: int | None = None,
    progress: bool | None = None,
    fresh_before_runs: pd.DataFrame | None = None,
    compare_table7: bool | None = None,
    confirm_seed: int | None = None,
    vehicle: Vehicle,
    table_file: str = "default",
    max_propellant_rise: float = MAX_RISE,
    drop_regressions: bool = False,
    further_seed: int | None = None,
    plugin: TablePlugin | None = None,
) -> Refinement:
    """Fly the old and the refined table on ``fresh_seed`` (the seed no decision used).

    Every searched case is compared on the same held-out runs (:mod:`~rcsim.analysis.apps.
    refinement.regressions`): a case significantly worse is a regression, and the changed rows
    that cause it are found by reverting each on that case's runs.  ``drop_regressions``:
    those rows go back to the original table's, and the original and the final table are
    flown again on ``further_seed`` (default one past every other seed), every case, which
    the changelog and :attr:`Refinement.further` report.

    ``fresh_after_runs`` / ``fresh_before_runs``: the refined / old table's runs on the fresh
    seed if a campaign already flew them
    (:func:`~rcsim.analysis.apps.refinement.evaluate.runs_from_campaign`); only the others are
    flown. ``compare_table7``: fly the paper's Table 7 on those runs too (default: when ``table`` is
    the packaged Table 6, the table the paper refined by hand).  ``vehicle`` and
    ``table_file``: what the refinement flew
    (:func:`~rcsim.analysis.apps.refinement.parameters.refinement_vehicle`).
    ``max_propellant_rise``: the propellant rule's limit; a changed row that does worse on
    this seed (more failures, or propellant beyond the limit without a paying failure gain)
    is marked "worse on held-out seed" (:func:`changelog`).
    """
    from rcsim.models.tables import load_lookup_table

    searched = result.before["case_index"].to_numpy()
    fresh = refinement_spec(
        runs_per_case=runs_per_case,
        seed=fresh_seed,
        duration_s=duration_s,
        vehicle=vehicle,
        table=table_file,
    )
    if compare_table7 is None:
        compare_table7 = is_table6(table)
    given = {"before": fresh_before_runs, "after": fresh_after_runs}
    tables = {"before": table, "after": result.table}
    if compare_table7:
        given["table7"] = None
        tables["table7"] = load_lookup_table(which="table7")
    to_fly = [k for k in tables if given[k] is None]
    scores_of = {k: trial_scores(v, searched.size) for k, v in given.items() if v is not None}
    runs_of = {k: v for k, v in given.items() if v is not None}
    if to_fly:
        trials = Trials(
            np.concatenate(
                [
                    np.repeat(np.asarray(tables[k].firing_time_s)[None], searched.size, 0)
                    for k in to_fly
                ]
            ),
            np.tile(searched, len(to_fly)),
            tuple(k for k in to_fly for _ in range(searched.size)),
        )
        runs = evaluate(
            fresh,
            table,
            trials,
            threads=threads,
            progress=progress,
            desc="refine: fresh seed",
            plugin=plugin,
        )
        scores = trial_scores(runs, trials.n_trials)
        for i, k in enumerate(to_fly):
            part = scores.iloc[i * searched.size : (i + 1) * searched.size]
            scores_of[k] = part.reset_index(drop=True)
            mine = runs[(runs["trial"] // searched.size) == i]
            runs_of[k] = mine.assign(trial=mine["trial"] - i * searched.size)
    fresh_before, fresh_after = scores_of["before"], scores_of["after"]
    log = changelog(table, result, fresh_before, fresh_after, vehicle.control.cycle_s)
    held_out_propellant(log, runs_of["before"], runs_of["after"], max_propellant_rise)
    fly: dict = dict(threads=threads, progress=progress, plugin=plugin)
    found = find_regressions(fresh, table, result.table, runs_of["before"], runs_of["after"], **fly)
    log = pd.concat(
        [log, regression_columns(found, searched, table.case).set_index(log.index)], axis=1
    )
    names = {"before": "Table 6 (paper)" if is_table6(table) else "original", "after": "refined"}
    if compare_table7:
        names["table7"] = "Table 7 (paper)"
    comparison = comparison_frame({names[k]: scores_of[k] for k in names}).assign(seed=fresh_seed)
    further = None
    if drop_regressions and found.rows_to_drop:
        further_seed = (
            max(seed, fresh_seed, confirm_seed if confirm_seed is not None else seed) + 1
            if further_seed is None
            else further_seed
        )
        result, further = _drop_and_check_again(
            table, result, found, log, fresh, further_seed, fresh_seed, fly
        )
        comparison = pd.concat(
            [comparison, further["comparison"].assign(seed=further_seed)], ignore_index=True
        )
    return Refinement(
        table,
        result,
        fresh_before,
        fresh_after,
        log,
        seed,
        fresh_seed,
        runs_per_case,
        duration_s,
        vehicle=vehicle,
        comparison=comparison,
        confirm_seed=confirm_seed,
        table_file=table_file,
        regressions=found.text(fresh_seed, table.case),
        further=further,
        plugin=plugin,
    )


def _drop_and_check_again(table, result, found, log, fresh, further_seed, fresh_seed, fly):
    """Revert the rows that cause held-out regressions (in ``result``'s table and in ``log``,
    in place), then fly the original and the final table on ``further_seed``, every searched
    case, and test every case again.  Returns the new result and the further check: its
    seed, comparison rows, per-case regressions (text) and failed runs."""
    from dataclasses import replace

    from rcsim.lookup.table_edits import with_times

    old = np.asarray(table.firing_time_s, float)
    final = np.asarray(result.table.firing_time_s, float).copy()
    dropped = found.rows_to_drop
    final[dropped] = old[dropped]
    refined = with_times(table, final, source=result.table.source)
    searched = result.before["case_index"].to_numpy()
    position = {int(c): t for t, c in enumerate(searched)}
    harmed = {r: [w for w, rows in found.causes.items() if r in rows] for r in dropped}
    for r in dropped:
        t = position.get(r)
        if t is None:
            continue
        for axis in AXES:
            log.loc[log.index[t], f"{axis}_new_s"] = log.loc[log.index[t], f"{axis}_old_s"]
            log.loc[log.index[t], f"{axis}_change_cycles"] = 0
        log.loc[log.index[t], "changed"] = False
        victims = ", ".join(f"case {int(table.case[w])}" for w in harmed[r])
        log.loc[log.index[t], "decision"] = (
            f"dropped (caused a regression of {victims} on held-out seed {fresh_seed}; "
            f"checked again on seed {further_seed})"
        )
    spec = replace(fresh, seed=int(further_seed))
    trials = Trials(
        np.concatenate(
            [np.repeat(old[None], searched.size, 0), np.repeat(final[None], searched.size, 0)]
        ),
        np.tile(searched, 2),
        tuple(["original"] * searched.size + ["final"] * searched.size),
    )
    runs = evaluate(spec, table, trials, desc="refine: further seed", **fly)
    n = searched.size
    before = runs[runs["trial"] < n]
    after = runs[runs["trial"] >= n].assign(trial=lambda f: f["trial"] - n)
    again = find_regressions(spec, table, refined, before, after, **fly)
    sb, sa = trial_scores(before, n), trial_scores(after, n)
    label = "Table 6 (paper)" if is_table6(table) else "original"
    further = {
        "seed": int(further_seed),
        "dropped_rows": [int(table.case[r]) for r in dropped],
        "comparison": comparison_frame({label: sb, "refined, regressions dropped": sa}),
        "failed_before": int(sb["failed"].sum()),
        "failed_after": int(sa["failed"].sum()),
        "runs": int(sb["runs"].sum()),
        "regressions": again.text(further_seed, table.case),
    }
    return replace(result, table=refined), further


def is_table6(table: LookupTable) -> bool:
    """Whether ``table`` has the packaged Table 6's firing times (the paper's original)."""
    from rcsim.models.tables import load_lookup_table

    t6 = load_lookup_table(which="table6")
    ours = np.asarray(table.firing_time_s, float)
    return ours.shape == t6.firing_time_s.shape and bool(
        np.allclose(ours, t6.firing_time_s, atol=1e-9)
    )


def comparison_frame(scores: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """One row per table on the held-out seed: ``table, failed, repeated, runs`` summed over
    the searched cases, the failure probability and its Clopper-Pearson 95 % interval."""
    rows = []
    for name, sc in scores.items():
        failed, runs = int(sc["failed"].sum()), int(sc["runs"].sum())
        lo, hi = clopper_pearson(failed, runs)
        rows.append(
            {
                "table": name,
                "failed": failed,
                "repeated": int(sc["repeated"].sum()),
                "runs": runs,
                "failed_pct": 100.0 * failed / max(runs, 1),
                "failed_ci_lo_pct": 100.0 * float(lo),
                "failed_ci_hi_pct": 100.0 * float(hi),
            }
        )
    return pd.DataFrame(rows)


def save_search(result: RefineResult, path: str | Path) -> None:
    """The search's per-case scores and rounds as JSON (the refined table is its own CSV)."""
    data = {
        "before": result.before.to_dict(orient="list"),
        "after": result.after.to_dict(orient="list"),
        "iterations": result.iterations,
        "runs_flown": result.runs_flown,
    }
    if result.evidence is not None:
        ev = result.evidence.astype(object)
        data["evidence"] = ev.where(ev.notna(), None).to_dict(orient="list")
    atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(data, indent=1, default=int)))


def load_search(path: str | Path, table: LookupTable) -> RefineResult:
    """:func:`save_search` read back, with ``table`` the refined table."""
    data = json.loads(Path(path).read_text())
    return RefineResult(
        table=table,
        before=pd.DataFrame(data["before"]),
        after=pd.DataFrame(data["after"]),
        iterations=data["iterations"],
        runs_flown=data["runs_flown"],
        evidence=pd.DataFrame(data["evidence"]) if "evidence" in data else None,
    )


def changelog(
    old: LookupTable,
    result: RefineResult,
    fresh_before: pd.DataFrame,
    fresh_after: pd.DataFrame,
    cycle_s: float,
) -> pd.DataFrame:
    """One row per searched case: times per axis before/after (whole ``cycle_s`` cycles, the
    flown vehicle's), outcomes on both seeds."""
    jet_axis = jet_axes(old)
    searched = result.before["case_index"].to_numpy()
    c_old = axis_cycles(old.firing_time_s, jet_axis, cycle_s)[searched]
    c_new = axis_cycles(result.table.firing_time_s, jet_axis, cycle_s)[searched]
    cols: dict = {"case": old.case[searched]}
    if old.recipe is not None:  # a channel table: which channel each axis's time is
        cols["channels"] = [", ".join(case_channels(old.rate_cmd[c])) for c in searched]
    for a, axis in enumerate(AXES):
        cols[f"{axis}_old_s"] = c_old[:, a] * cycle_s
        cols[f"{axis}_new_s"] = c_new[:, a] * cycle_s
        cols[f"{axis}_change_cycles"] = c_new[:, a] - c_old[:, a]
    frame = pd.DataFrame(cols)
    frame["changed"] = (c_new != c_old).any(axis=1)
    frame["runs"] = result.before["runs"].to_numpy()
    for name, scores in (
        ("search_before", result.before),
        ("search_after", result.after),
        ("fresh_before", fresh_before),
        ("fresh_after", fresh_after),
    ):
        frame[f"failed_{name}"] = scores["failed"].to_numpy()
        frame[f"repeated_{name}"] = scores["repeated"].to_numpy()
    frame["fresh_runs"] = fresh_before["runs"].to_numpy()
    for name in ("fresh_before", "fresh_after"):
        lo, hi = clopper_pearson(frame[f"failed_{name}"], frame["fresh_runs"])
        frame[f"failed_{name}_ci_lo"], frame[f"failed_{name}_ci_hi"] = lo, hi
    if result.evidence is not None:
        ev = result.evidence.drop(
            columns=[
                "case_index",
                "search_failed_before",
                "search_failed_after",
                "search_repeated_before",
                "search_repeated_after",
                "search_runs",
            ]
        ).reset_index(drop=True)
        for name in ("confirm_failed_before", "confirm_failed_after"):
            k = pd.to_numeric(ev[name], errors="coerce")
            n = pd.to_numeric(ev["confirm_runs"], errors="coerce")
            have = k.notna() & n.notna()
            lo = np.full(len(ev), np.nan)
            hi = np.full(len(ev), np.nan)
            if have.any():
                lo[have], hi[have] = clopper_pearson(k[have], n[have])
            ev[f"{name}_ci_lo"], ev[f"{name}_ci_hi"] = lo, hi
        frame = pd.concat([frame, ev], axis=1)
    return frame


def held_out_propellant(
    log: pd.DataFrame, before: pd.DataFrame, after: pd.DataFrame, max_rise: float = MAX_RISE
) -> None:
    """Add the held-out seed's propellant to a :func:`changelog` (in place) and mark the
    changed rows that do worse there.

    ``before`` / ``after``: the old and the refined table's scoring frames on the held-out seed
    (``trial`` = position among the searched cases, ``k``, ``failed``, ``propellant_kg``).
    Adds ``propellant_fresh_{before,after}_kg`` with t 95 % intervals (``..._ci_lo_kg``,
    ``..._ci_hi_kg``), ``propellant_fresh_change_pct`` and ``held_out``: ``holds``, or
    ``worse on held-out seed: ...`` (more failures; or propellant beyond ``max_rise`` without
    the failure gain that pays for it, :func:`~rcsim.analysis.apps.refinement.propellant.
    propellant_check`); "" for an unchanged row.  A worse row's ``decision`` no longer says
    "confirmed".
    """
    n = len(log)
    for name, runs in (("before", before), ("after", after)):
        stats_ = case_propellant(runs, n)
        log[f"propellant_fresh_{name}_kg"] = stats_["propellant_kg"].to_numpy()
        log[f"propellant_fresh_{name}_ci_lo_kg"] = stats_["ci_lo_kg"].to_numpy()
        log[f"propellant_fresh_{name}_ci_hi_kg"] = stats_["ci_hi_kg"].to_numpy()
    verdicts = []
    for t in range(n):
        if not bool(log["changed"].iloc[t]):
            verdicts.append("")
            continue
        fb, fa = int(log["failed_fresh_before"].iloc[t]), int(log["failed_fresh_after"].iloc[t])
        fuel = propellant_check(before[before["trial"] == t], after[after["trial"] == t], max_rise)
        if fa > fb:
            verdicts.append(f"worse on held-out seed: failures {fb} -> {fa}")
        elif not fuel.passes:
            verdicts.append(f"worse on held-out seed: {fuel.reason}")
        else:
            verdicts.append("holds")
    log["propellant_fresh_change_pct"] = 100.0 * (
        log["propellant_fresh_after_kg"] / log["propellant_fresh_before_kg"] - 1.0
    )
    log["held_out"] = verdicts
    if "decision" in log:
        worse = log["held_out"].str.startswith("worse")
        log.loc[worse, "decision"] = [
            "worse on held-out seed ("
            + d.split("(", 1)[-1].replace("; confirmed", "; passed the confirmation seed")
            for d in log.loc[worse, "decision"].astype(str)
        ]


def case_channels(rate_cmd: np.ndarray) -> list[str]:
    """The channels a case's row fires, e.g. ``["-roll", "+yaw"]`` (a channel table's columns
    are named by the axis and sign they turn)."""
    return [f"{'+' if r > 0 else '-'}{axis}" for axis, r in zip(AXES, rate_cmd) if r != 0]


#: The command whose outputs :func:`write_refinement` writes (named in the plots' marker).
COMMAND = "lookup refine"


def output_paths(out_csv: str | Path) -> dict[str, Path]:
    """Where a refinement writes: the table, its changelog and the plots folder (and, while
    it runs, the search's hidden round-by-round checkpoint; a channel table's recipe)."""
    from rcsim.models.tables import recipe_path

    out_csv = Path(out_csv)
    return {
        "table": out_csv,
        "recipe": recipe_path(out_csv),
        "changelog": out_csv.with_name(f"{out_csv.stem}_changelog.csv"),
        "heldout": out_csv.with_name(f"{out_csv.stem}_heldout.csv"),
        "plots": out_csv.with_name(f"{out_csv.stem}_plots"),
        "checkpoint": out_csv.with_name(f".{out_csv.stem}.refine-state"),
    }


def check_outputs(
    out_csv: str | Path,
    *,
    overwrite: bool = False,
    writer: str | None = None,
    channels: bool = False,
    inputs: dict | None = None,
) -> dict[str, Path]:
    """Check all the outputs before any flight (existing ones need ``overwrite``;
    ``writer``: the loop writing into its own directory, see :func:`check_out_file`;
    ``channels``: a channel table, whose recipe is written beside it; ``inputs``, ``{what:
    path}``: none of the outputs may be one, e.g. the table refined)."""
    paths = output_paths(out_csv)
    refuse_own_inputs([p for k, p in paths.items() if k != "checkpoint"], inputs or {})
    check_out_file(paths["table"], overwrite=overwrite, parameter="out", writer=writer)
    if channels:
        check_out_file(paths["recipe"], overwrite=overwrite, parameter="out", writer=writer)
    check_out_file(paths["changelog"], overwrite=overwrite, parameter="out", writer=writer)
    check_out_file(paths["heldout"], overwrite=overwrite, parameter="out", writer=writer)
    check_out_dir(paths["plots"], COMMAND, overwrite=overwrite)
    return paths


def write_refinement(
    ref: Refinement, out_csv: str | Path, *, overwrite: bool = False, writer: str | None = None
) -> dict[str, Path]:
    """Write ``OUT.csv``, ``OUT_changelog.csv``, ``OUT_heldout.csv`` (the held-out seed per
    table, :func:`comparison_frame`) and ``OUT_plots/*.png``; returns the paths.

    All are committed together: the plots folder is built aside, the files are written to
    temporaries and renamed into place (a channel table's recipe first, the table last,
    :func:`rcsim.analysis.engine.commit.commit_files`), and the folder is renamed last -- a
    failed write (a full disk) leaves none of them; a table on disk always has its changelog.
    """
    channels = ref.table.recipe is not None
    paths = check_outputs(out_csv, overwrite=overwrite, writer=writer, channels=channels)
    written = dict(paths)
    if not channels:
        del written["recipe"]
    worst = most_improved_case(ref.changelog)
    with atomic_dir(paths["plots"], COMMAND, overwrite=overwrite) as tmp:
        plot_failures_by_case(
            ref.changelog,
            tmp / "failures_by_case.png",
            title=f"{ref.runs_per_case} dispersed runs per case",
            seed=ref.seed,
            fresh_seed=ref.fresh_seed,
            search_runs=int(ref.result.before["runs"].max()),
        )
        written["summary_plot"] = paths["plots"] / "failures_by_case.png"
        if worst is not None:
            name = f"case_{int(worst['case']):02d}_before_after.png"
            plot_case_before_after(ref, int(worst["case"]), tmp / name)
            written["case_plot"] = paths["plots"] / name
        csv = {"index": False, "float_format": "%.6g"}
        log = ref.changelog
        if ref.plugin is not None:  # which flight software flew every table, on every row
            log = log.assign(controller=ref.plugin.describe())
        parts: list = [(paths["changelog"], lambda t: log.to_csv(t, **csv))]
        if ref.comparison is not None:
            comparison = (
                ref.comparison
                if "seed" in ref.comparison
                else ref.comparison.assign(seed=ref.fresh_seed)
            )
            parts.append((paths["heldout"], lambda t: comparison.to_csv(t, **csv)))
        else:
            del written["heldout"]
        if ref.table.recipe is not None:
            parts.append((paths["recipe"], ref.table.recipe.to_csv))
        parts.append((paths["table"], lambda t: ref.table.to_csv(t, with_recipe=False)))
        commit_files(parts)  # inside the block: the plots folder only once the files are in
    del written["plots"], written["checkpoint"]
    return written


__all__ = [
    "Refinement",
    "held_out_check",
    "run_refinement",
    "write_refinement",
]
