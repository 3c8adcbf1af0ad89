"""Scenario-discovery boxes: PRIM (Friedman & Fisher 1999) on the flagged inputs, their
ratios and the rate case.

A box is a conjunction of limits ``lo <= x_j <= hi`` on a few inputs (and a set of cases) where
runs fail much more often than overall.  PRIM finds one by *peeling*: starting from every run,
it tries to cut the ``peel_alpha`` share of the box's runs off the low or the high end of each
input (or one whole case off the case dimension) and keeps the cut with the best objective, until
the box would hold fewer than ``min_support`` of the runs.  Each peel is a point of the *peeling
trajectory* (coverage against density): early boxes hold most failures at a modest failure rate,
late ones few failures at a high rate.  The reported box is chosen on it by :data:`CHOICE_RULE`;
the trajectory is reported so that a reader can pick another.

The peeling reproduces EMA Workbench's ``prim.Prim`` (quantiles as its ``get_quantile``, the
same ``lenient1`` objective and tie-break, the same stopping rule: benchmarks/prim_vs_ema.py and
docs/drivers.md), without its pasting phase, and is batched with numpy: one step costs two
partial sorts and a few boolean reductions of the ``(runs in box, inputs)`` matrix.

Covering: after a box is chosen its runs are removed and the next box is searched among the
remaining ones (EMA's default), up to ``max_boxes``, while a box keeps at least
``MIN_BOX_FAILURES`` failures at a failure rate of at least ``MIN_LIFT`` times the overall one.

Restrictions that do not matter are dropped from the chosen box: a restriction whose removal
does not lower the box's failure rate significantly (EMA's quasi-p-value: one-sided binomial
test of the box's failures against the failure rate of the box without it, > ``QP_MAX``) is
removed, the least significant first.

A box holds only what fails (a box was once padded with four cases that never failed, and a
threshold that did nothing in one of its two cases).  :data:`CASE_RULE`: a case is in a box
exactly when, among that case's runs searched, the box's input limits hold failures at least
``MIN_LIFT`` times the overall failure rate *and* separate them -- more of the case's failures
inside the limits than of its runs, one-sided hypergeometric p <= :data:`SEPARATION_P` (for a
box without input limits, the density alone).  Every case is judged, also those the peeling
dropped.  A case left out keeps its runs for the next box; the limits are pruned again on the
cases kept, until both rules agree.

Minimum box size: peeling stops at ``min(5 %, half the share of runs that failed)`` of all
runs -- the smallest box that can hold half of all failures at density 1 -- so a rare tail
(3 % of runs) can get a box of its own size, where a fixed 5 % floor padded it with successful
runs (density 0.51 against a true 0.9).  The floor is the same for every search: a later box
smaller than that would be a sliver of an earlier one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
import pandas as pd
from scipy import stats

from rcsim.analysis.results.drivers.prim import Trajectory, _ema_quantiles, peel
from rcsim.analysis.results.proportions import clopper_pearson

__all__ = ["Trajectory", "_ema_quantiles", "peel"]  # the peeling, re-exported for callers

#: How the reported box is chosen on the peeling trajectory.
CHOICE_RULE = (
    "the densest box on the peeling trajectory that still holds at least half of the failures "
    "left to explain"
)
#: Smallest share of the (remaining) failures the chosen box must hold.
MIN_COVERAGE = 0.5
#: A box is reported only when its failure rate is at least this many times the overall one
#: (the factor of the 1-D failure regions).
MIN_LIFT = 2.0
#: ... and when it holds at least this many failures.
MIN_BOX_FAILURES = 5
#: Restrictions with a quasi-p-value above this are dropped from a chosen box.
QP_MAX = 0.05
#: Inputs (the first flagged) whose pairwise ratios are offered to PRIM.
MAX_RATIO_INPUTS = 8
#: Most flagged inputs PRIM sees (best first).
MAX_INPUTS = 30
#: Most runs the boxes are searched on; beyond, a seeded uniform subsample of this size (four
#: times the paper's campaign; a 250,000-run table would otherwise cost ~15 s of CPU).
MAX_BOX_RUNS = 100_000
#: The categorical dimension's name.
CASE = "case"
#: The rule that keeps a case in a box (module docstring).
CASE_RULE = (
    "a case is in a box exactly when the box's limits hold its failures at least "
    f"{MIN_LIFT:g}x the overall failure rate and separate them (more of the case's failures "
    "inside than of its runs, one-sided hypergeometric p <= 0.05)"
)
#: One-sided hypergeometric p-value at or below which a box's limits separate a case's failures.
SEPARATION_P = 0.05
#: Largest peeling floor [share of all runs] (EMA Workbench's ``mass_min`` default).
MAX_MIN_SUPPORT = 0.05


def in_box(X, codes, lo, hi, cats) -> np.ndarray:
    """Runs inside the box ``lo <= x <= hi`` (and, with ``codes``, in an allowed case)."""
    inside = ((X >= lo) & (X <= hi)).all(axis=1)
    if codes is not None and cats.size > 1:
        inside &= cats[codes]
    return inside


def limit_text(limit: float, values: np.ndarray, upper: bool) -> str:
    """``limit`` written with the fewest significant figures (at least 4) at which it keeps
    exactly the runs it keeps: applying the printed limit (``x <= printed`` for an upper
    limit, ``x >= printed`` for a lower one) to ``values`` (every run's value of the
    dimension) gives the same runs, so the counts a sentence states can be recounted from
    the printed text.  "" for an infinite (absent) limit."""
    if not np.isfinite(limit):
        return ""
    v = np.asarray(values, float)
    keep = v <= limit if upper else v >= limit
    for digits in range(4, 18):
        text = f"{limit:.{digits}g}"
        printed = float(text)
        if np.array_equal(v <= printed if upper else v >= printed, keep):
            return text
    return repr(float(limit))


def choose(traj: Trajectory, remaining_failed: int, min_coverage: float = MIN_COVERAGE) -> int:
    """Step of the trajectory chosen by :data:`CHOICE_RULE` (densest with enough coverage;
    ties: the larger coverage)."""
    share = traj.failed / max(remaining_failed, 1)
    ok = np.flatnonzero(share >= min_coverage - 1e-12)
    if not ok.size:
        return 0
    dens = traj.density[ok]
    best = ok[dens >= dens.max() - 1e-12]
    return int(best[np.argmax(traj.failed[best])])


def quasi_p(X, y, codes, lo, hi, cats, rows) -> dict:
    """EMA's quasi-p-value of each restriction of a box (searched among ``rows``): one-sided
    binomial test of the box's failures against the failure rate without that restriction.

    Keys: the input's column, ``-1`` for the case."""
    yr = y[rows]
    dims = [j for j in range(X.shape[1]) if np.isfinite(lo[j]) or np.isfinite(hi[j])]
    ok = [(X[rows, j] >= lo[j]) & (X[rows, j] <= hi[j]) for j in dims]
    if codes is not None and cats.size > 1 and not cats.all():
        dims.append(-1)
        ok.append(cats[codes[rows]])
    if not dims:
        return {}
    okm = np.array(ok)
    bad = (~okm).sum(axis=0)
    inside = bad == 0
    k, n = int(yr[inside].sum()), int(inside.sum())
    out = {}
    for i, j in enumerate(dims):
        wider = inside | ((bad == 1) & ~okm[i])  # the box without restriction i
        p0 = yr[wider].mean()
        out[j] = float(stats.binom.sf(k - 1, n, p0)) if n else 1.0
    return out


def prune(X, y, codes, lo, hi, cats, rows, qp_max: float = QP_MAX, cases: bool = True):
    """Drop the restrictions that do not matter, least significant first (see module doc);
    ``cases=False`` leaves the case restriction as it is (only input limits may go)."""
    lo, hi, cats = lo.copy(), hi.copy(), cats.copy()
    while True:
        qp = quasi_p(X, y, codes, lo, hi, cats, rows)
        if not cases:
            qp.pop(-1, None)
        if len(qp) <= (1 if cases else 0):
            return lo, hi, cats
        j, worst = max(qp.items(), key=lambda kv: kv[1])
        if worst <= qp_max:
            return lo, hi, cats
        if j < 0:
            cats[:] = True
        else:
            lo[j], hi[j] = -np.inf, np.inf


def case_rule(X, y, codes, lo, hi, cats, rows, base: float) -> np.ndarray:
    """The cases of ``cats`` whose failures the box concentrates (:data:`CASE_RULE`): among
    the runs ``rows``, each case's failures inside the input limits are at least ``MIN_LIFT x
    base`` of its runs inside and, when the box limits an input, over-represented there
    (one-sided hypergeometric p <= :data:`SEPARATION_P`)."""
    K = cats.size
    c, yr = codes[rows], y[rows].astype(float)
    inside = ((X[rows] >= lo) & (X[rows] <= hi)).all(axis=1)
    n_case = np.bincount(c, minlength=K)
    f_case = np.bincount(c, weights=yr, minlength=K)
    n_in = np.bincount(c[inside], minlength=K)
    f_in = np.bincount(c[inside], weights=yr[inside], minlength=K)
    keep = cats & (f_in >= 1) & (f_in >= MIN_LIFT * base * n_in)
    if np.isfinite(lo).any() or np.isfinite(hi).any():
        p = stats.hypergeom.sf(f_in - 1, n_case, f_case, n_in)
        keep &= p <= SEPARATION_P
    return keep


def settle(X, y, codes, lo, hi, cats, rows, base: float, rounds: int = 5):
    """The pruned box with its cases set by :func:`case_rule` over *every* case (those the
    peeling dropped too: peeling for density drops cases that happen to hold fewer failures,
    and a tail that acts in every case lost 8 of 26 to it), limits pruned again on the cases
    kept, until the two agree (``cats`` all False: no case holds the box)."""
    lo, hi, cats = prune(X, y, codes, lo, hi, cats, rows)
    if codes is None or cats.size < 2:
        return lo, hi, cats
    every = np.ones_like(cats)
    for _ in range(rounds):
        kept = case_rule(X, y, codes, lo, hi, every, rows, base)
        if np.array_equal(kept, cats) or not kept.any():
            return lo, hi, kept
        cats = kept
        lo, hi, _ = prune(X, y, codes, lo, hi, cats, rows, cases=False)
    return lo, hi, case_rule(X, y, codes, lo, hi, every, rows, base)


@dataclass
class Box:
    """One chosen (and pruned) box."""

    number: int
    lo: np.ndarray
    hi: np.ndarray
    cats: np.ndarray
    runs: int
    failed: int
    coverage: float
    density: float
    support: float
    p_lo: float
    p_hi: float
    step: int
    qp: dict
    dims: list = field(default_factory=list)  # restricted dimension names (case last)
    #: Each dimension's limits as printed (:func:`limit_text`; "" where not limited).
    lo_text: list = field(default_factory=list)
    hi_text: list = field(default_factory=list)


@dataclass
class BoxResults:
    """PRIM boxes of a run set: the dimensions searched, each box and its trajectory."""

    names: list
    case_names: list
    base_rate: float
    total_runs: int
    total_failed: int
    boxes: list
    trajectories: list  # one per search (the last may have given no box)
    chosen: list  # chosen step per trajectory
    ratio_parts: dict  # ratio name -> (numerator, denominator)
    regions_1d: pd.DataFrame | None = None
    #: Runs of the run set when the boxes were searched on a subsample of them (else None).
    subsample_of: int | None = None

    def limits_text(self, box: Box) -> str:
        return self._limits(box.lo, box.hi, (box.lo_text, box.hi_text) if box.lo_text else None)

    def _limits(self, lo, hi, texts=None) -> str:
        parts = []
        for j, name in enumerate(self.names):
            a, b = lo[j], hi[j]
            # A chosen box's limits as printed (they reproduce its counts); a trajectory's
            # other boxes, for browsing, to 4 figures.
            ta = texts[0][j] if texts else f"{a:.4g}"
            tb = texts[1][j] if texts else f"{b:.4g}"
            if np.isfinite(a) and np.isfinite(b):
                parts.append(f"{ta} <= {name} <= {tb}")
            elif np.isfinite(a):
                parts.append(f"{name} >= {ta}")
            elif np.isfinite(b):
                parts.append(f"{name} <= {tb}")
        return "; ".join(parts)

    def cases_text(self, box: Box) -> str:
        return self._cases(box.cats)

    def _cases(self, cats) -> str:
        if not self.case_names or cats.all():
            return "all"
        return ", ".join(c for c, k in zip(self.case_names, cats) if k)

    def table(self) -> pd.DataFrame:
        """``boxes.csv``: one row per box."""
        cols = [
            "box",
            "coverage",
            "density",
            "support",
            "runs",
            "failed",
            "p_fail_ci_lo",
            "p_fail_ci_hi",
            "lift",
            "limits",
            "cases",
            "restricted",
            "trajectory_step",
        ]
        rows = [
            {
                "box": b.number,
                "coverage": b.coverage,
                "density": b.density,
                "support": b.support,
                "runs": b.runs,
                "failed": b.failed,
                "p_fail_ci_lo": b.p_lo,
                "p_fail_ci_hi": b.p_hi,
                "lift": b.density / self.base_rate if self.base_rate > 0 else np.nan,
                "limits": self.limits_text(b),
                "cases": self.cases_text(b),
                "restricted": ", ".join(b.dims),
                "trajectory_step": b.step,
            }
            for b in self.boxes
        ]
        return pd.DataFrame(rows, columns=cols)

    def limits_table(self) -> pd.DataFrame:
        """One row per restriction of each box: dimension, lower, upper, quasi-p-value."""
        rows = []
        for b in self.boxes:
            for j, name in enumerate(self.names):
                if np.isfinite(b.lo[j]) or np.isfinite(b.hi[j]):
                    rows.append(
                        {
                            "box": b.number,
                            "dimension": name,
                            "lower": b.lo[j] if np.isfinite(b.lo[j]) else np.nan,
                            "upper": b.hi[j] if np.isfinite(b.hi[j]) else np.nan,
                            "cases": "",
                            "qp_value": b.qp.get(j, np.nan),
                        }
                    )
            if self.case_names and not b.cats.all():
                rows.append(
                    {
                        "box": b.number,
                        "dimension": CASE,
                        "lower": np.nan,
                        "upper": np.nan,
                        "cases": self.cases_text(b),
                        "qp_value": b.qp.get(-1, np.nan),
                    }
                )
        return pd.DataFrame(
            rows, columns=["box", "dimension", "lower", "upper", "cases", "qp_value"]
        )

    def trajectory_table(self) -> pd.DataFrame:
        """``trajectory.csv``: every step of every search (``box`` = search number)."""
        frames = []
        for k, (t, c) in enumerate(zip(self.trajectories, self.chosen)):
            frames.append(
                pd.DataFrame(
                    {
                        "box": k + 1,
                        "step": np.arange(t.runs.size),
                        "coverage": t.coverage,
                        "density": t.density,
                        "support": t.support,
                        "runs": t.runs,
                        "failed": t.failed,
                        "restricted": t.n_restricted(),
                        "chosen": np.arange(t.runs.size) == c,
                        "reported": k < len(self.boxes),
                        "limits": [self._limits(a, b) for a, b in zip(t.lo, t.hi)],
                        "cases": [self._cases(m) for m in t.cats],
                    }
                )
            )
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()

    def dims_of(self, factor: str) -> list[int]:
        """Numbers of the boxes restricting ``factor`` directly or through a ratio."""
        out = []
        for b in self.boxes:
            for d in b.dims:
                if d == factor or factor in self.ratio_parts.get(d, ()):
                    out.append(b.number)
                    break
        return out


def ratio_columns(X: pd.DataFrame, factors: list, max_inputs: int = MAX_RATIO_INPUTS) -> dict:
    """``a/b`` for each pair of the first ``max_inputs`` factors that keep one strict sign
    (a ratio of inputs that cross zero has no meaning as a band); constant ratios (an input and
    its copy) are skipped."""
    use = [f for f in factors if (X[f] > 0).all() or (X[f] < 0).all()][:max_inputs]
    out = {}
    for a, b in combinations(use, 2):
        r = (X[a] / X[b]).to_numpy(float)
        if np.isfinite(r).all() and np.unique(np.round(r, 12)).size >= 10:
            out[f"{a}/{b}"] = (a, b, r)
    return out


def find_boxes(
    X: pd.DataFrame,
    y: np.ndarray,
    strata: np.ndarray | None,
    factors: list,
    *,
    max_boxes: int = 3,
    ratios: bool = True,
    peel_alpha: float = 0.05,
    min_support: float | None = None,
) -> BoxResults:
    """PRIM boxes on ``factors`` (columns of ``X``), their pairwise ratios and the case.

    Parameters
    ----------
    X : DataFrame (n, inputs)
    y : ndarray bool (n,)
    strata : ndarray (n,) or None
        The rate case of each run (a restrictable dimension when there are several).
    factors : list of str
        The inputs searched (the flagged drivers, best first).
    min_support : float, optional
        Peeling floor [share of all runs]; default adaptive (module docstring).
    """
    y = np.asarray(y, bool)
    factors = list(factors)[:MAX_INPUTS]
    cols = {f: X[f].to_numpy(float) for f in factors}
    ratio_parts = {}
    if ratios:
        for name, (a, b, r) in ratio_columns(X, factors).items():
            cols[name] = r
            ratio_parts[name] = (a, b)
    names = list(cols)
    M = np.column_stack([cols[k] for k in names]) if names else np.zeros((y.size, 0))
    codes, case_names = _case_codes(strata)
    n, total_failed = y.size, int(y.sum())
    base = total_failed / n
    res = BoxResults(names, case_names, base, n, total_failed, [], [], [], ratio_parts)
    if M.shape[1] == 0 and codes is None:
        return res
    remaining = np.arange(n)
    for k in range(max_boxes):
        left_failed = int(y[remaining].sum())
        if left_failed < MIN_BOX_FAILURES:
            break
        floor = min(MAX_MIN_SUPPORT, 0.5 * base) if min_support is None else min_support
        t = peel(
            M,
            y,
            codes,
            len(case_names),
            remaining,
            peel_alpha=peel_alpha,
            min_support=floor,
        )
        step = choose(t, left_failed)
        res.trajectories.append(t)
        res.chosen.append(step)
        lo, hi, cats = settle(M, y, codes, t.lo[step], t.hi[step], t.cats[step], remaining, base)
        if not cats.any():  # no case holds what the box was chosen for
            break
        inside = in_box(M[remaining], None if codes is None else codes[remaining], lo, hi, cats)
        runs, failed = int(inside.sum()), int(y[remaining][inside].sum())
        density = failed / max(runs, 1)
        if failed < MIN_BOX_FAILURES or density < MIN_LIFT * base or step == 0:
            break
        plo, phi = clopper_pearson(failed, runs)
        dims = [nm for j, nm in enumerate(names) if np.isfinite(lo[j]) or np.isfinite(hi[j])]
        if codes is not None and not cats.all():
            dims.append(CASE)
        res.boxes.append(
            Box(
                number=k + 1,
                lo=lo,
                hi=hi,
                cats=cats,
                runs=runs,
                failed=failed,
                coverage=failed / max(total_failed, 1),
                density=density,
                support=runs / n,
                p_lo=float(plo),
                p_hi=float(phi),
                step=step,
                qp=quasi_p(M, y, codes, lo, hi, cats, remaining),
                dims=dims,
                lo_text=[limit_text(v, M[:, j], upper=False) for j, v in enumerate(lo)],
                hi_text=[limit_text(v, M[:, j], upper=True) for j, v in enumerate(hi)],
            )
        )
        remaining = remaining[~inside]
    return res


def _case_codes(strata) -> tuple[np.ndarray | None, list]:
    """Integer codes of the cases (sorted names), or ``(None, [])`` for fewer than two."""
    if strata is None:
        return None, []
    names = sorted({str(c) for c in np.asarray(strata)})
    if len(names) < 2:
        return None, []
    return np.searchsorted(names, np.asarray(strata).astype(str)), names
