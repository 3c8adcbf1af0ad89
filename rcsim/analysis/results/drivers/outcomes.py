"""Several failure outcomes at once: per axis, and the failure threshold's sensitivity.

The pooled ``failed`` outcome mixes failures of different axes: a run that ends with too much
roll rate and one that ends with too much yaw rate are failures of different jets, and an input
that drives only one axis's failures is diluted by the others (in the Table 6
campaign 28 % of failures are roll-only or pitch-only; analysed alone, roll authority ranks
first where pooled it ranks 11th).  Beside the pooled outcome this module analyses

* ``roll``, ``pitch``, ``yaw`` -- the run fails on that axis: ``not |final rate error| < thr``
  on it (``thr`` the campaign's ``failure.rate_error_deg_s``, from its manifest; as the
  campaign applies the criterion, a run whose simulation failed has NaN errors and so fails on
  every axis);
* ``failed at thr2`` -- the campaign's criterion with the rate threshold ``thr2`` instead of
  ``thr`` (default 0.06 against 0.04 deg/s, the paper's pair): runs that failed for another
  reason (simulation, attitude, propellant; read from ``reason``) still fail;
* ``propellant ...`` and ``delta-v ...`` -- the run's ``propellant_kg`` / ``delta_v_N_m_s``
  exceeds the campaign's ``[failure]`` budget, or, without one, lies in the runs' top decile
  (:func:`budget_outcomes`: what drives propellant use and translation).

Each outcome is scored by :class:`~rcsim.analysis.results.drivers.single.SingleFactorKDE` with
as many permutations as the pooled singles, labels permuted within cases.  The outcomes are one
family of flags (:mod:`rcsim.analysis.results.drivers.findings`): every outcome's fit draws
the *same* permutations of the runs (``joint=True`` and one seed), so the largest standardised
null score over every outcome and input at each permutation is the exact max-T null of all of
them together, and an outcome's driver is flagged when that family-wise p-value is below the
family's share of the report-wise level.  (Each outcome was once corrected on its
own at 0.05: five outcomes, five chances of a false flag.)  Pairs are not run per outcome
(they cost ~40x the singles).  Per-axis outcomes need the per-axis
``final_rate_err_*`` columns and the campaign's threshold; without them they are skipped with
a note.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from rcsim.analysis.engine import runs_table
from rcsim.analysis.results.drivers.kde import N_BINS_1D, bin_codes, maxt_p, rank_scale
from rcsim.analysis.results.drivers.probabilities import probability_frame
from rcsim.analysis.results.drivers.single import SingleFactorKDE

AXES = ("roll", "pitch", "yaw")
RATE_COLUMN = "final_rate_err_{axis}_deg_s"
#: Drivers listed per outcome in ``outcomes.csv`` and the report.
TOP_DRIVERS = 5
#: Default second rate threshold [deg/s] of the sensitivity (the paper's 0.04 against 0.06).
DEFAULT_SECOND_THRESHOLD = 0.06
#: How the engine words a rate failure in ``reason`` (rcsim.analysis.engine.campaign.outcomes).
_RATE_REASON = "final |rate error|"


@dataclass
class Outcome:
    """One outcome analysed: its name, what it means, its labels and (if fitted) singles."""

    name: str
    criterion: str
    y: np.ndarray
    singles: SingleFactorKDE | None = None
    #: Max-T p-value over every outcome and input (aligned with ``singles.feature_names_in_``).
    p_family: np.ndarray | None = None
    #: ``p_family`` below the outcome family's share of the budget: a flag the report shows.
    significant: np.ndarray | None = None
    #: Its share of the runs is set by its definition (the runs' top decile), not estimated:
    #: no interval and no "runs to bound" belong to it.
    by_construction: bool = False

    @property
    def runs(self) -> int:
        return int(self.y.size)

    @property
    def failed(self) -> int:
        return int(self.y.sum())


@dataclass
class OutcomeResults:
    """Every outcome analysed, the campaign threshold, and what the reader must know."""

    outcomes: list = field(default_factory=list)
    threshold: float | None = None
    second_threshold: float | None = None
    axis_breakdown: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


def campaign_threshold(manifest: dict | None) -> float | None:
    """The campaign's rate threshold [deg/s] (manifest ``thresholds``, else the spec's
    ``failure`` table); None when the runs carry no manifest."""
    if not manifest:
        return None
    thr = (manifest.get("thresholds") or {}).get("rate_error_deg_s")
    if thr is None:
        thr = ((manifest.get("spec") or {}).get("failure") or {}).get("rate_error_deg_s")
    return None if thr is None else float(thr)


def axis_failures(runs: pd.DataFrame, threshold: float) -> dict[str, np.ndarray]:
    """Per axis: ``not |final rate error| < threshold`` (NaN, a non-flight, fails)."""
    return {
        a: ~(np.abs(runs[RATE_COLUMN.format(axis=a)].to_numpy(float)) < threshold) for a in AXES
    }


def other_failures(runs: pd.DataFrame, y: np.ndarray, rate_any: np.ndarray) -> np.ndarray:
    """Runs that failed for a reason besides the final rate error (simulation failure,
    attitude, propellant): from ``sim_failed`` and the ``reason`` text when present, else the
    failed runs whose rate errors all passed."""
    other = y & ~rate_any
    if "sim_failed" in runs:
        other |= runs["sim_failed"].to_numpy(bool)
    if "reason" in runs:
        parts = runs["reason"].fillna("").astype(str).str.split("; ")
        other |= y & parts.map(lambda ps: any(p and not p.startswith(_RATE_REASON) for p in ps))
    return other


def _breakdown(axes: dict[str, np.ndarray]) -> dict[str, int]:
    """Failed runs by the set of axes they fail on (``roll only``, ..., ``2+ axes``)."""
    stack = np.column_stack([axes[a] for a in AXES])
    n_axes = stack.sum(axis=1)
    out = {f"{a} only": int((stack[:, i] & (n_axes == 1)).sum()) for i, a in enumerate(AXES)}
    out["2 or 3 axes"] = int((n_axes >= 2).sum())
    return out


def build_outcomes(runset, second_threshold: float = DEFAULT_SECOND_THRESHOLD) -> OutcomeResults:
    """The outcomes beside the pooled one that ``runset`` supports (no fitting): per axis,
    the second threshold, then propellant and delta-v (:func:`budget_outcomes`)."""
    res = _rate_outcomes(runset, second_threshold)
    res.outcomes += budget_outcomes(runset.runs, runset.manifest, res.notes)
    return res


#: Propellant and translation outcomes: column, the spec's ``[failure]`` budget
#: key, unit, words.  Without a budget a run is in the outcome when its value is in the
#: campaign's top decile (what drives heavy use), at or above the 90th percentile.
BUDGET_OUTCOMES = (
    ("propellant_kg", "max_propellant_kg", "kg", "propellant"),
    ("delta_v_N_m_s", "max_delta_v_m_s", "m/s", "delta-v"),
)
TOP_QUANTILE = 0.9


def budget_outcomes(runs: pd.DataFrame, manifest: dict | None, notes: list) -> list[Outcome]:
    """A propellant and a delta-v outcome when the runs carry ``propellant_kg`` /
    ``delta_v_N_m_s``: over the campaign's budget (manifest ``thresholds``) when it set one,
    else at or above the runs' 90th percentile.  Runs without a value (simulation failed)
    are not in it (a note counts them).  Outcomes, never inputs: the columns are outcome
    columns of the schema (:func:`rcsim.analysis.engine.runs_table.outcome_columns`)."""
    thresholds = (manifest or {}).get("thresholds") or {}
    out = []
    for column, key, unit, words in BUDGET_OUTCOMES:
        if column not in runs.columns:
            continue
        x = runs[column].to_numpy(float)
        ok = np.isfinite(x)
        if not ok.any():
            continue
        limit = thresholds.get(key)
        if limit is not None:
            y = ok & (x > float(limit))
            name, criterion = f"{words} > {float(limit):g}", f"{column} > {float(limit):g} {unit}"
        else:
            q = float(np.quantile(x[ok], TOP_QUANTILE))
            y = ok & (x >= q)
            name = f"{words} top 10 %"
            criterion = f"{column} >= {q:.4g} {unit} (the runs' 90th percentile; no budget set)"
        out.append(Outcome(name, criterion, y, by_construction=limit is None))
        if not ok.all():
            notes.append(
                f"outcomes: {int((~ok).sum())} run(s) without {column} (simulation failed) "
                f"are not in the {words} outcome"
            )
    return out


def _rate_outcomes(runset, second_threshold: float) -> OutcomeResults:
    """Per-axis outcomes and the second rate threshold (module docstring)."""
    res = OutcomeResults(second_threshold=second_threshold)
    runs = runset.runs
    cols = [RATE_COLUMN.format(axis=a) for a in AXES]
    if not all(c in runs.columns for c in cols):
        res.notes.append(
            "outcomes: the runs carry no per-axis final rate errors "
            f"({', '.join(cols)}); per-axis outcomes and the threshold sensitivity skipped"
        )
        return res
    thr = campaign_threshold(runset.manifest)
    if thr is None:
        res.notes.append(
            "outcomes: no campaign manifest gives the failure threshold; per-axis outcomes and "
            "the threshold sensitivity skipped (analyse the campaign directory)"
        )
        return res
    res.threshold = thr
    axes = axis_failures(runs, thr)
    for a in AXES:
        res.outcomes.append(Outcome(a, f"|final {a} rate error| >= {thr:g} deg/s", axes[a]))
    res.axis_breakdown = _breakdown(axes)
    n_nan = int(runs[cols].isna().any(axis=1).sum())
    if n_nan:
        res.notes.append(
            f"outcomes: {n_nan} run(s) without final rate errors (simulation failed) count as "
            "failed on every axis, as the campaign's criterion does"
        )
    if second_threshold != thr:
        rate_any = np.logical_or.reduce([axes[a] for a in AXES])
        y2 = np.logical_or.reduce(list(axis_failures(runs, second_threshold).values()))
        y2 |= other_failures(runs, runset.y, rate_any) if runset.outcome == "failed" else False
        res.outcomes.append(
            Outcome(
                f"failed at {second_threshold:g}",
                f"|final rate error| >= {second_threshold:g} deg/s on any axis"
                + (" or another failure reason" if runset.outcome == "failed" else ""),
                y2,
            )
        )
    return res


def analyze_outcomes(res, rng: np.random.Generator) -> OutcomeResults:
    """Fit the single factors of every extra outcome of ``res`` (a
    :class:`~rcsim.analysis.results.drivers.pipeline.DriverResults` whose pooled singles are
    fitted), all on the same permutations, and flag their drivers family-wise over every
    outcome and input (module docstring) at ``res.levels["outcomes"]``.
    """
    rs, st = res.runset, res.settings
    out = build_outcomes(rs, getattr(st, "second_threshold", DEFAULT_SECOND_THRESHOLD))
    codes = None  # the inputs' rank-scale bins: the same for every outcome, computed once
    seed = int(rng.integers(2**63))  # every outcome's permutations from this one seed
    fitted = []
    for o in out.outcomes:
        if o.y.all() or not o.y.any():
            continue
        if codes is None:
            codes = bin_codes(rank_scale(rs.X.to_numpy(float)), N_BINS_1D)
        o.singles = SingleFactorKDE(
            n_permutations=st.n_permutations, random_state=np.random.default_rng(seed)
        ).fit(rs.X, o.y, rs.strata, codes=codes, joint=True)
        fitted.append(o)
    if fitted:
        max_null = np.max([o.singles.null_max_z_ for o in fitted], axis=0)
        level = (getattr(res, "levels", None) or {}).get("outcomes", st.alpha)
        for o in fitted:
            o.p_family = maxt_p(o.singles.z_, max_null)
            o.significant = o.p_family < level
    return out


def pooled_criterion(runset) -> str:
    """What the analysed outcome means: the campaign's criterion for its ``failed`` column."""
    thr = campaign_threshold(runset.manifest)
    if runset.outcome != "failed" or thr is None:
        return f"column {runset.outcome!r}"
    att = ((runset.manifest or {}).get("thresholds") or {}).get("attitude_error_deg")
    flown = ((runset.manifest or {}).get("spec") or {}).get("vehicle")
    budgets = (runset.manifest or {}).get("thresholds") or {}
    return runs_table.criterion_text(thr, att, vehicle_file=bool(flown), budgets=budgets)


def outcome_table(res, top: int = TOP_DRIVERS) -> pd.DataFrame:
    """``outcomes.csv``: per outcome (the pooled one first) its counts, failure probability
    with its Clopper-Pearson 95 % interval and runs to the bound, and its top drivers (one row
    each: rank, factor, score, p-value, significant, the factor's rank on the pooled outcome).
    ``p_value`` and ``significant`` are the report's: for the pooled outcome the single
    drivers' family, for the others the outcome family over every outcome and input.
    """
    rs, st = res.runset, res.settings
    bound_p = float(getattr(st, "bound_p", 0.01))
    pooled = Outcome(rs.outcome, pooled_criterion(rs), rs.y, res.singles)
    extra = res.outcomes.outcomes if getattr(res, "outcomes", None) is not None else []
    pooled_rank = (
        dict(zip(res.singles.feature_names_in_, res.singles.rank_))
        if res.singles is not None
        else {}
    )
    rows = []
    for o in [pooled, *extra]:
        prob = probability_frame(o.failed, o.runs, bound_p).iloc[0].to_dict()
        if o.by_construction:  # a share fixed by the definition is no estimate
            prob.update(cp95_low=np.nan, cp95_high=np.nan, runs_to_bound=np.nan)
        base = {
            "outcome": o.name,
            "criterion": o.criterion,
            "runs": o.runs,
            "failed": o.failed,
            **prob,
            "bound_p": bound_p,
        }
        if o.singles is None:
            rows.append({**base, "rank": 0, "factor": ""})
            continue
        t = o.singles.table().head(top)
        p_of, flag_of = _family_calls(o, res)
        for _, r in t.iterrows():
            rows.append(
                {
                    **base,
                    "rank": int(r["rank"]),
                    "factor": r["factor"],
                    "score": r["score"],
                    "p_value": p_of[r["factor"]],
                    "significant": flag_of[r["factor"]],
                    "pooled_rank": pooled_rank.get(r["factor"], np.nan),
                    "failure_region": r["failure_region"],
                }
            )
    return pd.DataFrame(rows)


def _family_calls(o: Outcome, res) -> tuple[dict, dict]:
    """Per factor, the p-value and the flag the report shows for outcome ``o``: the pooled
    outcome's are the single drivers' (``res.drivers``), the others' the outcome family's."""
    assert o.singles is not None  # called for fitted outcomes only
    names = list(o.singles.feature_names_in_)
    if o.p_family is None or o.significant is None:  # the pooled outcome
        d = res.drivers.set_index("factor")
        return (
            {f: float(d.loc[f, "p_value"]) for f in names},
            {f: bool(d.loc[f, "significant"]) for f in names},
        )
    return (
        dict(zip(names, map(float, o.p_family))),
        dict(zip(names, map(bool, o.significant))),
    )
