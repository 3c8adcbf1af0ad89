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
4. The cases whose rows changed are flown again with all accepted changes, and 2-3 repeat
   until every case is robust, no entry is left to try, or ``max_iterations`` is reached.
   The table returned is the best one flown (fewest failures, then repeated firings, over
   all searched cases).

The search flies a subset of each case's runs, the first ``search_runs_per_case`` (200 by
default) of the campaign's own draws: its cost scales with the evidence a decision needs, not
with the campaign (a 26 x 1,000 campaign is searched on 26 x 200 runs).

Guarding against fitting the seed is the caller's job (:func:`refine` reports the search seed
only; :func:`analysis.apps.refinement.outputs.held_out_check` flies a fresh seed).
"""

from __future__ import annotations

import hashlib
import pickle
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from analysis.apps.refinement.evaluate import Trials, evaluate
from analysis.engine.campaign.spec import CampaignSpec
from analysis.results.scoring import offending_runs, score_key, total, trial_scores
from lookup.table_edits import axis_cycles, jet_axes, shift_axes, with_times
from models.atomic import atomic_write
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


#: Runs per case the search flies by default: the first 200 of each case's campaign runs (the
#: same draws).  Enough to tell a candidate that removes failures at a rate of a few percent
#: from one that does not (issue 19); the held-out check then flies every run at full size.
SEARCH_RUNS_PER_CASE = 200


def refine(
    spec: CampaignSpec,
    table: LookupTable,
    cases=None,
    *,
    max_iterations: int = 8,
    threads: int | None = None,
    progress: bool | None = None,
    lookup_params=None,
    baseline_runs: pd.DataFrame | None = None,
    search_runs_per_case: int | None = SEARCH_RUNS_PER_CASE,
    checkpoint: str | Path | None = None,
) -> RefineResult:
    """Refine ``table`` against the dispersed runs of ``spec``.

    Parameters
    ----------
    spec : CampaignSpec
        A rate-cases campaign with one case per table row (all 26, in table order).
    table : LookupTable
    cases : sequence of int, optional
        Table rows (0-based) to search; default all.
    max_iterations : int
        Most rounds of candidates (each round: candidates, then the changed cases again).
    baseline_runs : DataFrame, optional
        The table's own runs on ``spec`` if already flown (a campaign's, through
        :func:`~analysis.apps.refinement.evaluate.runs_from_campaign`); default: fly them.
    search_runs_per_case : int or None
        The search flies runs ``0 .. search_runs_per_case - 1`` of each case (the campaign's
        own draws, numbered as the campaign numbers them); None or more than
        ``spec.runs_per_case``: all of them.  The result depends on this number and the seed,
        never on how the flying is split (chunks, threads).
    checkpoint : path, optional
        A file the search keeps its state in after the baseline and after every round
        (written atomically).  If it exists and was written by a search with the same
        arguments, the search continues from it instead of starting again: a search killed in
        its fifth round resumes there, and ends with the table an uninterrupted one finds.
        Removed when the search ends.
    """
    if len(spec.cases) != len(table.case):
        raise ValueError(f"spec has {len(spec.cases)} cases, the table {len(table.case)}")
    if max_iterations < 1:
        raise ValueError(f"max_iterations must be >= 1, got {max_iterations}")
    if search_runs_per_case is not None and search_runs_per_case < 1:
        raise ValueError(f"search_runs_per_case must be >= 1, got {search_runs_per_case}")
    cases = np.arange(len(table.case)) if cases is None else np.asarray(sorted(set(cases)), int)
    search = _Search(
        spec,
        table,
        cases,
        dict(threads=threads, progress=progress, lookup_params=lookup_params),
        min(spec.runs_per_case, search_runs_per_case or spec.runs_per_case),
    )
    key = _checkpoint_key(spec, table, cases, max_iterations, search.runs_per_case)
    saved = _load_checkpoint(checkpoint, key)
    if saved is not None:
        search.__dict__.update(saved)
    else:
        search.start(baseline_runs)
        _save_checkpoint(checkpoint, key, search)
    for it in range(len(search.iterations), max_iterations):
        trials, edits = search.candidates()
        if trials is None:
            break
        search.round(it + 1, trials, edits)
        _save_checkpoint(checkpoint, key, search)
    if checkpoint is not None:
        Path(checkpoint).unlink(missing_ok=True)
    refined = with_times(table, search.best[0], source=f"refined from {table.source or 'a table'}")
    return RefineResult(
        table=refined,
        before=search.before,
        after=search.best[1],
        iterations=search.iterations,
        runs_flown=search.flown,
    )


#: What a checkpoint keeps of a :class:`_Search` (everything a round reads or changes).
_STATE = ("current", "runs", "scores", "before", "best", "iterations", "flown", "visited")


def _checkpoint_key(spec, table, cases, max_iterations, runs_per_case) -> str:
    """A digest of everything the search's result depends on: a checkpoint of another search
    (another spec, table, cases or subset) is never continued."""
    parts = [
        spec.digest(),
        np.asarray(table.firing_time_s, float).tobytes().hex(),
        np.asarray(cases).tobytes().hex(),
        str(max_iterations),
        str(runs_per_case),
    ]
    return hashlib.sha256("|".join(parts).encode()).hexdigest()


def _save_checkpoint(path, key: str, search: _Search) -> None:
    if path is None:
        return
    state = {"key": key, **{name: getattr(search, name) for name in _STATE}}
    Path(path).parent.mkdir(parents=True, exist_ok=True)  # where the outputs will go too
    atomic_write(path, lambda tmp: Path(tmp).write_bytes(pickle.dumps(state)))


def _load_checkpoint(path, key: str) -> dict | None:
    """The saved search state, or None (no file, another search's, or unreadable: start)."""
    if path is None or not Path(path).is_file():
        return None
    try:
        state = pickle.loads(Path(path).read_bytes())  # our own file, written by this module
    except Exception:  # a damaged checkpoint only costs the work it held
        return None
    if not isinstance(state, dict) or state.get("key") != key:
        return None
    return {name: state[name] for name in _STATE}


class _Search:
    """The state of one :func:`refine` search: the current table, its runs and scores per
    searched case, the entries already flown, the best table so far (steps 2-4 of the module
    docstring, one method each)."""

    def __init__(
        self,
        spec: CampaignSpec,
        table: LookupTable,
        cases: np.ndarray,
        kw: dict,
        runs_per_case: int,
    ):
        self.spec, self.table, self.cases, self.kw = spec, table, cases, kw
        self.runs_per_case = runs_per_case
        self.jet_axis = jet_axes(table)
        self.threshold_deg_s = float(np.degrees(spec.rate_threshold_rad_s))
        self.current = np.asarray(table.firing_time_s, float)
        self.iterations: list = []
        self.flown = 0
        # Entries already flown, per case (its firing cycles per axis): a candidate that
        # returns to one of them (the step back after a step that helped) or repeats a
        # rejected one is not flown again.  Other entries may have changed since, which could
        # shift the verdict slightly; the re-fly after each round measures what is kept.
        self.visited = {(int(c), tuple(axis_cycles(self.current, self.jet_axis)[c])) for c in cases}

    def _fly(self, times: np.ndarray, trial_cases: np.ndarray, desc: str) -> pd.DataFrame:
        trials = Trials(
            np.repeat(times[None], trial_cases.size, axis=0),
            trial_cases,
            tuple(f"case {c + 1}: current" for c in trial_cases),
        )
        runs = evaluate(
            self.spec, self.table, trials, desc=desc, runs_per_case=self.runs_per_case, **self.kw
        )
        self.flown += len(runs)
        return runs

    def start(self, baseline_runs: pd.DataFrame | None) -> None:
        """Step 1: the table's own runs, flown or taken from the campaign that flew them."""
        if baseline_runs is None:
            self.runs = self._fly(self.current, self.cases, "refine: baseline")
        else:
            mine = baseline_runs[baseline_runs["k"] < self.runs_per_case]
            self.runs = mine.reset_index(drop=True)
        self.scores = trial_scores(self.runs, self.cases.size)
        self.before = self.scores.assign(case_index=self.cases)
        self.best = (self.current, self.before)

    def candidates(self) -> tuple[Trials | None, list]:
        """Step 2: one axis per non-robust case, one cycle shorter and longer."""
        offending = offending_runs(self.runs, self.threshold_deg_s, self.cases.size)
        times, labels, trial_case, edits = [], [], [], []
        for t, c in enumerate(self.cases):
            if score_key(self.scores.iloc[t]) == (0, 0):
                continue
            # One axis per case and round: the one most runs fail or re-fire on (the paper's
            # yaw), before axes with a stray run or two; the next round moves on if it does
            # not help (its entries are then visited).
            for a in sorted(np.flatnonzero(offending[t]), key=lambda a: -offending[t, a]):
                found = self._axis_candidates(t, int(c), int(a))
                for candidate, label, shift in found:
                    times.append(candidate)
                    labels.append(label)
                    trial_case.append(c)
                    edits.append((t, shift))
                if found:
                    break
        if not times:
            return None, []
        return Trials(np.array(times), np.array(trial_case), tuple(labels)), edits

    def _axis_candidates(self, t: int, c: int, a: int) -> list:
        """Case ``c``'s axis ``a`` one cycle either way, the entries not flown yet."""
        found = []
        for step in STEP_CYCLES:
            shift = np.zeros((len(self.table.case), len(AXES)), int)
            shift[c, a] = step
            try:
                candidate = shift_axes(self.current, self.jet_axis, shift)
            except ValueError:  # would leave less than a cycle: not a candidate
                continue
            state = (int(c), tuple(axis_cycles(candidate, self.jet_axis)[c]))
            if state in self.visited:
                continue
            self.visited.add(state)
            found.append((candidate, f"case {c + 1}: {AXES[a]} {step:+d} cycle", shift))
        return found

    def round(self, number: int, trials: Trials, edits: list) -> None:
        """Steps 3-4: fly the candidates, keep each case's best if strictly better, fly the
        changed cases again with every accepted change."""
        cand_runs = evaluate(
            self.spec,
            self.table,
            trials,
            desc=f"refine: round {number} candidates",
            runs_per_case=self.runs_per_case,
            **self.kw,
        )
        self.flown += len(cand_runs)
        cand = trial_scores(cand_runs, trials.n_trials)
        accepted = np.zeros((len(self.table.case), len(AXES)), int)
        changed = []
        for t in np.unique([e[0] for e in edits]):
            mine = [i for i, e in enumerate(edits) if e[0] == t]
            # Best candidate: fewest failures, then fewest repeated firings; first wins a tie
            # (shorter before longer, roll before yaw), so the search is deterministic.
            i = min(mine, key=lambda i: score_key(cand.iloc[i]))
            if score_key(cand.iloc[i]) < score_key(self.scores.iloc[t]):
                accepted += edits[i][1]
                changed.append(trials.label[i])
        if not changed:
            # Nothing helped: the table and its runs stand; the next round tries the entries
            # not flown yet (other axes), and the search ends when there are none.
            self.iterations.append({"round": number, "candidates": trials.n_trials, "changed": []})
            return
        self.current = shift_axes(self.current, self.jet_axis, accepted)
        self._refly(
            np.flatnonzero(np.isin(self.cases, np.flatnonzero(accepted.any(axis=1)))),
            f"refine: round {number} re-fly",
        )
        totals = self.scores[["failed", "repeated"]].sum()
        self.iterations.append(
            {
                "round": number,
                "candidates": trials.n_trials,
                "changed": changed,
                "failed": int(totals["failed"]),
                "repeated": int(totals["repeated"]),
            }
        )
        if total(self.scores) < total(self.best[1]):
            self.best = (self.current, self.scores.assign(case_index=self.cases))

    def _refly(self, positions: np.ndarray, desc: str) -> None:
        """Fly the current table on the searched cases at ``positions`` (indices into
        ``cases``) and replace their runs.  Only the cases whose own rows changed are flown
        again: a row change could in principle alter another case's late correction firings,
        which the held-out check at full size measures."""
        fresh = self._fly(self.current, self.cases[positions], desc)
        fresh["trial"] = positions[fresh["trial"].to_numpy()]
        kept = self.runs[~self.runs["trial"].isin(positions)]
        self.runs = (
            pd.concat([kept, fresh], ignore_index=True)
            .sort_values(["trial", "k"], kind="stable")
            .reset_index(drop=True)
        )
        self.scores = trial_scores(self.runs, self.cases.size)


def changed_cells(old: LookupTable, new: LookupTable) -> pd.DataFrame:
    """Per case and axis whose firing time changed: ``case, axis, old_cycles, new_cycles``."""
    jet_axis = jet_axes(old)
    a_old = axis_cycles(old.firing_time_s, jet_axis)
    a_new = axis_cycles(new.firing_time_s, jet_axis)
    rows = [
        {
            "case": int(old.case[c]),
            "axis": AXES[a],
            "old_cycles": int(a_old[c, a]),
            "new_cycles": int(a_new[c, a]),
        }
        for c, a in np.argwhere(a_old != a_new)
    ]
    return pd.DataFrame(rows, columns=["case", "axis", "old_cycles", "new_cycles"])
