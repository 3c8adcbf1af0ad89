"""Report parts of the failure probabilities and of the several outcomes.

Helpers :mod:`.report_sections` calls to add a probability to its summary, per-case and driver
tables, and the section "Outcomes: per axis and threshold sensitivity" (:func:`outcomes`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers import probabilities as P
from rcsim.analysis.results.drivers.outcomes import TOP_DRIVERS, outcome_table
from rcsim.analysis.results.report.html import Section, table_block, text_block

#: Header of every displayed probability: says which interval it is.
P_HEADER = "failure probability (Clopper-Pearson 95 % CI)"


def _bound_p(res) -> float:
    return float(getattr(res.settings, "bound_p", P.DEFAULT_BOUND_P))


def bound_header(res) -> str:
    return f"runs to bound p < {100 * _bound_p(res):g} % (95 %)"


def overall_facts(res) -> list[tuple[str, str]]:
    """Summary lines: the overall probability and the runs its bound needs."""
    row = P.overall_table(res).iloc[0]
    return [
        (
            "failure probability (all runs)",
            P.p_with_ci(row["failure_probability"], row["cp95_low"], row["cp95_high"])
            + " -- Clopper-Pearson exact interval",
        ),
        (
            f"runs to bound it below {100 * _bound_p(res):g} % (95 %)",
            P.bound_words(row["runs_to_bound"], int(row["runs"]), _bound_p(res)),
        ),
    ]


def with_case_columns(df: pd.DataFrame, res) -> pd.DataFrame:
    """``df`` (one row per case, column ``case``) with :func:`case_columns` inserted after its
    ``failed`` column (so they show without scrolling)."""
    extra = case_columns(res)
    out = df.join(extra, on="case")
    cols = [c for c in df.columns]
    at = cols.index("failed") + 1 if "failed" in cols else len(cols)
    return out[cols[:at] + list(extra.columns) + cols[at:]]


def case_columns(res) -> pd.DataFrame:
    """Per case (index: case name): the probability with its interval and the runs to bound
    it, as displayed."""
    t = P.case_probabilities(res)
    runs = {str(c.case): c.runs for c in res.cases}
    return pd.DataFrame(
        {
            P_HEADER: [
                P.p_with_ci(p, lo, hi)
                for p, lo, hi in zip(t["failure_probability"], t["cp95_low"], t["cp95_high"])
            ],
            bound_header(res): [_need(n, runs[c]) for c, n in zip(t["case"], t["runs_to_bound"])],
        },
        index=t["case"].to_numpy(),
    )


def _need(need: float, have: int) -> str:
    if not np.isfinite(need):
        return "not at this rate"
    need = int(need)
    return f"{need:,}" + ("" if need <= have else f" ({need - have:,} more)")


def region_column(d: pd.DataFrame) -> pd.Series:
    """``p = x % (95 % CI a-b %)`` of each factor's failure region ("" without one)."""
    if "region_failure_probability" not in d:
        return pd.Series([""] * len(d), index=d.index)
    return pd.Series(
        [
            P.p_with_ci(p, lo, hi) if np.isfinite(p) else ""
            for p, lo, hi in zip(
                d["region_failure_probability"], d["region_cp95_low"], d["region_cp95_high"]
            )
        ],
        index=d.index,
    )


def outcomes(res) -> Section:
    """Per-axis outcomes and the threshold sensitivity beside the pooled outcome."""
    o = getattr(res, "outcomes", None)
    if o is None:
        return Section(
            "Outcomes: per axis and threshold sensitivity",
            [text_block("Not analysed (Settings.outcomes off).")],
            "outcomes",
        )
    blocks = []
    if not o.outcomes:
        blocks.append(text_block(*(o.notes or ["No per-axis outcome could be built."])))
    else:
        blocks.append(
            text_block(
                "The pooled outcome mixes failures of different axes; an input that drives one "
                "axis's failures is diluted by the others. Each outcome below is analysed on its "
                "own with the same single-factor method (labels shuffled within cases, every "
                "outcome by the same shuffles; pairs are not repeated per outcome). An outcome's "
                "driver is flagged family-wise over every outcome and input together (max-T), at "
                f"p < {100 * res.levels.get('outcomes', res.settings.alpha):.3g} %, this family's "
                "share of the report's budget. "
                + _threshold_words(o)
                + "'rank on the pooled outcome': a large one marks a driver the pooled "
                "analysis hides."
            )
        )
        if o.axis_breakdown:
            nf = sum(o.axis_breakdown.values())
            parts = ", ".join(f"{k} {v}" for k, v in o.axis_breakdown.items())
            single = sum(v for k, v in o.axis_breakdown.items() if k.endswith("only"))
            blocks.append(
                text_block(
                    f"Runs failing the rate criterion by axis: {parts} "
                    + (f"({P.share_text(single, nf)} fail on one axis only)." if nf else "")
                )
            )
    t = outcome_table(res)
    first = t.drop_duplicates("outcome").reset_index(drop=True)
    summary = first[["outcome", "criterion", "runs", "failed"]].copy()
    summary[P_HEADER] = [
        P.p_with_ci(p, lo, hi)
        if np.isfinite(lo)
        else f"{P.pct(p)} % (the top decile by construction: no interval)"
        for p, lo, hi in zip(first["failure_probability"], first["cp95_low"], first["cp95_high"])
    ]
    blocks.append(table_block(summary, "Outcomes (outcomes.csv)", max_rows=20))
    blocks.append(
        table_block(
            _top(t, TOP_SHOWN),
            f"Top {TOP_SHOWN} drivers of each outcome (outcomes.csv has {TOP_DRIVERS}); "
            "p_value family-wise over every outcome and input (the pooled outcome: over its "
            "inputs, the single drivers' family)",
            max_rows=10 * TOP_SHOWN,
        )
    )
    return Section("Outcomes: per axis and threshold sensitivity", blocks, "outcomes")


#: Drivers per outcome shown in the report.
TOP_SHOWN = 3


def _top(t: pd.DataFrame, k: int) -> pd.DataFrame:
    """The first ``k`` drivers of every outcome (one row saying so when not analysed)."""
    rows = []
    for name, g in t.groupby("outcome", sort=False):
        if "p_value" not in g or g["factor"].eq("").all():
            rows.append({"outcome": name, "rank": "", "factor": "not analysed (no failure)"})
            continue
        for _, r in g.head(k).iterrows():
            rows.append(
                {
                    "outcome": name,
                    "rank": int(r["rank"]),
                    "factor": r["factor"],
                    "p_value": r["p_value"],
                    "significant": "yes" if r["significant"] else "no",
                    "rank on the pooled outcome": int(r["pooled_rank"]),
                    # A region is a claim about where runs fail: only a flagged driver's.
                    "failure_region": r["failure_region"] if r["significant"] else "",
                }
            )
    return pd.DataFrame(rows).astype(object).fillna("")


def _threshold_words(o) -> str:
    """The per-axis and second-threshold outcomes in words, when the table has a rate
    threshold (a table without one gets only the propellant and delta-v outcomes)."""
    if o.threshold is None:
        return ""
    words = (
        f"Per axis: the run ends with |rate error| >= {o.threshold:g} deg/s on that axis (the "
        "campaign's threshold). "
    )
    if o.second_threshold is not None:
        words += (
            f"'failed at {o.second_threshold:g}': the campaign's criterion with "
            f"{o.second_threshold:g} deg/s instead of {o.threshold:g} deg/s. "
        )
    return words
