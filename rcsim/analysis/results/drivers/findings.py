"""One false-positive budget for the whole report, and the list of every flag it shows.

A review board reads the report, not a family of tests: every mark a reader can see (an input
called a driver, a pair called an interaction, a case's driver, an outcome's driver) is a claim
it may act on.  The report-wise level ``alpha`` (``Settings.alpha``, 5 % by default) bounds the
probability that the report shows *any* false flag.

Families and the split (Bonferroni)
    ``singles`` (weight 2): an input whose failed and successful runs differ, pooled over the
    cases (max-T over every input); ``interactions`` (1): a pair that adds to its two inputs'
    separate effects within cases (exact conditional test, Holm over every pair), shown only
    when the pair's joint test also holds; ``per case`` (1): an input driving one case's
    failures (max-T over every case and input together); ``outcomes`` (1): an input driving
    one axis's failures or the failures at the second threshold (max-T over every outcome and
    input together, the outcomes permuted alike).  Each family the analysis holds gets
    ``alpha x weight / (sum of the weights of the families it holds)``; the shares add up to
    ``alpha``.  Each family's procedure holds its own family-wise error at its share whatever
    else is true (strong control), so by the union bound the chance that the report shows any
    false flag is at most ``alpha``, whatever the dependence between families, on a table where
    nothing acts and on one where some inputs do.

What raises no flag, and why
    The pairs' joint test is a gate: an interaction needs it too (at ``alpha``), and a gate can
    only remove flags, so it spends none of the budget; a pair that passes only the joint test
    is not marked.  The random forest is a ranking shown for comparison, not a test.  Scenario
    boxes and kNN maps are searched and drawn only for inputs a family already flagged (and the
    paper's Fig. 15 pair, labelled as a comparison): on a table with no flag there is no box
    and no map of evidence.

Resolution
    A permutation p-value is at least ``1 / (B + 1)``: a family whose share is not above that
    cannot flag anything with ``B`` permutations, and the report's method section says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

#: Weights of the report-wise budget's split (module docstring).
FAMILY_WEIGHTS = {"singles": 2.0, "interactions": 1.0, "per_case": 1.0, "outcomes": 1.0}
#: How each family is named in the report and on the terminal.
FAMILY_WORDS = {
    "singles": "single drivers",
    "interactions": "interactions",
    "per_case": "per-case drivers",
    "outcomes": "outcome drivers",
}
#: Findings of a family listed by name on the terminal and in loop.json before "N more".
LISTED = 8


def family_levels(alpha: float, present) -> dict[str, float]:
    """Each present family's share of the report-wise level ``alpha`` (module docstring)."""
    names = [f for f in FAMILY_WEIGHTS if f in set(present)]
    total = sum(FAMILY_WEIGHTS[f] for f in names)
    return {f: float(alpha) * FAMILY_WEIGHTS[f] / total for f in names} if total else {}


@dataclass(frozen=True)
class Finding:
    """One flag the report shows.

    Attributes
    ----------
    family : {"singles", "interactions", "per_case", "outcomes"}
    factor : str
        The input (for an interaction, the first of the pair).
    p_value : float
        Its family-wise p-value.
    level : float
        Its family's share of the report-wise level (flagged: ``p_value < level``).
    factor_b : str
        The pair's second input ("" otherwise).
    case : str
        The case of a per-case driver ("" otherwise).
    outcome : str
        The outcome of an outcome driver ("" otherwise).
    """

    family: str
    factor: str
    p_value: float
    level: float
    factor_b: str = ""
    case: str = ""
    outcome: str = ""

    @property
    def label(self) -> str:
        """The finding in a few words: ``a``, ``a x b``, ``a in rate-05``, ``a (yaw)``."""
        if self.family == "interactions":
            return f"{self.factor} x {self.factor_b}"
        if self.family == "per_case":
            return f"{self.factor} in {self.case}"
        if self.family == "outcomes":
            return f"{self.factor} ({self.outcome})"
        return self.factor


def findings(res) -> list[Finding]:
    """Every flag the report of ``res`` (a
    :class:`~rcsim.analysis.results.drivers.pipeline.DriverResults`) shows, family by family,
    strongest first within a family."""
    out: list[Finding] = []
    levels = getattr(res, "levels", {}) or {}
    d = res.drivers
    if d is not None and "singles" in levels:
        for _, r in d[d["significant"].astype(bool)].iterrows():
            out.append(Finding("singles", str(r["factor"]), float(r["p_value"]), levels["singles"]))
    pt = res.pair_table
    if pt is not None and "interactions" in levels:
        for _, r in pt[pt["significant"].astype(bool)].iterrows():
            out.append(
                Finding(
                    "interactions",
                    str(r["factor_a"]),
                    float(r["p_interaction"]),
                    levels["interactions"],
                    factor_b=str(r["factor_b"]),
                )
            )
    if "per_case" in levels:
        rows = []
        for c in res.cases:
            if c.singles is None or c.significant is None:
                continue
            for j in np.flatnonzero(c.significant):
                rows.append((float(c.p_family[j]), c.case, c.singles.feature_names_in_[j]))
        for p, case, f in sorted(rows, key=lambda r: (r[0], r[1])):
            out.append(Finding("per_case", str(f), p, levels["per_case"], case=str(case)))
    o = getattr(res, "outcomes", None)
    if o is not None and "outcomes" in levels:
        for oc in o.outcomes:
            if oc.singles is None or oc.significant is None:
                continue
            order = np.argsort(oc.p_family, kind="stable")
            for j in order[oc.significant[order]]:
                out.append(
                    Finding(
                        "outcomes",
                        str(oc.singles.feature_names_in_[j]),
                        float(oc.p_family[j]),
                        levels["outcomes"],
                        outcome=oc.name,
                    )
                )
    return out


def findings_frame(found: list[Finding]) -> pd.DataFrame:
    """``findings.csv``: one row per flag (``family, finding, factor, factor_b, case, outcome,
    p_value, level``)."""
    cols = ["family", "finding", "factor", "factor_b", "case", "outcome", "p_value", "level"]
    return pd.DataFrame(
        [
            {
                "family": f.family,
                "finding": f.label,
                "factor": f.factor,
                "factor_b": f.factor_b,
                "case": f.case,
                "outcome": f.outcome,
                "p_value": f.p_value,
                "level": f.level,
            }
            for f in found
        ],
        columns=cols,
    )


def summary_lines(found: list[Finding], alpha: float, listed: int = LISTED) -> list[str]:
    """The findings for a terminal or a summary: a head line, then one line per family with a
    finding (at most ``listed`` named, then "and N more")."""
    rate = f"{100 * alpha:g} %"
    if not found:
        return [f"no finding: nothing is flagged (report-wise false-flag rate {rate})"]
    counts = {f: sum(x.family == f for x in found) for f in FAMILY_WEIGHTS}
    head = (
        f"{len(found)} finding{'s' if len(found) > 1 else ''} (report-wise false-flag rate {rate})"
    )
    on_failures = ", ".join(
        f"{n} {_words(f, n)}" for f, n in counts.items() if n and f in FAILURE_FAMILIES
    )
    n_out = counts["outcomes"]
    # The outcome families (per axis, a second threshold, propellant, delta-v) answer other
    # questions than "why do runs fail": said after the failures, never in their place.
    if n_out and not on_failures:
        every = "it is an outcome driver" if n_out == 1 else f"all {n_out} are outcome drivers"
        lines = [
            f"{head}, none on the failures: no input, pair or case is a flagged driver of the "
            f"runs failing the criterion; {every} ({outcome_counts(found)})"
        ]
    elif n_out:
        lines = [
            f"{head}: on the failures {on_failures}; beside them {n_out} "
            f"{_words('outcomes', n_out)} ({outcome_counts(found)})"
        ]
    else:
        lines = [f"{head}: {on_failures}"]
    for fam, n in counts.items():
        if not n:
            continue
        labels = [x.label for x in found if x.family == fam]
        more = f" and {n - listed} more (findings.csv)" if n > listed else ""
        lines.append(f"  {FAMILY_WORDS[fam]}: {', '.join(labels[:listed])}{more}")
    return lines


#: The families that say why runs fail the campaign's criterion (the rest: other outcomes).
FAILURE_FAMILIES = ("singles", "interactions", "per_case")


def outcome_counts(found: list[Finding]) -> str:
    """``21 on propellant top 10 %, 10 on delta-v top 10 %``: the outcome drivers per outcome."""
    names: dict[str, int] = {}
    for x in found:
        if x.family == "outcomes":
            names[x.outcome] = names.get(x.outcome, 0) + 1
    return ", ".join(f"{v} on {k}" for k, v in names.items())


def _words(family: str, n: int) -> str:
    """The family's name, singular for one finding ("1 single driver")."""
    words = FAMILY_WORDS[family]
    return words if n != 1 else words[:-1]


def summary_text(found: list[Finding], alpha: float, listed: int = LISTED) -> str:
    """:func:`summary_lines` on one line (``loop.json``)."""
    lines = summary_lines(found, alpha, listed)
    return "; ".join([lines[0], *(s.strip() for s in lines[1:])])


def smallest_p(n_permutations: int) -> float:
    """The smallest permutation p-value ``B`` permutations can give."""
    return 1.0 / (int(n_permutations) + 1.0)


def blind_families(res) -> list[str]:
    """The families that can flag nothing with the analysis's permutations (their smallest
    p-value, ``1 / (B + 1)``, not below their share; interactions: their joint test's gate),
    each with that smallest p-value in words."""
    st = res.settings
    levels = getattr(res, "levels", {}) or {}
    out = [
        f"{FAMILY_WORDS[f]} (smallest p with {st.n_permutations} permutations: "
        f"1/{st.n_permutations + 1})"
        for f in ("singles", "per_case", "outcomes")
        if f in levels and smallest_p(st.n_permutations) >= levels[f]
    ]
    if "interactions" in levels and smallest_p(st.pair_b) >= float(st.alpha):
        out.append(
            f"interactions (the joint test's smallest p with {st.pair_b} permutations: "
            f"1/{st.pair_b + 1})"
        )
    return out


def method_text(res) -> str:
    """The budget as the report's method section states it."""
    st = res.settings
    levels = getattr(res, "levels", {}) or {}
    alpha = float(st.alpha)
    shares = "; ".join(
        f"{FAMILY_WORDS[f]} {_level(lv)}" for f, lv in levels.items() if f in FAMILY_WORDS
    )
    blind = blind_families(res)
    text = (
        f"One false-flag budget for the whole report: the chance that any flag it shows is "
        f"false is at most {_level(alpha)}. It is split over the families of flags by weight "
        "(Bonferroni: single drivers 2, interactions 1, per-case drivers 1, outcome drivers 1, "
        f"over the families analysed here): {shares}. Each family holds its family-wise "
        "error at its share; the shares add up to the budget. A pair is an interaction only "
        f"when its joint test also holds (p_joint < {_level(alpha)}: a gate, which can only "
        "remove flags and spends none of the budget). The random forest's ranking is shown "
        "for comparison and is not a test; scenario boxes and failure maps are drawn only for "
        "flagged inputs."
    )
    if blind:
        text += (
            " With these permutations no flag is possible in: "
            + "; ".join(blind)
            + " (use more permutations)."
        )
    return text


def _level(x: float) -> str:
    return f"{100 * x:.3g} %"
