"""When the refinement may change a table row: the evidence rule.

A 200-run search that takes any strictly better candidate also takes changes resting on one
failure in 200 runs, which a fresh seed does not confirm.  A row change is therefore kept only
when it passes two gates:

1. **Search gate, per decision.**  A candidate and the current table are flown over the same
   dispersed runs (common random numbers), so the natural test is paired: the exact McNemar
   test on the discordant runs (bad before and good after: ``b``; good before and bad after:
   ``c``), one-sided, ``p = P(X >= b)`` with ``X ~ Binomial(b + c, 1/2)``
   (:func:`rcsim.analysis.results.proportions.mcnemar_one_sided`).  "Bad" is *failed* first; a
   candidate that does not remove failures significantly may still pass on *failed or
   repeated* (the search's second objective) if it fails no more runs than the current table.
   Level :data:`ALPHA` per decision, no adjustment: the search is the screen, and the
   multiplicity of its candidates, cases and rounds is paid at the second gate.
2. **Confirmation gate, family-wise.**  Every row the search changed (and, on a symmetric
   vehicle, its mirror row, see :func:`mirror_rows`) is flown before and after on the runs of
   a seed the search never saw (the *confirmation seed*), and tested again the same way, on the
   outcome that decided it on the search.  The tests of all changed rows are one family,
   Holm-adjusted at :data:`ALPHA` (:func:`rcsim.analysis.results.proportions.holm`): the chance that
   any kept change is no improvement is at most ``ALPHA``, whatever the search tried, because
   the confirmation runs are independent of the search's choices.  A row that fails the
   confirmation goes back to the original table's row.

The held-out check (:func:`rcsim.analysis.apps.refinement.outputs.held_out_check`) then flies the
final table on a third seed, used by no decision: its figures are an unbiased estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from rcsim.analysis.results.proportions import mcnemar_one_sided

#: Level of each one-sided McNemar test, and the family-wise level of the confirmation.
ALPHA = 0.05

#: Outcomes a decision can rest on: the run failed; the run failed or needed repeated firings.
FAILED, BAD = "failed", "failed or repeated"


@dataclass(frozen=True)
class PairedTest:
    """One paired comparison of a row's runs before and after a change (same runs).

    ``outcome``: what decided (``FAILED`` or ``BAD``); ``b`` / ``c``: discordant runs (better /
    worse after); ``p``: one-sided exact McNemar p-value on ``outcome``; ``failed_*`` and
    ``repeated_*``: counts before and after; ``passed``: at level ``alpha``.
    """

    outcome: str
    b: int
    c: int
    p: float
    failed_before: int
    failed_after: int
    repeated_before: int
    repeated_after: int
    runs: int
    passed: bool


def _paired(before: pd.DataFrame, after: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The two frames' runs aligned on ``k`` (the same dispersed vehicles)."""
    b = before.set_index("k").sort_index()
    a = after.set_index("k").sort_index()
    if not b.index.equals(a.index):
        raise ValueError("before and after must fly the same runs (same k)")
    return b, a


def _discordant(before: np.ndarray, after: np.ndarray) -> tuple[int, int]:
    return int((before & ~after).sum()), int((~before & after).sum())


def paired_test(
    before: pd.DataFrame, after: pd.DataFrame, alpha: float = ALPHA, outcome: str | None = None
) -> PairedTest:
    """The gate's test of one row change on paired runs (``k, failed, repeated`` per run).

    ``outcome`` None: the search's rule -- significant on failed runs, or else on failed-or-
    repeated runs with no more failures after; given: the test on that outcome only (the
    confirmation, which re-tests what decided on the search), again with no more failures
    after when it is ``BAD``.
    """
    b_runs, a_runs = _paired(before, after)
    fb, fa = b_runs["failed"].to_numpy(bool), a_runs["failed"].to_numpy(bool)
    rb, ra = b_runs["repeated"].to_numpy(bool), a_runs["repeated"].to_numpy(bool)
    counts = dict(
        failed_before=int(fb.sum()),
        failed_after=int(fa.sum()),
        repeated_before=int(rb.sum()),
        repeated_after=int(ra.sum()),
        runs=int(fb.size),
    )
    tests = {}
    for name, x_b, x_a in ((FAILED, fb, fa), (BAD, fb | rb, fa | ra)):
        d_b, d_c = _discordant(x_b, x_a)
        tests[name] = (d_b, d_c, float(mcnemar_one_sided(d_b, d_c)))
    no_more_failures = counts["failed_after"] <= counts["failed_before"]
    if outcome is None:
        outcome = FAILED if tests[FAILED][2] <= alpha or not no_more_failures else BAD
        if outcome == BAD and tests[BAD][2] > alpha:
            # Neither passes: report the outcome that moved more (what the search chose on).
            outcome = FAILED if counts["failed_after"] < counts["failed_before"] else BAD
    d_b, d_c, p = tests[outcome]
    passed = p <= alpha and (outcome == FAILED or no_more_failures)
    return PairedTest(outcome, d_b, d_c, p, passed=bool(passed), **counts)


def mirror_rows(rate_cmd: np.ndarray) -> np.ndarray:
    """Index of each row's mirror: the row whose rate command is its negation (all three
    signs flipped; -1 if none).  With Table 3's 26 cases in their order, row ``i`` mirrors row
    ``25 - i`` (case 3 (-,-,+) and case 24 (+,+,-); case 2 (-,-,0) and case 25 (+,+,0))."""
    signs = np.sign(np.asarray(rate_cmd, float))
    out = np.full(len(signs), -1, int)
    for i, s in enumerate(signs):
        match = np.flatnonzero((signs == -s).all(axis=1))
        if match.size:
            out[i] = int(match[0])
    return out


@dataclass(frozen=True)
class CaseWorse:
    """One case's paired comparison for harm: ``b`` / ``c`` runs better / worse after on
    ``outcome``, ``p`` the one-sided exact McNemar p-value that the case got worse, ``p_holm``
    Holm-adjusted over the cases compared, ``worse``: significant at the level."""

    case_index: int
    outcome: str
    b: int
    c: int
    p: float
    p_holm: float
    worse: bool
    failed_before: int
    failed_after: int
    runs: int


def _bad(frame: pd.DataFrame, outcome: str) -> np.ndarray:
    failed = frame["failed"].to_numpy(bool)
    return failed if outcome == FAILED else failed | frame["repeated"].to_numpy(bool)


def worse_cases(
    before: pd.DataFrame, after: pd.DataFrame, alpha: float = ALPHA, outcome: str = FAILED
) -> list[CaseWorse]:
    """Per case, whether the change made it significantly worse on the same runs.

    ``before`` / ``after``: scoring frames (``case_index, k, failed, repeated``) of the same
    runs with the table before and after a change.  Per case, the exact one-sided McNemar
    test that it got worse (``p = P(X >= c)``, ``X ~ Binomial(b + c, 1/2)``, :func:`~rcsim.
    analysis.results.proportions.mcnemar_one_sided` with the roles swapped); Holm over the
    cases at ``alpha`` (every case compared is one family: the chance that any case is named
    worse when none is is at most ``alpha``).  In ``case_index`` order.
    """
    from rcsim.analysis.results.proportions import holm_adjusted

    b_all = before.set_index(["case_index", "k"]).sort_index()
    a_all = after.set_index(["case_index", "k"]).sort_index()
    if not b_all.index.equals(a_all.index):
        raise ValueError("before and after must fly the same runs (same case_index, k)")
    xb, xa = _bad(b_all, outcome), _bad(a_all, outcome)
    fb, fa = b_all["failed"].to_numpy(bool), a_all["failed"].to_numpy(bool)
    case_of = b_all.index.get_level_values(0).to_numpy()
    cases = np.unique(case_of)
    rows = []
    for c in cases:
        sel = case_of == c
        better, worse = _discordant(xb[sel], xa[sel])
        rows.append((int(c), better, worse, float(mcnemar_one_sided(worse, better)), sel))
    adj = holm_adjusted(np.array([r[3] for r in rows])) if rows else np.array([])
    return [
        CaseWorse(
            case_index=c,
            outcome=outcome,
            b=better,
            c=worse,
            p=p,
            p_holm=float(adj[i]),
            worse=bool(adj[i] <= alpha),
            failed_before=int(fb[sel].sum()),
            failed_after=int(fa[sel].sum()),
            runs=int(sel.sum()),
        )
        for i, (c, better, worse, p, sel) in enumerate(rows)
    ]


def worse_text(harmed: list[CaseWorse]) -> str:
    """The cases named worse, e.g. ``case 6 worse (failed 10 -> 33 of 40; failed: 23:0
    runs worse:better, Holm p=1.2e-07)``; "" when none."""
    return "; ".join(
        f"case {w.case_index + 1} worse (failed {w.failed_before} -> {w.failed_after} of "
        f"{w.runs}; {w.outcome}: {w.c}:{w.b} runs worse:better, Holm p={w.p_holm:.2g})"
        for w in harmed
        if w.worse
    )
