"""Automated lookup-table refinement (Gambone sec. III, Table 6 -> Table 7, automated).

The paper fixed 14 yaw cases by hand after Monte Carlo and notes that the update "can be
automated by measuring the number of firings and the final rate error".  Here:

1. Fly the table's dispersed runs of every case (the campaign's seed, dispersions and failure
   threshold).  A case is *not robust* when some run fails (its final rate error does not
   converge under the threshold) or needs repeated firings to reach the commanded rate.
2. For each such case, the *offending axes* are those on which some run failed or needed more
   than one firing event.  Candidates move all the jets of the axis with the most offending
   runs by one control cycle, shorter or longer (:func:`lookup.table_edits.shift_axes`);
   an entry already flown is never flown again, so the next round walks on in the direction
   that helped, or turns to the next offending axis.
3. Every candidate of every case is flown in one batch over the same dispersed runs as the
   current table (common random numbers).  A case takes its best candidate when it is strictly
   better: fewer failures first, then fewer repeated firings.
4. The current table is flown again with all accepted changes (one entry's change can alter
   another case's correction firings), and 2-3 repeat until every case is robust, no entry
   is left to try, or ``max_iterations`` is reached.  The table returned is the best one
   flown (fewest failures, then repeated firings, over all searched cases).

Guarding against fitting the seed is the caller's job (:func:`refine` reports the search seed
only; :func:`analysis.apps.refinement.outputs.held_out_check` flies a fresh seed).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from analysis.apps.refinement.evaluate import Trials, evaluate
from analysis.engine.campaign.spec import CampaignSpec
from analysis.results.scoring import offending_runs, score_key, total, trial_scores
from lookup.table_edits import axis_cycles, jet_axes, shift_axes, with_times
from models.tables import AXES, LookupTable

#: Cycles a candidate moves one axis: one control cycle either way; repeated iterations walk
#: further in the direction that helps.
STEP_CYCLES = (-1, 1)


@dataclass
class RefineResult:
    """What :func:`refine` found.

    Attributes
    ----------
    table : LookupTable
        The refined table (``source`` says what it was refined from).
    before, after : DataFrame
        Per searched case on the search seed: ``case_index, failed, repeated, runs``.
    iterations : list of dict
        Per iteration: candidates flown, cases changed, totals after.
    runs_flown : int
    """

    table: LookupTable
    before: pd.DataFrame
    after: pd.DataFrame
    iterations: list = field(default_factory=list)
    runs_flown: int = 0


def refine(spec: CampaignSpec, table: LookupTable, cases=None, *, max_iterations: int = 8,
           threads: int | None = None, progress: bool | None = None,
           lookup_params=None, baseline_runs: pd.DataFrame | None = None) -> RefineResult:
    """Refine ``table`` against the dispersed runs of ``spec``.

    Parameters
    ----------
    spec : CampaignSpec
        A rate-cases campaign with one case per table row (all 26, in table order).
    table : LookupTable
    cases : sequence of int, optional
        Table rows (0-based) to search; default all.
    max_iterations : int
        Most rounds of candidates (each round: candidates, then the current table again).
    baseline_runs : DataFrame, optional
        The table's own runs on ``spec`` if already flown (a campaign's, through
        :func:`~analysis.apps.refinement.evaluate.runs_from_campaign`); default: fly them.
    """
    if len(spec.cases) != len(table.case):
        raise ValueError(f"spec has {len(spec.cases)} cases, the table {len(table.case)}")
    if max_iterations < 1:
        raise ValueError(f"max_iterations must be >= 1, got {max_iterations}")
    cases = np.arange(len(table.case)) if cases is None else np.asarray(sorted(set(cases)), int)
    jet_axis = jet_axes(table)
    threshold_deg_s = float(np.degrees(spec.rate_threshold_rad_s))
    kw = dict(threads=threads, progress=progress, lookup_params=lookup_params)

    def fly_current(times: np.ndarray, desc: str):
        trials = Trials(np.repeat(times[None], cases.size, axis=0), cases,
                        tuple(f"case {c + 1}: current" for c in cases))
        runs = evaluate(spec, table, trials, desc=desc, **kw)
        return runs, trial_scores(runs, trials.n_trials)

    current = np.asarray(table.firing_time_s, float)
    if baseline_runs is None:
        runs, scores = fly_current(current, "refine: baseline")
        flown = len(runs)
    else:
        runs, scores, flown = baseline_runs, trial_scores(baseline_runs, cases.size), 0
    before = scores.assign(case_index=cases)
    best = (current, before)
    iterations = []
    # Entries already flown, per case (its firing cycles per axis): a candidate that returns
    # to one of them (the step back after a step that helped) or repeats a rejected one is not
    # flown again.  Other entries may have changed since, which could shift the verdict
    # slightly; the re-fly of the whole table after each round still measures what is kept.
    visited = {(int(c), tuple(axis_cycles(current, jet_axis)[c])) for c in cases}
    for it in range(max_iterations):
        offending = offending_runs(runs, threshold_deg_s, cases.size)
        times, labels, trial_case, edits = [], [], [], []
        for t, c in enumerate(cases):
            if score_key(scores.iloc[t]) == (0, 0):
                continue
            # One axis per case and round: the one most runs fail or re-fire on (the paper's
            # yaw), before axes with a stray run or two; the next round moves on if it does
            # not help (its entries are then visited).
            n_before = len(times)
            for a in sorted(np.flatnonzero(offending[t]), key=lambda a: -offending[t, a]):
                if len(times) > n_before:
                    break
                for step in STEP_CYCLES:
                    shift = np.zeros((len(table.case), len(AXES)), int)
                    shift[c, a] = step
                    try:
                        candidate = shift_axes(current, jet_axis, shift)
                    except ValueError:  # would leave less than a cycle: not a candidate
                        continue
                    state = (int(c), tuple(axis_cycles(candidate, jet_axis)[c]))
                    if state in visited:
                        continue
                    visited.add(state)
                    times.append(candidate)
                    labels.append(f"case {c + 1}: {AXES[a]} {step:+d} cycle")
                    trial_case.append(c)
                    edits.append((t, shift))
        if not times:
            break
        trials = Trials(np.array(times), np.array(trial_case), tuple(labels))
        cand_runs = evaluate(spec, table, trials, desc=f"refine: round {it + 1} candidates", **kw)
        flown += len(cand_runs)
        cand = trial_scores(cand_runs, trials.n_trials)
        accepted = np.zeros((len(table.case), len(AXES)), int)
        changed = []
        for t in np.unique([e[0] for e in edits]):
            mine = [i for i, e in enumerate(edits) if e[0] == t]
            # Best candidate: fewest failures, then fewest repeated firings; first wins a tie
            # (shorter before longer, roll before yaw), so the search is deterministic.
            i = min(mine, key=lambda i: score_key(cand.iloc[i]))
            if score_key(cand.iloc[i]) < score_key(scores.iloc[t]):
                accepted += edits[i][1]
                changed.append(labels[i])
        if not changed:
            # Nothing helped: the table and its runs stand; the next round tries the entries
            # not flown yet (other axes), and the search ends when there are none.
            iterations.append({"round": it + 1, "candidates": trials.n_trials, "changed": []})
            continue
        current = shift_axes(current, jet_axis, accepted)
        runs, scores = fly_current(current, f"refine: round {it + 1} re-fly")
        flown += len(runs)
        totals = scores[["failed", "repeated"]].sum()
        iterations.append({"round": it + 1, "candidates": trials.n_trials, "changed": changed,
                           "failed": int(totals["failed"]), "repeated": int(totals["repeated"])})
        if total(scores) < total(best[1]):
            best = (current, scores.assign(case_index=cases))
    refined = with_times(table, best[0], source=f"refined from {table.source or 'a table'}")
    return RefineResult(table=refined, before=before, after=best[1], iterations=iterations,
                        runs_flown=flown)


def changed_cells(old: LookupTable, new: LookupTable) -> pd.DataFrame:
    """Per case and axis whose firing time changed: ``case, axis, old_cycles, new_cycles``."""
    jet_axis = jet_axes(old)
    a_old = axis_cycles(old.firing_time_s, jet_axis)
    a_new = axis_cycles(new.firing_time_s, jet_axis)
    rows = [{"case": int(old.case[c]), "axis": AXES[a], "old_cycles": int(a_old[c, a]),
             "new_cycles": int(a_new[c, a])}
            for c, a in np.argwhere(a_old != a_new)]
    return pd.DataFrame(rows, columns=["case", "axis", "old_cycles", "new_cycles"])
