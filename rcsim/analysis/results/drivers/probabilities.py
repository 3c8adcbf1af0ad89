"""Failure probabilities of an analysis, each with its exact interval and the runs a bound needs.

Three scopes, one recipe (:mod:`rcsim.analysis.results.proportions`):

* overall -- the share of all analysed runs that failed (the campaign's case mix);
* per case -- the share of the case's runs that failed;
* per failure region -- for each input, the share of the runs inside its single-factor failure
  region (:class:`~rcsim.analysis.results.drivers.single.SingleFactorKDE`) that failed.

Each probability ``k / n`` carries the Clopper-Pearson (exact) two-sided 95 % interval
(``cp95_low``, ``cp95_high``: the Beta quantiles ``Beta(0.025; k, n - k + 1)`` and
``Beta(0.975; k + 1, n - k)``) and ``runs_to_bound``: how many runs, at the failure rate
observed, make the one-sided exact 95 % upper bound fall below ``bound_p``
(:func:`~rcsim.analysis.results.proportions.runs_to_bound`; with no failure, the rule of three's
exact form ``ln 0.05 / ln(1 - bound_p)``; ``inf`` when the observed rate is already ``>= bound_p``:
no number of runs at that rate bounds it).  ``runs_to_bound`` counts all runs, those already
flown included.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers.single import in_region
from rcsim.analysis.results.proportions import CONFIDENCE, clopper_pearson, runs_to_bound

#: Default ``bound_p``: "how many runs bound this failure probability below 1 %?".
DEFAULT_BOUND_P = 0.01
#: Column names of the probability, its interval and the runs to a bound (every CSV).
PROBABILITY_COLUMNS = ["failure_probability", "cp95_low", "cp95_high", "runs_to_bound"]
INTERVAL_NAME = "Clopper-Pearson exact 95 % interval"


def probability_frame(k, n, bound_p: float = DEFAULT_BOUND_P) -> pd.DataFrame:
    """``failure_probability``, ``cp95_low``, ``cp95_high``, ``runs_to_bound`` of counts
    ``k`` failed of ``n`` runs (arrays of equal length; ``n = 0`` gives NaN and (0, 1))."""
    k = np.atleast_1d(np.asarray(k, float))
    n = np.atleast_1d(np.asarray(n, float))
    lo, hi = clopper_pearson(k, n, CONFIDENCE)
    p = np.divide(k, n, out=np.full(k.shape, np.nan), where=n > 0)
    need = np.where(n > 0, runs_to_bound(k, np.maximum(n, 1), bound_p, CONFIDENCE), np.nan)
    return pd.DataFrame(
        {
            "failure_probability": p,
            "cp95_low": np.atleast_1d(lo),
            "cp95_high": np.atleast_1d(hi),
            "runs_to_bound": need,
        }
    )


def overall_table(res) -> pd.DataFrame:
    """One row (``summary.csv``): runs, failed, probability, interval, runs to the bound."""
    rs = res.runset
    n, k = int(rs.y.size), int(rs.y.sum())
    if getattr(rs, "subsampled", False):
        # "all runs" means every run of the table, not the subsample the drivers analysed:
        # the reading counted them all (a tighter interval, and the figure the title claims).
        n, k = int(rs.total_runs), int(rs.total_failed)
    bound_p = _bound_p(res)
    row = pd.DataFrame({"scope": ["all runs"], "outcome": [rs.outcome], "runs": [n], "failed": [k]})
    out = pd.concat([row, probability_frame(k, n, bound_p)], axis=1)
    out["bound_p"] = bound_p
    out["interval"] = INTERVAL_NAME
    return out


def case_probabilities(res) -> pd.DataFrame:
    """One row per case: ``case``, then :data:`PROBABILITY_COLUMNS` of its runs."""
    k = [c.failed for c in res.cases]
    n = [c.runs for c in res.cases]
    out = probability_frame(k, n, _bound_p(res))
    out.insert(0, "case", [str(c.case) for c in res.cases])
    return out


def with_case_probabilities(table: pd.DataFrame, res) -> pd.DataFrame:
    """``table`` (``cases.csv``: one or more rows per case) with the case's probability
    columns added after its own (nothing else changed)."""
    probs = case_probabilities(res)
    if "case" not in table.columns or not len(table):
        return table
    merged = table.merge(probs, on="case", how="left", sort=False)
    merged["bound_p"] = _bound_p(res)
    return merged


def region_counts(singles, X, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Runs inside each input's failure region and failed runs among them (in the order of
    ``singles.feature_names_in_``), counted on the runs ``X`` (DataFrame) with the region as
    its text gives it -- the text the report shows, so every count said of a region is the
    same count (:func:`~.single.in_region`)."""
    y = np.asarray(y, bool)
    runs_in, failed_in = [], []
    for name, region in zip(singles.feature_names_in_, singles.regions_):
        inside = in_region(X[name].to_numpy(float), region)
        runs_in.append(int(inside.sum()))
        failed_in.append(int((inside & y).sum()))
    return np.array(failed_in, dtype=int), np.array(runs_in, dtype=int)


def add_region_columns(drivers: pd.DataFrame, singles, X, y, bound_p: float) -> pd.DataFrame:
    """``drivers`` (one row per factor) with ``region_runs``, ``region_failed``,
    ``region_failure_probability`` and its ``region_cp95_low`` / ``region_cp95_high``: the
    share of the runs inside the factor's failure region that failed; ``region_fail_share``
    and ``region_run_share`` recounted the same way.  Factors with no region get NaN (and
    shares 0)."""
    failed_in, runs_in = region_counts(singles, X, y)
    probs = probability_frame(failed_in, runs_in, bound_p)
    has = runs_in > 0
    n, nf = len(y), max(int(np.sum(y)), 1)

    def only_with_region(col: str) -> np.ndarray:
        return np.where(has, probs[col].to_numpy(), np.nan)

    by_name = pd.DataFrame(
        {
            "region_fail_share": failed_in / nf,
            "region_run_share": runs_in / n,
            "region_runs": runs_in,
            "region_failed": np.where(has, failed_in, 0),
            "region_failure_probability": only_with_region("failure_probability"),
            "region_cp95_low": only_with_region("cp95_low"),
            "region_cp95_high": only_with_region("cp95_high"),
        },
        index=list(singles.feature_names_in_),
    )
    out = drivers.copy()
    for col in by_name.columns:
        out[col] = out["factor"].map(by_name[col])
    return out


def add_to_results(res) -> None:
    """Add the failure-region probability columns to ``res.drivers`` (``drivers.csv``)."""
    if res.drivers is None or res.singles is None:
        return
    rs = res.runset
    res.drivers = add_region_columns(res.drivers, res.singles, rs.X, rs.y, _bound_p(res))


def _bound_p(res) -> float:
    return float(getattr(res.settings, "bound_p", DEFAULT_BOUND_P))


# --------------------------------------------------------------------------------- words --
def pct(p: float) -> str:
    """A probability as a percentage with sensible digits (12.5, 2.1, 0.62, 0.031, 0, 100).

    Never rounds a non-zero probability to "0" nor one below 1 to "100" (0.9996 is "99.96"):
    a rounding that turns "rare" into "never" is a false sentence.
    """
    if not np.isfinite(p):
        return "-"
    v = 100.0 * p
    if v == 0 or v == 100:
        return f"{v:.0f}"
    if v >= 1:
        text, digits = f"{v:.1f}", 1
        while float(text) >= 100.0 and digits < 12:  # 99.96 % must not read 100 %
            digits += 1
            text = f"{v:.{digits}f}"
        return text
    if v >= 0.1:
        return f"{v:.2f}"
    return f"{v:.2g}"


def rate_text(k: int, n: int) -> str:
    """``"41.3 % (95 % CI 38.2-44.5 %)"``: ``k`` of ``n`` runs with its Clopper-Pearson
    interval ("-" when ``n`` is 0)."""
    if n <= 0:
        return "-"
    lo, hi = clopper_pearson(k, n, CONFIDENCE)
    return f"{pct(k / n)} % (95 % CI {pct(float(lo))}-{pct(float(hi))} %)"


def share_text(k: int, n: int) -> str:
    """``"1,234 of 2,458 (50.2 %)"``: a count and its share, never "0 %" for ``k > 0``."""
    return f"{int(k):,} of {int(n):,} ({pct(k / n) if n > 0 else '-'} %)"


def p_with_ci(p: float, lo: float, hi: float) -> str:
    """``"p = 2.1 % (95 % CI 1.4-3.0 %)"``."""
    if not np.isfinite(p):
        return "-"
    return f"p = {pct(p)} % (95 % CI {pct(lo)}-{pct(hi)} %)"


def bound_words(need: float, have: int, bound_p: float) -> str:
    """The runs-to-bound answer in words, against the runs already flown."""
    target = f"below {100 * bound_p:g} %"
    if not np.isfinite(need):
        return (
            f"no number of runs bounds it {target}: the observed rate is already "
            f">= {100 * bound_p:g} %"
        )
    need = int(need)
    if need <= have:
        return f"{need:,} runs bound it {target}; {have:,} flown"
    return f"{need:,} runs bound it {target} ({need - have:,} more)"
