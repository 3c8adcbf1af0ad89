"""Scenario-discovery boxes: PRIM (Friedman & Fisher 1999) on the significant inputs, their
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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
import pandas as pd
from scipy import stats

from rcsim.analysis.results.proportions import clopper_pearson

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
#: Inputs (most significant first) whose pairwise ratios are offered to PRIM.
MAX_RATIO_INPUTS = 8
#: Most significant inputs PRIM sees (by rank).
MAX_INPUTS = 30
#: Most runs the boxes are searched on; beyond, a seeded uniform subsample of this size (four
#: times the paper's campaign; a 250,000-run table would otherwise cost ~15 s of CPU).
MAX_BOX_RUNS = 100_000
#: The categorical dimension's name.
CASE = "case"


def _ema_quantiles(XbT: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``XbT`` (inputs x runs), EMA Workbench's ``get_quantile`` at ``alpha`` and
    ``1 - alpha``.

    Lower: the midpoint between the sorted value at ``floor((m - 1) alpha)`` and the next larger
    distinct value; upper: between the value at ``ceil((m - 1)(1 - alpha))`` and the next smaller
    distinct value (each the value itself when there is none).
    """
    m = XbT.shape[1]
    k = int(np.floor((m - 1) * alpha))
    c = int(np.ceil((m - 1) * (1.0 - alpha)))
    # Rows are contiguous: partitioning along them is several times faster than down columns.
    part = np.partition(XbT, sorted({k, c}), axis=1)
    dk, dc = part[:, k : k + 1], part[:, c : c + 1]
    nxt = np.where(XbT > dk, XbT, np.inf).min(axis=1)
    prv = np.where(XbT < dc, XbT, -np.inf).max(axis=1)
    dk, dc = dk[:, 0], dc[:, 0]
    nxt = np.where(np.isfinite(nxt), nxt, dk)
    prv = np.where(np.isfinite(prv), prv, dc)
    return (dk + nxt) / 2.0, (prv + dc) / 2.0


def _objective(kind: str, m: int, f: int, n_new: np.ndarray, f_new: np.ndarray) -> np.ndarray:
    """EMA's objectives of the candidate boxes (``n_new`` runs, ``f_new`` failed) of a box of
    ``m`` runs with ``f`` failed."""
    n_new = n_new.astype(float)
    mean_old = f / m
    mean_new = np.divide(f_new, n_new, out=np.zeros_like(n_new), where=n_new > 0)
    if kind == "original":
        return np.where(n_new > 0, mean_new, -1.0)
    dn = np.abs(m - n_new)
    change = mean_new - mean_old
    if kind == "lenient1":
        out = np.divide(change, dn, out=np.zeros_like(n_new), where=dn > 0)
    elif kind == "lenient2":
        out = np.divide(n_new * change, dn, out=np.zeros_like(n_new), where=dn > 0)
    else:
        raise ValueError(f"objective must be lenient1, lenient2 or original, got {kind!r}")
    return np.where(mean_new != mean_old, out, 0.0)


@dataclass
class Trajectory:
    """The boxes of one peeling sequence, step 0 = all runs searched.

    ``lo``/``hi`` (steps, p) are the limits (``-inf``/``inf``: unrestricted), ``cats`` (steps, K)
    the cases allowed, ``runs``/``failed`` (steps,) the runs and failures inside (among the
    runs searched), ``total_failed`` all failures of the run set, ``total_runs`` all its runs.
    """

    lo: np.ndarray
    hi: np.ndarray
    cats: np.ndarray
    runs: np.ndarray
    failed: np.ndarray
    total_runs: int
    total_failed: int

    @property
    def coverage(self) -> np.ndarray:
        return self.failed / max(self.total_failed, 1)

    @property
    def density(self) -> np.ndarray:
        return self.failed / np.maximum(self.runs, 1)

    @property
    def support(self) -> np.ndarray:
        return self.runs / self.total_runs

    def n_restricted(self) -> np.ndarray:
        dims = (np.isfinite(self.lo) | np.isfinite(self.hi)).sum(axis=1)
        return dims + (~self.cats.all(axis=1)).astype(int)


def peel(
    X: np.ndarray,
    y: np.ndarray,
    codes: np.ndarray | None = None,
    n_cats: int = 0,
    rows: np.ndarray | None = None,
    *,
    peel_alpha: float = 0.05,
    min_support: float = 0.05,
    objective: str = "lenient1",
) -> Trajectory:
    """One PRIM peeling sequence (no pasting) on the runs ``rows`` (default: all).

    Parameters
    ----------
    X : ndarray float (n, p)
        Continuous inputs.
    y : ndarray bool (n,)
    codes : ndarray int (n,), optional
        The case of each run, ``0 .. n_cats - 1`` (a categorical dimension peeled one case at
        a time).
    rows : ndarray int, optional
        The runs searched (the others belong to earlier boxes); support is over all ``n`` runs.
    peel_alpha, min_support, objective
        As EMA Workbench's ``peel_alpha``, ``mass_min`` and ``obj_function``.
    """
    X = np.asarray(X, float)
    y = np.asarray(y, bool)
    n, p = X.shape
    rows = np.arange(n) if rows is None else np.asarray(rows)
    has_cat = codes is not None and n_cats > 1
    kodes = np.zeros(n, np.int64) if codes is None else np.asarray(codes)
    lo, hi = np.full(p, -np.inf), np.full(p, np.inf)
    cats = np.ones(max(n_cats, 1), bool)
    yi = y.astype(np.int64)
    traj: dict[str, list] = {"lo": [], "hi": [], "cats": [], "runs": [], "failed": []}

    def record(idx):
        traj["lo"].append(lo.copy())
        traj["hi"].append(hi.copy())
        traj["cats"].append(cats.copy())
        traj["runs"].append(idx.size)
        traj["failed"].append(int(yi[idx].sum()))

    XT = np.ascontiguousarray(X.T)  # inputs x runs
    idx = rows
    record(idx)
    while idx.size >= 2:
        XbT, yb = XT[:, idx], yi[idx]
        m, f = idx.size, int(yb.sum())
        v_lo, v_hi = _ema_quantiles(XbT, peel_alpha)
        keep_hi, keep_lo = XbT <= v_hi[:, None], XbT >= v_lo[:, None]
        # Candidates in EMA's order: per input its upper then its lower peel, then the cases.
        n_new = np.stack([keep_hi.sum(axis=1), keep_lo.sum(axis=1)], axis=1).ravel()
        f_new = np.stack([keep_hi @ yb, keep_lo @ yb], axis=1).ravel()
        restricted = np.isfinite(lo) | np.isfinite(hi)
        base_r = int(restricted.sum()) + int(has_cat and not cats.all())
        nres = np.repeat(base_r + (~restricted).astype(int), 2)
        if has_cat and cats.sum() > 1:
            cb = kodes[idx]
            cnt = np.bincount(cb, minlength=n_cats)
            fcnt = np.bincount(cb, weights=yb, minlength=n_cats).astype(np.int64)
            allowed = np.flatnonzero(cats)
            n_new = np.concatenate([n_new, m - cnt[allowed]])
            f_new = np.concatenate([f_new, f - fcnt[allowed]])
            nres = np.concatenate([nres, np.full(allowed.size, base_r + int(cats.all()))])
        if not n_new.size:  # no input and a single case left: nothing to peel
            break
        obj = _objective(objective, m, f, n_new, f_new)
        # Best objective; ties: fewer restricted dimensions, then the first candidate.
        order = np.lexsort((np.arange(obj.size), nres, -obj))
        best = int(order[0])
        if not (n_new[best] / X.shape[0] >= min_support and n_new[best] < m and obj[best] > 0):
            break
        if best < 2 * p:
            j, side = divmod(best, 2)
            if side == 0:
                hi[j] = v_hi[j]
                idx = idx[keep_hi[j]]
            else:
                lo[j] = v_lo[j]
                idx = idx[keep_lo[j]]
        else:
            c = int(allowed[best - 2 * p])
            cats[c] = False
            idx = idx[kodes[idx] != c]
        record(idx)
    return Trajectory(
        lo=np.array(traj["lo"]),
        hi=np.array(traj["hi"]),
        cats=np.array(traj["cats"]),
        runs=np.array(traj["runs"]),
        failed=np.array(traj["failed"]),
        total_runs=int(n),
        total_failed=int(y.sum()),
    )


def in_box(X, codes, lo, hi, cats) -> np.ndarray:
    """Runs inside the box ``lo <= x <= hi`` (and, with ``codes``, in an allowed case)."""
    inside = ((X >= lo) & (X <= hi)).all(axis=1)
    if codes is not None and cats.size > 1:
        inside &= cats[codes]
    return inside


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


def prune(X, y, codes, lo, hi, cats, rows, qp_max: float = QP_MAX):
    """Drop the restrictions that do not matter, least significant first (see module doc)."""
    lo, hi, cats = lo.copy(), hi.copy(), cats.copy()
    while True:
        qp = quasi_p(X, y, codes, lo, hi, cats, rows)
        if len(qp) <= 1:
            return lo, hi, cats
        j, worst = max(qp.items(), key=lambda kv: kv[1])
        if worst <= qp_max:
            return lo, hi, cats
        if j < 0:
            cats[:] = True
        else:
            lo[j], hi[j] = -np.inf, np.inf


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
        return self._limits(box.lo, box.hi)

    def _limits(self, lo, hi) -> str:
        parts = []
        for j, name in enumerate(self.names):
            a, b = lo[j], hi[j]
            if np.isfinite(a) and np.isfinite(b):
                parts.append(f"{a:.4g} <= {name} <= {b:.4g}")
            elif np.isfinite(a):
                parts.append(f"{name} >= {a:.4g}")
            elif np.isfinite(b):
                parts.append(f"{name} <= {b:.4g}")
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
    min_support: float = 0.05,
) -> BoxResults:
    """PRIM boxes on ``factors`` (columns of ``X``), their pairwise ratios and the case.

    Parameters
    ----------
    X : DataFrame (n, inputs)
    y : ndarray bool (n,)
    strata : ndarray (n,) or None
        The rate case of each run (a restrictable dimension when there are several).
    factors : list of str
        The inputs searched (the significant drivers, best first).
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
        t = peel(
            M,
            y,
            codes,
            len(case_names),
            remaining,
            peel_alpha=peel_alpha,
            min_support=min_support,
        )
        step = choose(t, left_failed)
        res.trajectories.append(t)
        res.chosen.append(step)
        lo, hi, cats = prune(M, y, codes, t.lo[step], t.hi[step], t.cats[step], remaining)
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


def regions_1d(X: pd.DataFrame, y: np.ndarray, drivers: pd.DataFrame, res: BoxResults):
    """A 1-D PRIM region (that input alone, all runs) for each significant driver, and, for one
    without a KDE failure region, why it has none: it acts jointly (it is a limit of box N) or
    its effect over all runs is weak (it may still matter within cases: the per-case analysis).

    The case is not offered here: with it, the best 1-D "region" of a weak input is the cases
    that fail most, which says nothing about the input.

    Returns a DataFrame ``factor, rank, region_1d, region_1d_density, region_1d_coverage,
    region_1d_lift, region_note``.
    """
    y = np.asarray(y, bool)
    base = res.base_rate
    rows = []
    sig = drivers[drivers["significant"].astype(bool)]
    for _, r in sig.iterrows():
        f = r["factor"]
        has_region = bool(str(r.get("failure_region", "") or "").strip())
        x = X[f].to_numpy(float)[:, None]
        t = peel(x, y)
        step = choose(t, int(y.sum()))
        lo, hi = t.lo[step, 0], t.hi[step, 0]
        if np.isfinite(lo) and np.isfinite(hi):
            text = f"{lo:.4g} .. {hi:.4g}"
        elif np.isfinite(lo):
            text = f">= {lo:.4g}"
        elif np.isfinite(hi):
            text = f"<= {hi:.4g}"
        else:
            text = ""
        dens, cov = float(t.density[step]), float(t.coverage[step])
        in_boxes = res.dims_of(f)
        where = ", ".join(f"box {b}" for b in in_boxes)
        lift = dens / base if base > 0 else np.nan
        if has_region:
            note = "1-D failure region" + (f"; also a limit of {where}" if where else "")
        elif in_boxes:
            note = f"no 1-D region: acts jointly, a limit of {where}"
        elif text:
            note = (
                f"no 1-D region and in no box: weak alone (its best range raises P(fail) "
                f"{lift:.2g}x); see Per case"
            )
        else:
            note = "no 1-D region and in no box: no range of it alone raises P(fail); see Per case"
        rows.append(
            {
                "factor": f,
                "rank": int(r["rank"]),
                "region_1d": text,
                "region_1d_density": dens,
                "region_1d_coverage": cov,
                "region_1d_lift": lift,
                "region_note": note,
            }
        )
    cols = [
        "factor",
        "rank",
        "region_1d",
        "region_1d_density",
        "region_1d_coverage",
        "region_1d_lift",
        "region_note",
    ]
    return pd.DataFrame(rows, columns=cols)


def analyze_boxes(res) -> BoxResults | None:
    """Boxes of a :class:`~rcsim.analysis.results.drivers.pipeline.DriverResults` (its significant
    drivers, their ratios and the case), with the 1-D regions of its significant drivers."""
    if not res.has_failures or res.drivers is None:
        return None
    rs = res.runset
    X, y, strata = rs.X, rs.y, rs.strata
    n = y.size
    if n > MAX_BOX_RUNS:
        # Seeded apart from the analysis' SeedSequence children: no other result changes.
        rng = np.random.default_rng(np.random.SeedSequence([res.settings.random_state, 0xB0C5]))
        keep = np.sort(rng.choice(n, MAX_BOX_RUNS, replace=False))
        X = X.iloc[keep].reset_index(drop=True)
        y = y[keep]
        strata = None if strata is None else strata[keep]
    sig = res.drivers[res.drivers["significant"].astype(bool)]
    factors = [f for f in sig["factor"] if X[f].nunique() > 1]
    out = find_boxes(X, y, strata, factors)
    out.regions_1d = regions_1d(X, y, res.drivers, out)
    out.subsample_of = n if n > MAX_BOX_RUNS else None
    return out
