"""Automated lookup-table refinement (Gambone sec. III, Table 6 -> Table 7, automated).

The paper fixed 14 yaw cases by hand after Monte Carlo and notes that the update "can be
automated by measuring the number of firings and the final rate error".  Here:

1. Fly the table's dispersed runs of every case (the campaign's seed, dispersions and failure
   threshold).  A case is *not robust* when some run fails (its final rate error does not
   converge under the threshold) or needs repeated firings to reach the commanded rate.
2. For each such case, the *offending axes* are those on which some run failed or needed more
   than one firing event.  Candidates move all the jets of the axis with the most offending
   runs by one control cycle, shorter or longer (:func:`rcsim.lookup.table_edits.shift_axes`);
   an entry already flown is never flown again, so the next round walks on in the direction
   that helped, or turns to the next offending axis.
3. Every candidate of every case is flown in one batch over the same dispersed runs as the
   current table (common random numbers).  A case's best candidate (fewer failures first,
   then fewer repeated firings) is taken only when its improvement is significant on those
   paired runs: the exact one-sided McNemar test of :mod:`rcsim.analysis.apps.refinement.gate`.
   A candidate is flown on every searched case whose runs fire its row (each run records the
   rows it fired), judged on all of them (its gain pooled; no case significantly worse, Holm
   over the cases).  Changes whose runs interact are taken one after the other, each of the
   others judged again on runs that include the one taken (flying only the runs it moves).
4. The accepted changes' runs are their candidates' (no re-fly), and 2-3 repeat
   until every case is robust, no entry is left to try, or ``max_iterations`` is reached.
   The best table flown (fewest failures, then repeated firings, over all searched cases)
   is the search's.
5. With a confirmation seed, every changed row (and the mirror row of a changed case on a
   symmetric vehicle) is flown before and after on that seed's runs, and kept only if the
   improvement holds there too (Holm over the rows); the others go back to the original row.

The search flies a subset of each case's runs, the first ``search_runs_per_case`` (200 by
default) of the campaign's own draws: its cost scales with the evidence a decision needs, not
with the campaign (a 26 x 1,000 campaign is searched on 26 x 200 runs).

:func:`rcsim.analysis.apps.refinement.outputs.held_out_check` then flies a third seed, which no
decision used.
"""

from __future__ import annotations

import hashlib
import pickle
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.evaluate import Trials, evaluate
from rcsim.analysis.apps.refinement.evidence import (
    add_propellant,
    evidence_frame,
    refused_candidates,
    test_dict,
)
from rcsim.analysis.apps.refinement.gate import (
    ALPHA,
    FAILED,
    PairedTest,
    mirror_rows,
    paired_test,
    worse_cases,
    worse_text,
)
from rcsim.analysis.apps.refinement.propellant import MAX_RISE, propellant_check
from rcsim.analysis.engine.campaign.spec import CampaignSpec
from rcsim.analysis.results.proportions import holm
from rcsim.analysis.results.scoring import (
    offending_runs,
    rows_fired_by_trial,
    score_key,
    total,
    trial_scores,
)
from rcsim.lookup.table_edits import axis_cycles, jet_axes, shift_axes, with_times
from rcsim.models.atomic import atomic_write
from rcsim.models.tables import AXES, LookupTable

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
        Per iteration: candidates flown, cases changed, totals after, and per case whose best
        candidate was strictly better the gate's test (``decisions``).
    runs_flown : int
    evidence : DataFrame, optional
        Per searched case, the evidence of its change (:func:`evidence_frame`): the search
        seed's paired test of the original row against the final one, the confirmation
        seed's, the decision and the mirror case's.
    """

    table: LookupTable
    before: pd.DataFrame
    after: pd.DataFrame
    iterations: list = field(default_factory=list)
    runs_flown: int = 0
    evidence: pd.DataFrame | None = None


#: Runs per case the search flies by default: the first 200 of each case's campaign runs (the
#: same draws).  Enough to tell a candidate that removes failures at a rate of a few percent
#: from one that does not; the held-out check then flies every run at full size.
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
    confirm_seed: int | None = None,
    alpha: float = ALPHA,
    max_propellant_rise: float = MAX_RISE,
    plugin=None,
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
        :func:`~rcsim.analysis.apps.refinement.evaluate.runs_from_campaign`); default: fly them.
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
    confirm_seed : int, optional
        The confirmation seed (step 5 of the module docstring): every changed row is flown
        before and after on all ``spec.runs_per_case`` runs of that seed, and kept only if its
        improvement holds there (Holm at ``alpha`` over the rows).  None: no confirmation (the
        search gate alone).
    alpha : float
        Level of each paired test (:data:`rcsim.analysis.apps.refinement.gate.ALPHA`).
    max_propellant_rise : float
        Largest rise of a case's mean propellant (a fraction) judged on failures alone; a
        change raising it more must pay with failures, on the search and on the confirmation
        seed (:mod:`rcsim.analysis.apps.refinement.propellant`).
    plugin : rcsim.lookup.table_plugins.TablePlugin, optional
        A plug-in that flies every candidate instead of the built-in lookup controller.
    """
    if len(spec.cases) != len(table.case):
        raise ValueError(f"spec has {len(spec.cases)} cases, the table {len(table.case)}")
    if max_iterations < 1:
        raise ValueError(f"max_iterations must be >= 1, got {max_iterations}")
    if search_runs_per_case is not None and search_runs_per_case < 1:
        raise ValueError(f"search_runs_per_case must be >= 1, got {search_runs_per_case}")
    cases = np.arange(len(table.case)) if cases is None else np.asarray(sorted(set(cases)), int)
    if not max_propellant_rise >= 0:
        raise ValueError(f"max_propellant_rise must be >= 0, got {max_propellant_rise}")
    if confirm_seed is not None and confirm_seed == spec.seed:
        raise ValueError("the confirmation seed must differ from the search seed")
    search = _Search(
        spec,
        table,
        cases,
        dict(threads=threads, progress=progress, lookup_params=lookup_params, plugin=plugin),
        min(spec.runs_per_case, search_runs_per_case or spec.runs_per_case),
        alpha,
        max_propellant_rise,
    )
    key = (
        _checkpoint_key(
            spec, table, cases, max_iterations, search.runs_per_case, confirm_seed, alpha
        )
        + f"|propellant {max_propellant_rise!r}"
        + ("" if plugin is None else f"|plugin {plugin.name!r} {plugin.params!r} {plugin.record!r}")
    )
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
    final, after, evidence = search.confirm(confirm_seed)
    evidence["refused"] = refused_candidates(search.iterations, table.case[cases])
    if checkpoint is not None:
        Path(checkpoint).unlink(missing_ok=True)
    refined = with_times(table, final, source=f"refined from {table.source or 'a table'}")
    return RefineResult(
        table=refined,
        before=search.before,
        after=after,
        iterations=search.iterations,
        runs_flown=search.flown,
        evidence=evidence,
    )


#: What a checkpoint keeps of a :class:`_Search` (everything a round reads or changes).
_STATE = (
    "current",
    "runs",
    "scores",
    "before",
    "base",
    "best",
    "iterations",
    "flown",
    "visited",
)


def _checkpoint_key(spec, table, cases, max_iterations, runs_per_case, confirm_seed, alpha) -> str:
    """A digest of everything the search's result depends on: a checkpoint of another search
    (another spec, table, cases, subset, confirmation seed or level, or a search without the
    gate) is never continued."""
    parts = [
        "gate-2",
        spec.digest(),
        np.asarray(table.firing_time_s, float).tobytes().hex(),
        np.asarray(cases).tobytes().hex(),
        str(max_iterations),
        str(runs_per_case),
        str(confirm_seed),
        repr(float(alpha)),
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
        alpha: float = ALPHA,
        max_rise: float = MAX_RISE,
    ):
        self.spec, self.table, self.cases, self.kw = spec, table, cases, kw
        self.runs_per_case = runs_per_case
        self.alpha = alpha
        self.max_rise = max_rise
        self.jet_axis = jet_axes(table)
        self.cycle_s = spec.cycle_s  # the flown vehicle's: candidates move whole cycles of it
        self.threshold_deg_s = float(np.degrees(spec.rate_threshold_rad_s))
        self.current = np.asarray(table.firing_time_s, float)
        self.iterations: list = []
        self.flown = 0
        # Entries already flown, per case (its firing cycles per axis): a candidate that
        # returns to one of them (the step back after a step that helped) or repeats a
        # rejected one is not flown again.  Other entries may have changed since, which could
        # shift the verdict slightly; the re-fly after each round measures what is kept.
        self.visited = {
            (int(c), tuple(axis_cycles(self.current, self.jet_axis, self.cycle_s)[c]))
            for c in cases
        }

    def _fly(
        self, times: np.ndarray, trial_cases: np.ndarray, desc: str, spec=None, runs_per_case=-1
    ) -> pd.DataFrame:
        trials = Trials(
            np.repeat(times[None], trial_cases.size, axis=0),
            trial_cases,
            tuple(f"case {c + 1}: current" for c in trial_cases),
        )
        runs = evaluate(
            self.spec if spec is None else spec,
            self.table,
            trials,
            desc=desc,
            runs_per_case=self.runs_per_case if runs_per_case == -1 else runs_per_case,
            **self.kw,
        )
        self.flown += len(runs)
        return runs

    def start(self, baseline_runs: pd.DataFrame | None) -> None:
        """Step 1: the table's own runs, flown or taken from the campaign that flew them."""
        if baseline_runs is None or "rows_fired" not in baseline_runs:
            # A campaign's runs do not record which table rows each run fired, which the
            # search needs (a changed row is judged on every case whose runs fire it): the
            # same runs are flown again, recording it (bit for bit the campaign's).
            self.runs = self._fly(self.current, self.cases, "refine: baseline")
        else:
            mine = baseline_runs[baseline_runs["k"] < self.runs_per_case]
            self.runs = mine.reset_index(drop=True)
        self.scores = trial_scores(self.runs, self.cases.size)
        self.before = self.scores.assign(case_index=self.cases)
        self.base = self.runs  # the original table's runs: the changelog's "before"
        self.best = (self.current, self.before, self.runs)

    def candidates(self) -> tuple[Trials | None, list]:
        """Step 2: one axis per non-robust case, one cycle shorter and longer, each flown on
        every searched case whose runs fire the case's row (a correction firing picks its row
        by the sign pattern of the rate error, so a row flies in other cases' runs too; a run
        that never fires the row is unchanged by it, bit for bit).  All in one batch.

        Returns the trials and, per candidate, ``(position of its case, shift, positions it
        is flown on, its trials)``."""
        offending = offending_runs(self.runs, self.threshold_deg_s, self.cases.size)
        fired = rows_fired_by_trial(self.runs, self.cases.size)
        found_all = []
        for t, c in enumerate(self.cases):
            if score_key(self.scores.iloc[t]) == (0, 0):
                continue
            # One axis per case and round: the one most runs fail or re-fire on (the paper's
            # yaw), before axes with a stray run or two; the next round moves on if it does
            # not help (its entries are then visited).
            for a in sorted(np.flatnonzero(offending[t]), key=lambda a: -offending[t, a]):
                found = self._axis_candidates(t, int(c), int(a))
                for candidate, label, shift in found:
                    found_all.append((t, int(c), candidate, label, shift))
                if found:
                    break
        if not found_all:
            return None, []
        times: list = []
        labels: list = []
        trial_case: list = []
        trial_k: list = []
        edits: list = []
        every = np.arange(self.runs_per_case)
        for t, c, candidate, label, shift in found_all:
            # Its own case first, then every other searched case whose runs fire row c: of
            # those, only the runs that fire it (the others are unchanged, bit for bit).
            others = np.flatnonzero((fired >> np.int64(c)) & 1)
            positions = np.array([t, *[int(p) for p in others if p != t]], int)
            first = len(times)
            for p in positions:
                times.append(candidate)
                labels.append(label)
                trial_case.append(int(self.cases[p]))
                if p == t:
                    trial_k.append(every)
                else:
                    mine = self.runs[self.runs["trial"] == p]
                    fires = ((mine["rows_fired"].to_numpy(np.int64) >> np.int64(c)) & 1) > 0
                    trial_k.append(mine["k"].to_numpy(int)[fires])
            edits.append((t, shift, positions, np.arange(first, len(times))))
        trials = Trials(np.array(times), np.array(trial_case), tuple(labels), tuple(trial_k))
        return trials, edits

    def _axis_candidates(self, t: int, c: int, a: int) -> list:
        """Case ``c``'s axis ``a`` one cycle either way, the entries not flown yet."""
        found = []
        for step in STEP_CYCLES:
            shift = np.zeros((len(self.table.case), len(AXES)), int)
            shift[c, a] = step
            try:
                candidate = shift_axes(self.current, self.jet_axis, shift, self.cycle_s)
            except ValueError:  # would leave less than a cycle: not a candidate
                continue
            state = (int(c), tuple(axis_cycles(candidate, self.jet_axis, self.cycle_s)[c]))
            if state in self.visited:
                continue
            self.visited.add(state)
            found.append(
                (candidate, f"case {c + 1}: {self._axis_name(c, a)} {step:+d} cycle", shift)
            )
        return found

    def _axis_name(self, c: int, a: int) -> str:
        """How a move is named: the axis (``yaw``), or for a channel table the channel
        (``+yaw channel``: its columns are channels, named by the axis and sign they turn)."""
        if self.table.recipe is None:
            return AXES[a]
        sign = "+" if self.table.rate_cmd[c, a] > 0 else "-"
        return f"{sign}{AXES[a]} channel"

    def _pooled(self, runs: pd.DataFrame, positions: np.ndarray) -> pd.DataFrame:
        """The runs of ``positions`` as one paired sample: ``k`` numbered across the cases
        (position-major), ``case_index`` kept."""
        parts = []
        for i, p in enumerate(positions):
            mine = runs[runs["trial"] == p].sort_values("k")
            parts.append(mine.assign(k=mine["k"] + i * self.runs_per_case))
        return pd.concat(parts, ignore_index=True)

    def _judge(self, t: int, positions: np.ndarray, cand: pd.DataFrame, label: str) -> dict:
        """One candidate's verdict on the paired runs of every case at ``positions`` (its own
        case ``t`` first): the current table's runs against the candidate's ``cand``."""
        before = self._pooled(self.runs, positions)
        after = self._pooled(cand, positions)
        # Strictly better is not enough: the gain must be significant on the paired runs (a
        # change resting on a run or two in 200 is noise), over every case the row flies in.
        test = paired_test(before, after, self.alpha)
        # Propellant, the second objective: a rise of the case's own mean beyond max_rise
        # must be paid for.
        fuel = propellant_check(
            self.runs[self.runs["trial"] == t], cand[cand["trial"] == t], self.max_rise
        )
        # No case may get significantly worse (Holm over the cases it flies in).
        harm = worse_text(
            worse_cases(before, after, self.alpha, test.outcome) if test.passed else []
        )
        return {
            "candidate": label,
            **test_dict(test),
            "accepted": bool(test.passed and fuel.passes and not harm),
            "test_passed": bool(test.passed),
            "cases_judged": [int(self.cases[p]) + 1 for p in positions],
            "propellant_change_pct": fuel.rise_pct,
            "propellant_refused": fuel.reason,
            "worse_refused": harm,
        }

    def round(self, number: int, trials: Trials, edits: list) -> None:
        """Steps 3-4: fly the candidates on every case whose runs fire their rows, keep each
        case's best if its gain over all those cases is significant and no case gets
        significantly worse; changes whose runs interact (they share a run, or one's runs
        fire the other's row) are not taken together: the one with the smaller p is, and the
        others are judged again on runs that include it (a *wave*: one batched flight of only
        the runs the taken changes can move), until none is left."""
        cand_runs = evaluate(
            self.spec,
            self.table,
            trials,
            desc=f"refine: round {number} candidates",
            runs_per_case=self.runs_per_case,
            **self.kw,
        )
        self.flown += len(cand_runs)
        # Each candidate's runs, with ``trial`` the position of the case they fly.
        flown_of = []
        for _t, _shift, positions, trial_ids in edits:
            mine = cand_runs[cand_runs["trial"].isin(trial_ids)]
            pos_of_trial = dict(zip(trial_ids.tolist(), positions.tolist()))
            mine = mine.assign(trial=mine["trial"].map(pos_of_trial))
            # The runs not flown (another case's runs that do not fire the row) are the
            # current table's, unchanged.
            same = self.runs[self.runs["trial"].isin(positions)]
            flown_keys = set(zip(mine["trial"].tolist(), mine["k"].tolist()))
            keep = [
                (p, k) not in flown_keys for p, k in zip(same["trial"].tolist(), same["k"].tolist())
            ]
            flown_of.append(
                pd.concat([mine, same[keep]], ignore_index=True)
                .sort_values(["trial", "k"], kind="stable")
                .reset_index(drop=True)
            )
        scores_now = self.scores
        proposals, decisions = [], []
        for t in np.unique([e[0] for e in edits]):
            mine = [i for i, e in enumerate(edits) if e[0] == t]

            def pooled_key(i: int) -> tuple[int, int]:
                sc = trial_scores(flown_of[i], self.cases.size)
                return score_key(sc.iloc[edits[i][2]].sum())

            # Best candidate first: fewest failures, then fewest repeated firings, over every
            # case it flies in; first wins a tie (shorter before longer), so the search is
            # deterministic.
            for i in sorted(mine, key=pooled_key):
                positions = edits[i][2]
                if not pooled_key(i) < score_key(scores_now.iloc[positions].sum()):
                    break
                verdict = self._judge(t, positions, flown_of[i], trials.label[edits[i][3][0]])
                decisions.append(verdict)
                ok = verdict["accepted"]
                test_passed = verdict["test_passed"]
                if ok:
                    proposals.append((verdict["p"], i, len(decisions) - 1))
                    break
                if not test_passed:
                    # Only a candidate refused for its propellant or for a case it harms
                    # gives way to the next best (the other direction may do better).
                    break
        changed: list = []
        positions_of = {i: edits[i][2] for _p, i, _d in proposals}
        pending = proposals
        wave = 0
        while pending:
            # Changes whose runs do not interact are taken together (taking them one after
            # the other would fly the same runs); the one with the smaller p first.
            taken: list = []
            deferred = []
            for _p, i, d in sorted(pending, key=lambda x: (x[0], x[1])):
                t = edits[i][0]
                positions = positions_of[i]
                row = int(self.cases[t])
                fires = int(np.bitwise_or.reduce(rows_fired_by_trial(flown_of[i], self.cases.size)))
                clash = [
                    o_row + 1
                    for o_row, o_positions, o_fires, _ in taken
                    if set(positions.tolist()) & set(o_positions.tolist())
                    or (fires >> o_row) & 1
                    or (o_fires >> row) & 1
                ]
                if clash:
                    decisions[d]["accepted"] = False
                    decisions[d]["deferred"] = (
                        f"its runs interact with case {clash[0]}'s change, taken first: "
                        "judged again"
                    )
                    deferred.append(i)
                    continue
                taken.append((row, positions, fires, i))
                changed.append(decisions[d]["candidate"])
            wave_shift = np.sum([edits[i][1] for *_, i in taken], axis=0)
            self.current = shift_axes(self.current, self.jet_axis, wave_shift, self.cycle_s)
            # The taken changes' runs are their candidates' runs: every case whose runs fire
            # a changed row was flown with it (and with no other change taken with it: they
            # do not interact), every other case's runs are unchanged bit for bit.
            replaced = np.concatenate([positions for _, positions, _, _ in taken])
            kept = self.runs[~self.runs["trial"].isin(replaced)]
            moved = [flown_of[i][flown_of[i]["trial"].isin(pos)] for _, pos, _, i in taken]
            self.runs = (
                pd.concat([kept, *moved], ignore_index=True)
                .sort_values(["trial", "k"], kind="stable")
                .reset_index(drop=True)
            )
            self.scores = trial_scores(self.runs, self.cases.size)
            if not deferred:
                break
            # Judge the others again on runs that include the taken changes, in one batch:
            # a candidate's run is the current one where the current run does not fire its
            # row, its earlier run where that did not fire a taken row, else flown again.
            wave += 1
            taken_rows = sum(1 << r for r, *_ in taken)
            fired_now = rows_fired_by_trial(self.runs, self.cases.size)
            plan = []
            for i in deferred:
                t, shift = edits[i][0], edits[i][1]
                row = int(self.cases[t])
                candidate = shift_axes(self.current, self.jet_axis, shift, self.cycle_s)
                others = np.flatnonzero((fired_now >> np.int64(row)) & 1)
                positions = np.array(
                    [t, *sorted({int(p) for p in [*others, *positions_of[i]]} - {t})], int
                )
                now = self.runs[self.runs["trial"].isin(positions)]
                earlier = flown_of[i].set_index(["trial", "k"])
                reuse: list = []
                fly_k: dict = {int(p): [] for p in positions}
                for r in now.itertuples(index=False):
                    key = (int(r.trial), int(r.k))
                    if not (int(r.rows_fired) >> row) & 1:
                        reuse.append(("now", key))
                    elif key in earlier.index and not (
                        int(earlier.loc[key, "rows_fired"]) & taken_rows
                    ):
                        reuse.append(("earlier", key))
                    else:
                        fly_k[key[0]].append(key[1])
                plan.append((i, candidate, positions, reuse, fly_k))
            times, cases_, ks, owner = [], [], [], []
            for i, candidate, _positions, _reuse, fly_k in plan:
                for p, k in fly_k.items():
                    if k:
                        times.append(candidate)
                        cases_.append(int(self.cases[p]))
                        ks.append(np.array(k, int))
                        owner.append((i, p))
            again = None
            if times:
                again = evaluate(
                    self.spec,
                    self.table,
                    Trials(np.array(times), np.array(cases_), ("again",) * len(times), tuple(ks)),
                    desc=f"refine: round {number} judged again",
                    runs_per_case=self.runs_per_case,
                    **self.kw,
                )
                self.flown += len(again)
            pending = []
            now_by_key = self.runs.set_index(["trial", "k"])
            for i, _candidate, positions, reuse, _fly_k in plan:
                parts = []
                for where, key in reuse:
                    src = now_by_key if where == "now" else flown_of[i].set_index(["trial", "k"])
                    parts.append(src.loc[[key]].reset_index())
                if again is not None:
                    for j, (o, p) in enumerate(owner):
                        if o == i:
                            parts.append(again[again["trial"] == j].assign(trial=p))
                runs_i = (
                    pd.concat(parts, ignore_index=True)
                    .sort_values(["trial", "k"], kind="stable")
                    .reset_index(drop=True)
                )
                flown_of[i] = runs_i
                positions_of[i] = positions
                verdict = self._judge(edits[i][0], positions, runs_i, trials.label[edits[i][3][0]])
                verdict["judged_again"] = f"wave {wave}"
                decisions.append(verdict)
                if verdict["accepted"]:
                    pending.append((verdict["p"], i, len(decisions) - 1))
        if not changed:
            # Nothing helped: the table and its runs stand; the next round tries the entries
            # not flown yet (other axes), and the search ends when there are none.
            self.iterations.append(
                {
                    "round": number,
                    "candidates": trials.n_trials,
                    "changed": [],
                    "decisions": decisions,
                }
            )
            return
        self.scores = trial_scores(self.runs, self.cases.size)
        totals = self.scores[["failed", "repeated"]].sum()
        self.iterations.append(
            {
                "round": number,
                "candidates": trials.n_trials,
                "changed": changed,
                "decisions": decisions,
                "failed": int(totals["failed"]),
                "repeated": int(totals["repeated"]),
            }
        )
        if total(self.scores) < total(self.best[1]):
            self.best = (self.current, self.scores.assign(case_index=self.cases), self.runs)

    def confirm(self, confirm_seed: int | None) -> tuple[np.ndarray, pd.DataFrame, pd.DataFrame]:
        """Step 5: the confirmation gate on ``confirm_seed`` (None: none).  Returns the final
        times, the per-case scores on the search seed and :func:`evidence_frame`'s rows."""
        from dataclasses import replace

        orig = np.asarray(self.table.firing_time_s, float)
        best, runs = self.best[0], self.best[2]
        c_orig = axis_cycles(orig, self.jet_axis, self.cycle_s)
        c_best = axis_cycles(best, self.jet_axis, self.cycle_s)
        pos = {int(c): t for t, c in enumerate(self.cases)}
        changed = [t for t, c in enumerate(self.cases) if (c_best[c] != c_orig[c]).any()]
        mirror = mirror_rows(self.table.rate_cmd)
        # The paper vehicle's jets come in pairs mirrored through the centre of mass, and
        # the Table 5 dispersions are symmetric: a case and its mirror (every rate command
        # negated) are the same problem flown on the opposite jets.  Another vehicle file is
        # not assumed symmetric.
        symmetric = self.spec.vehicle.ref == "paper"
        final = best.copy()
        source: dict[int, int] = {}  # mirror row position -> the changed case's position
        notes: dict[int, str] = {}
        for t in changed:
            c = int(self.cases[t])
            m = int(mirror[c])
            if m < 0 or m not in pos or pos[m] in changed or pos[m] in source:
                continue
            if not symmetric:
                notes[pos[m]] = "a vehicle file: mirror symmetry not assumed"
                continue
            if (c_orig[m] != c_orig[c]).any():
                notes[pos[m]] = "the original table's rows differ: the change does not carry over"
                continue
            shift = np.zeros_like(c_orig)
            shift[m] = c_best[c] - c_orig[c]
            try:
                final = shift_axes(final, self.jet_axis, shift, self.cycle_s)
            except ValueError:
                notes[pos[m]] = "the mirrored change would leave less than a cycle"
                continue
            source[pos[m]] = t
        # Search-seed runs of every row as finally proposed (mirror rows flown once here).
        search_runs = {t: runs[runs["trial"] == t] for t in range(self.cases.size)}
        if source:
            mt = np.array(sorted(source))
            fresh = self._fly(final, self.cases[mt], "refine: mirror rows, search seed")
            for i, t in enumerate(mt):
                search_runs[int(t)] = fresh[fresh["trial"] == i].assign(trial=int(t))
        search_tests = {
            t: paired_test(self.base[self.base["trial"] == t], search_runs[t], self.alpha)
            for t in range(self.cases.size)
        }
        search_fuel = {
            t: propellant_check(self.base[self.base["trial"] == t], search_runs[t], self.max_rise)
            for t in range(self.cases.size)
        }
        involved = sorted([*changed, *source])
        confirm_tests: dict[int, PairedTest] = {}
        confirm_fuel = {}
        kept = {t: True for t in involved}
        if confirm_seed is not None and involved:
            spec = replace(self.spec, seed=int(confirm_seed))
            rows = self.cases[np.array(involved)]
            # All runs of the confirmation seed (spec.runs_per_case), the original and the
            # final table over the same runs.
            trials = Trials(
                np.concatenate(
                    [np.repeat(orig[None], len(rows), 0), np.repeat(final[None], len(rows), 0)]
                ),
                np.tile(rows, 2),
                tuple(["original"] * len(rows) + ["refined"] * len(rows)),
            )
            flown = evaluate(spec, self.table, trials, desc="refine: confirmation seed", **self.kw)
            self.flown += len(flown)
            for i, t in enumerate(involved):
                decided = search_tests[source.get(t, t)].outcome
                pair = flown[flown["trial"] == i], flown[flown["trial"] == i + len(rows)]
                confirm_tests[t] = paired_test(*pair, self.alpha, outcome=decided)
                confirm_fuel[t] = propellant_check(*pair, self.max_rise)
            p = np.array([confirm_tests[t].p for t in involved])
            held = holm(p, self.alpha)
            for j, t in enumerate(involved):
                ct = confirm_tests[t]
                kept[t] = (
                    bool(held[j])
                    and (ct.outcome == FAILED or ct.failed_after <= ct.failed_before)
                    and confirm_fuel[t].passes
                )
        for t in involved:
            if not kept[t]:
                c = int(self.cases[t])
                final[c] = orig[c]
                search_runs[t] = self.base[self.base["trial"] == t]
        after_runs = pd.concat(search_runs.values(), ignore_index=True)
        after = trial_scores(after_runs, self.cases.size).assign(case_index=self.cases)
        evidence = evidence_frame(
            self.table,
            self.cases,
            final,
            self.jet_axis,
            search_tests,
            confirm_tests,
            kept,
            source,
            notes,
            confirm_seed is not None,
            self.cycle_s,
        )
        add_propellant(evidence, search_fuel, confirm_fuel, kept)
        return final, after, evidence
