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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.evaluate import Trials, evaluate
from rcsim.analysis.apps.refinement.search import (
    SEARCH_RUNS_PER_CASE,
    RefineResult,
    changed_cells,
    refine,
)
from rcsim.analysis.engine.campaign.outcomes import outcomes
from rcsim.analysis.engine.campaign.spec import parse_dict
from rcsim.analysis.engine.commit import commit_files
from rcsim.analysis.engine.flight import fly_batch
from rcsim.analysis.engine.output import atomic_dir, check_out_dir, check_out_file
from rcsim.analysis.engine.output_places import refuse_own_inputs
from rcsim.analysis.engine.plots import AXIS_COLORS, new_figure
from rcsim.analysis.results.proportions import clopper_pearson
from rcsim.analysis.results.scoring import trial_scores
from rcsim.lookup.pattern_recognition import LookupController
from rcsim.lookup.table_edits import axis_cycles, jet_axes
from rcsim.models.atomic import atomic_write
from rcsim.models.errors import InputError
from rcsim.models.tables import AXES, CONTROL_CYCLE_S, LookupTable
from rcsim.spacecraft.dispersions import MAX_SEED, draw_runs
from rcsim.spacecraft.vehicle import load_model

DPI = 90
#: Most runs drawn in the before/after plot of one case.
PLOT_RUNS = 200


def rate_cases_campaign(
    *,
    runs_per_case: int,
    seed: int,
    duration_s: float = 20.0,
    table: str = "default",
    histories: str = "none",
    plots: bool = False,
    vehicle: str | None = None,
    controller: str = "lookup",
) -> dict:
    """The campaign a refinement flies, as a spec dict: all 26 Table 3 cases from rest, Table 5
    dispersions, the campaign's default failure threshold.

    The one definition: ``rcsim loop`` writes it as the TOML of its campaigns, and uses the
    "before" campaign's runs as the search's baseline -- the same runs only if both come
    from here.  ``controller``: another than the lookup controller only to check a vehicle
    before its table exists (the loop's ``generate``).
    """
    spec: dict = {
        "seed": seed,
        "runs_per_case": runs_per_case,
        "scenario": {
            "kind": "rate-cases",
            "cases": "all",
            "mode": "command",
            "duration_s": float(duration_s),
        },
        "controller": {"name": "lookup", "table": table}
        if controller == "lookup"
        else {"name": controller},
        "dispersions": {"table": "default", "scale": 1.0},
        "output": {"histories": histories, "plots": plots},
    }
    if vehicle is not None:  # a vehicle file (or packaged name): the campaign flies it
        spec["vehicle"] = vehicle
    return spec


def refinement_spec(
    *,
    runs_per_case: int,
    seed: int,
    duration_s: float = 20.0,
    source: str = "lookup refine",
    vehicle: str | None = None,
    table: str = "default",
    controller: str = "lookup",
):
    """:func:`rate_cases_campaign` validated (a :class:`CampaignSpec`).

    ``table``: the table file the campaign names (the refinement flies its candidates
    itself); a channel table's file, so that it is checked against ``vehicle``."""
    return parse_dict(
        rate_cases_campaign(
            runs_per_case=runs_per_case,
            seed=seed,
            duration_s=duration_s,
            vehicle=vehicle,
            table=table,
            controller=controller,
        ),
        source=source,
        base_dir=None,
    )


def table_vehicle(table: LookupTable) -> tuple[str | None, str]:
    """What a refinement of ``table`` flies: ``(vehicle, table file)``.

    A jet table flies the packaged vehicle (None) and names no file ("default"); a channel
    table flies the vehicle file its recipe was solved for, and is named by its own file
    (the one it was loaded from: its recipe is beside it).
    """
    if table.recipe is None:
        return None, "default"
    source = Path(table.source)
    if not source.is_file():
        raise InputError(
            f"{table.source or '<lookup table>'}: a channel table is refined from its file "
            "(its recipe beside it); save it with LookupTable.to_csv and load it",
            parameter="table",
            value=table.source,
        )
    return table.recipe.vehicle, str(source.absolute())


@dataclass
class Refinement:
    """A refinement with its held-out check.

    Attributes
    ----------
    original : LookupTable
        The table refined.
    result : RefineResult
    fresh_before, fresh_after : DataFrame
        Per searched case on the fresh seed: ``failed, repeated, runs``.
    changelog : DataFrame
    seed, fresh_seed, runs_per_case : int
    duration_s : float
        Simulated time of every run [s].
    comparison : DataFrame, optional
        The held-out seed per table (the original, the refined and, when the original is the
        packaged Table 6, the paper's Table 7): :func:`comparison_frame`.
    confirm_seed : int, optional
        The confirmation seed (None: the search gate alone).
    vehicle : str, optional
        The vehicle file flown (None: the packaged vehicle).
    table_file : str
        The original table's file as the campaigns name it (a channel table's), or "default".
    """

    original: LookupTable
    result: RefineResult
    fresh_before: pd.DataFrame
    fresh_after: pd.DataFrame
    changelog: pd.DataFrame
    seed: int
    fresh_seed: int
    runs_per_case: int
    duration_s: float
    comparison: pd.DataFrame | None = None
    confirm_seed: int | None = None
    vehicle: str | None = None
    table_file: str = "default"

    @property
    def table(self) -> LookupTable:
        return self.result.table


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

    Raises
    ------
    InputError
        A parameter out of range (named by ``parameter``).
    """
    fresh_seed = held_out_seed(seed) if fresh_seed is None else fresh_seed
    confirm_seed = confirmation_seed(seed, fresh_seed) if confirm_seed is None else confirm_seed
    check_parameters(
        runs_per_case=runs_per_case,
        seed=seed,
        fresh_seed=fresh_seed,
        duration_s=duration_s,
        max_iterations=max_iterations,
        search_runs_per_case=search_runs_per_case,
        confirm_seed=confirm_seed,
    )
    # A channel table flies the vehicle its recipe was solved for; a jet table the packaged one.
    vehicle, table_file = table_vehicle(table)
    spec = refinement_spec(
        runs_per_case=runs_per_case,
        seed=seed,
        duration_s=duration_s,
        vehicle=vehicle,
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
        vehicle=vehicle,
        table_file=table_file,
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
    vehicle: str | None = None,
    table_file: str = "default",
) -> Refinement:
    """Fly the old and the refined table on ``fresh_seed`` (the seed no decision used).

    ``fresh_after_runs`` / ``fresh_before_runs``: the refined / old table's runs on the fresh
    seed if a campaign already flew them
    (:func:`~rcsim.analysis.apps.refinement.evaluate.runs_from_campaign`); only the others are
    flown. ``compare_table7``: fly the paper's Table 7 on those runs too (default: when ``table`` is
    the packaged Table 6, the table the paper refined by hand).  ``vehicle`` and
    ``table_file``: what the refinement flew (:func:`table_vehicle`).
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
            fresh, table, trials, threads=threads, progress=progress, desc="refine: fresh seed"
        )
        scores = trial_scores(runs, trials.n_trials)
        for i, k in enumerate(to_fly):
            part = scores.iloc[i * searched.size : (i + 1) * searched.size]
            scores_of[k] = part.reset_index(drop=True)
    fresh_before, fresh_after = scores_of["before"], scores_of["after"]
    log = changelog(table, result, fresh_before, fresh_after)
    names = {"before": "Table 6 (paper)" if is_table6(table) else "original", "after": "refined"}
    if compare_table7:
        names["table7"] = "Table 7 (paper)"
    comparison = comparison_frame({names[k]: scores_of[k] for k in names})
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
        comparison=comparison,
        confirm_seed=confirm_seed,
        vehicle=vehicle,
        table_file=table_file,
    )


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


#: Most runs per case a refinement accepts: 26 cases x 100,000 runs is 65 days of a 2-core
#: machine's flying; a larger number is a typo, refused before any work.
MAX_RUNS_PER_CASE = 100_000


def load_refinable_table(table) -> LookupTable:
    """The table to refine (a CSV path or ``table6`` / ``table7``).

    Refinement flies the 16-jet vehicle; a table generated for failed jets (its companion file
    records them, :mod:`rcsim.lookup.jet_sets`) is refused with that reason rather than with
    the jet-map mismatch the plain loader would report.
    """
    from rcsim.lookup.jet_sets import jets_off_of
    from rcsim.models.tables import PAPER_LOOKUP_TABLES, load_lookup_table

    if str(table) not in PAPER_LOOKUP_TABLES and Path(table).is_file():
        off = jets_off_of(table)
        if off:
            raise InputError(
                f"{table}: a table for jets {','.join(map(str, off))} off; "
                "refinement flies the full 16-jet vehicle (fly this table with "
                "`rcsim campaign run` and its spec's controller.table)",
                parameter="table",
                value=str(table),
            )
    return load_lookup_table(table)


def held_out_seed(seed: int) -> int:
    """The default held-out seed of a search on ``seed``: ``seed + 1``.

    Any other seed is as unseen (each seed's streams are independent); one rule keeps
    ``rcsim lookup refine`` and ``rcsim loop`` on the same default.
    """
    return seed + 1


def confirmation_seed(seed: int, fresh_seed: int) -> int:
    """The default confirmation seed (the refinement's second gate): one past the larger of
    the search and held-out seeds, so that it is neither (seeds 1 and 2: 3)."""
    return max(seed, fresh_seed) + 1


def check_parameters(
    *,
    runs_per_case,
    seed,
    fresh_seed,
    duration_s,
    max_iterations,
    search_runs_per_case=SEARCH_RUNS_PER_CASE,
    confirm_seed=None,
) -> None:
    """Raise :class:`InputError` naming the first out-of-range refinement parameter."""

    def bad(name, value, problem):
        return InputError(f"{problem}, got {value!r}", parameter=name, value=value)

    for name, value, lo, hi in (
        ("runs_per_case", runs_per_case, 1, MAX_RUNS_PER_CASE),
        ("seed", seed, 0, MAX_SEED),
        ("fresh_seed", fresh_seed, 0, MAX_SEED),
        ("max_iterations", max_iterations, 1, 1000),
        ("search_runs_per_case", search_runs_per_case, 1, MAX_RUNS_PER_CASE),
        *((("confirm_seed", confirm_seed, 0, MAX_SEED),) if confirm_seed is not None else ()),
    ):
        if (
            not isinstance(value, (int, np.integer))
            or isinstance(value, bool)
            or value < lo
            or (hi is not None and value > hi)
        ):
            raise bad(name, value, f"must be an integer in {lo}..{hi if hi else 'inf'}")
    if fresh_seed == seed:
        raise bad(
            "fresh_seed", fresh_seed, "must differ from the search seed (it is the held-out check)"
        )
    if confirm_seed is not None and confirm_seed in (seed, fresh_seed):
        raise bad(
            "confirm_seed",
            confirm_seed,
            "must differ from the search and held-out seeds (it is the second gate)",
        )
    from rcsim.analysis.engine.campaign.limits import max_duration_s

    longest = max_duration_s()
    # At least a second: the longest table firing (0.52 s), the 0.16 s hold and a correction.
    if not (
        isinstance(duration_s, (int, float))
        and np.isfinite(duration_s)
        and 1.0 <= duration_s <= longest
    ):
        raise bad(
            "duration_s",
            duration_s,
            f"must be a time in 1..{longest:.0f} s (a firing, "
            "its hold and a correction; at most what one campaign chunk holds)",
        )


def changelog(
    old: LookupTable, result: RefineResult, fresh_before: pd.DataFrame, fresh_after: pd.DataFrame
) -> pd.DataFrame:
    """One row per searched case: times per axis before/after, outcomes on both seeds."""
    jet_axis = jet_axes(old)
    searched = result.before["case_index"].to_numpy()
    c_old = axis_cycles(old.firing_time_s, jet_axis)[searched]
    c_new = axis_cycles(result.table.firing_time_s, jet_axis)[searched]
    cols: dict = {"case": old.case[searched]}
    if old.recipe is not None:  # a channel table: which channel each axis's time is
        cols["channels"] = [", ".join(case_channels(old.rate_cmd[c])) for c in searched]
    for a, axis in enumerate(AXES):
        cols[f"{axis}_old_s"] = c_old[:, a] * CONTROL_CYCLE_S
        cols[f"{axis}_new_s"] = c_new[:, a] * CONTROL_CYCLE_S
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
        )
        written["summary_plot"] = paths["plots"] / "failures_by_case.png"
        if worst is not None:
            name = f"case_{int(worst['case']):02d}_before_after.png"
            plot_case_before_after(ref, int(worst["case"]), tmp / name)
            written["case_plot"] = paths["plots"] / name
        csv = {"index": False, "float_format": "%.6g"}
        parts: list = [(paths["changelog"], lambda t: ref.changelog.to_csv(t, **csv))]
        if ref.comparison is not None:
            comparison = ref.comparison.assign(seed=ref.fresh_seed)
            parts.append((paths["heldout"], lambda t: comparison.to_csv(t, **csv)))
        else:
            del written["heldout"]
        if ref.table.recipe is not None:
            parts.append((paths["recipe"], ref.table.recipe.to_csv))
        parts.append((paths["table"], lambda t: ref.table.to_csv(t, with_recipe=False)))
        commit_files(parts)  # inside the block: the plots folder only once the files are in
    del written["plots"], written["checkpoint"]
    return written


def most_improved_case(log: pd.DataFrame):
    """The changelog row of the changed case with the largest drop in failures (then in
    repeated firings) on the search seed; None if no case changed."""
    changed = log[log["changed"]]
    if changed.empty:
        return None
    gain = (changed["failed_search_before"] - changed["failed_search_after"]) * 10_000 + (
        changed["repeated_search_before"] - changed["repeated_search_after"]
    )
    return changed.loc[gain.idxmax()]


def plot_failures_by_case(log: pd.DataFrame, path: Path, *, title: str) -> None:
    """Failed and repeated-firing runs per case, before and after, on both seeds."""
    fig, axes = new_figure(2, 2, figsize=(12, 6.5), sharex=True, sharey="row")
    x = np.arange(len(log))
    for col, seed in enumerate(("search", "fresh")):
        for row, what in enumerate(("failed", "repeated")):
            ax = axes[row, col]
            ax.bar(x - 0.2, log[f"{what}_{seed}_before"], 0.4, color="tab:red", label="before")
            ax.bar(x + 0.2, log[f"{what}_{seed}_after"], 0.4, color="tab:blue", label="after")
            ax.set_ylabel(f"{what} runs" if col == 0 else "")
            ax.grid(alpha=0.3, axis="y")
            ax.set_title(
                f"{what} runs per case, {seed} seed "
                f"({int(log[f'{what}_{seed}_before'].sum())} -> "
                f"{int(log[f'{what}_{seed}_after'].sum())})",
                fontsize=10,
            )
            ax.legend(fontsize=8)
        axes[1, col].set_xticks(
            x,
            [str(int(c)) + ("*" if ch else "") for c, ch in zip(log["case"], log["changed"])],
            fontsize=7,
        )
        axes[1, col].set_xlabel("rate case (* = firing time changed)")
    fig.suptitle(
        f"Lookup-table refinement: {title}; repeated = needed more than one firing "
        "to reach the commanded rate"
    )
    fig.savefig(path, dpi=DPI)


def plot_case_before_after(ref: Refinement, case: int, path: Path) -> None:
    """Figs 9-10 style: the changed axis's body rate of every search-seed run of ``case``,
    with the old table (left) and the refined one (right); failed runs in red."""
    log = ref.changelog.set_index("case").loc[case]
    axis = max(AXES, key=lambda a: abs(int(log[f"{a}_change_cycles"])))
    a = AXES.index(axis)
    from rcsim.analysis.engine.campaign.chunk import nominal_of, spec_vehicle

    spec = refinement_spec(
        runs_per_case=ref.runs_per_case,
        seed=ref.seed,
        duration_s=ref.duration_s,
        vehicle=ref.vehicle,
        table=ref.table_file,
    )
    row = case - 1
    vehicle = spec_vehicle(spec)  # the refinement's vehicle, flown as its campaigns fly it
    model = load_model() if vehicle is None else vehicle.model
    # At most PLOT_RUNS runs: enough to see the spread, and a fixed cost however many runs
    # the search flew (the whole history of every run is kept for the plot).
    shown = min(ref.runs_per_case, PLOT_RUNS)
    ids = row * ref.runs_per_case + np.arange(shown)
    params = draw_runs(nominal_of(spec, model), spec.sigmas, spec.seed, ids).params
    flying: dict = {}
    if vehicle is not None:
        flying = vehicle.flight_options(shown)
    thr = np.degrees(spec.rate_threshold_rad_s)
    fig, axes = new_figure(1, 2, figsize=(12, 4.5), sharey=True)
    cmd = np.degrees(spec.cases[row].rate_cmd_rad_s[a])
    for ax, (label, table, old_new) in zip(
        axes, (("old table", ref.original, "old"), ("refined table", ref.table, "new"))
    ):
        history = fly_batch(
            [spec.cases[row]] * shown, params, LookupController(table), model=model, **flying
        )
        rate = np.degrees(history.omega_B[:, :, a])
        failed = outcomes(history, spec)["failed"].to_numpy(bool)
        for fail, color in ((False, AXIS_COLORS["roll"]), (True, "tab:red")):
            sel = failed == fail
            if sel.any():
                ax.plot(history.t_s, rate[sel].T, color=color, lw=0.6, alpha=0.5)
        ax.axhspan(cmd - thr, cmd + thr, color="0.8", alpha=0.6, label=f"command +-{thr:g} deg/s")
        ax.set_title(
            f"{label}: {axis} {log[f'{axis}_{old_new}_s']:.2f} s; "
            f"{int(failed.sum())} of {shown} runs fail (red)",
            fontsize=10,
        )
        ax.set_xlabel("time [s]")
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right", fontsize=8)
    axes[0].set_ylabel(f"{axis} rate [deg/s]")
    fig.suptitle(
        f"Rate case {case}: {axis} rate of every dispersed run, before and after "
        "refinement (search seed)"
    )
    fig.savefig(path, dpi=DPI)


__all__ = [
    "Refinement",
    "changed_cells",
    "held_out_check",
    "rate_cases_campaign",
    "refinement_spec",
    "run_refinement",
    "write_refinement",
]
