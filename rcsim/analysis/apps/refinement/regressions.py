"""The held-out check of every case: which cases the refined table made significantly worse,
and which changed rows cause it.

A correction firing picks its table row by the sign pattern of the rate error, so a changed
row also flies in other cases' runs: a change the search judged on its own evidence can still
harm a case on a seed no decision used.  Here, on the held-out seed (the original and the
refined table on the same runs):

1. **Per case**, the exact one-sided McNemar test that the case got worse (failed runs), Holm
   over the cases (:func:`~rcsim.analysis.apps.refinement.gate.worse_cases`): every case named
   worse is a regression.
2. **Cause.**  For each regression, the refined table with one changed row reverted at a time
   is flown on that case's held-out runs (one batch); a row *causes* the regression when, with
   it reverted, the case is no longer worse than with the original table (the same one-sided
   test at the level, unadjusted: a row is cleared only when the case's runs no longer show
   harm).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.evaluate import Trials, evaluate
from rcsim.analysis.apps.refinement.gate import ALPHA, FAILED, CaseWorse, worse_cases
from rcsim.analysis.results.proportions import mcnemar_one_sided


@dataclass
class Regressions:
    """The held-out check of every case.

    Attributes
    ----------
    per_case : list of CaseWorse
        Every searched case, original against refined table on the held-out runs.
    causes : dict
        Case index of each regression -> the changed rows (0-based) whose revert removes it.
    reverted_failed : dict
        ``(case index, row)`` -> failed runs of the case with that row reverted.
    runs_flown : int
    """

    per_case: list
    causes: dict = field(default_factory=dict)
    reverted_failed: dict = field(default_factory=dict)
    runs_flown: int = 0

    @property
    def worse(self) -> list[CaseWorse]:
        return [w for w in self.per_case if w.worse]

    @property
    def rows_to_drop(self) -> list[int]:
        """The changed rows that cause some regression (sorted)."""
        return sorted({r for rows in self.causes.values() for r in rows})

    def text(self, seed: int, case_numbers) -> str:
        """One sentence per regression, e.g. ``case 6 is significantly worse on held-out seed
        2 (failed 10 -> 33 of 40; 23:0 runs worse:better, Holm p=1.2e-07), caused by case
        21's row (reverted: 10 failed)``; "" when none."""
        out = []
        for w in self.worse:
            head = (
                f"case {int(case_numbers[w.case_index])} is significantly worse on held-out "
                f"seed {seed} (failed {w.failed_before} -> {w.failed_after} of {w.runs}; "
                f"{w.c}:{w.b} runs worse:better, Holm p={w.p_holm:.2g})"
            )
            rows = self.causes.get(w.case_index, [])
            if rows:
                why = " and ".join(
                    f"case {int(case_numbers[r])}'s row (reverted: "
                    f"{self.reverted_failed[(w.case_index, r)]} failed)"
                    for r in rows
                )
                out.append(f"{head}, caused by {why}")
            else:
                out.append(f"{head}; no single changed row's revert removes it")
        return "; ".join(out)


def find_regressions(
    spec,
    original,
    refined,
    before: pd.DataFrame,
    after: pd.DataFrame,
    *,
    alpha: float = ALPHA,
    **fly,
) -> Regressions:
    """:mod:`this module <rcsim.analysis.apps.refinement.regressions>`'s check.

    ``spec``: the held-out seed's campaign; ``original`` / ``refined``: the tables; ``before``
    / ``after``: their scoring frames on ``spec``'s runs (``case_index, k, failed,
    repeated``); ``fly``: :func:`~rcsim.analysis.apps.refinement.evaluate.evaluate`'s keywords
    (threads, progress).
    """
    per_case = worse_cases(before, after, alpha, FAILED)
    found = Regressions(per_case)
    worse = [w.case_index for w in found.worse]
    old = np.asarray(original.firing_time_s, float)
    new = np.asarray(refined.firing_time_s, float)
    changed = [int(r) for r in np.flatnonzero((old != new).any(axis=1))]
    if not worse or not changed:
        return found
    times, cases = [], []
    for r in changed:
        reverted = new.copy()
        reverted[r] = old[r]
        for c in worse:
            times.append(reverted)
            cases.append(c)
    trials = Trials(np.array(times), np.array(cases), tuple(f"row {r + 1} reverted" for r in cases))
    runs = evaluate(spec, original, trials, desc="refine: held-out regressions", **fly)
    found.runs_flown = len(runs)
    i = 0
    for r in changed:
        for c in worse:
            mine = runs[runs["trial"] == i].set_index("k").sort_index()
            base = before[before["case_index"] == c].set_index("k").sort_index()
            fb, fr = base["failed"].to_numpy(bool), mine["failed"].to_numpy(bool)
            better, harmed = int((fb & ~fr).sum()), int((~fb & fr).sum())
            found.reverted_failed[(c, r)] = int(fr.sum())
            if float(mcnemar_one_sided(harmed, better)) > alpha:
                found.causes.setdefault(c, []).append(r)
            i += 1
    return found


def regression_columns(found: Regressions, searched: np.ndarray, case_numbers) -> pd.DataFrame:
    """Per searched case (changelog order): ``held_out_better_runs``, ``held_out_worse_runs``,
    ``held_out_worse_p_holm``, ``held_out_regression`` (significantly worse) and
    ``held_out_regression_rows`` (the cases whose changed rows cause it, e.g. ``case 21``)."""
    by_case = {w.case_index: w for w in found.per_case}
    rows = []
    for c in searched:
        w = by_case.get(int(c))
        rows.append(
            {
                "held_out_better_runs": w.b if w else 0,
                "held_out_worse_runs": w.c if w else 0,
                "held_out_worse_p_holm": w.p_holm if w else 1.0,
                "held_out_regression": bool(w and w.worse),
                "held_out_regression_rows": ", ".join(
                    f"case {int(case_numbers[r])}" for r in found.causes.get(int(c), [])
                ),
            }
        )
    return pd.DataFrame(rows)
