"""PRIM's peeling (Friedman & Fisher 1999), as EMA Workbench's ``prim.Prim`` does it.

A box is a conjunction of limits ``lo <= x_j <= hi`` on a few inputs (and a set of cases).
Peeling starts from every run and, step by step, cuts the ``peel_alpha`` share of the box's
runs off the low or the high end of one input (or one whole case off the case dimension),
keeping the cut with the best objective, until the box would hold fewer than ``min_support``
of all runs.  Each step is a point of the *peeling trajectory* (coverage against density).

Reproduces EMA Workbench's peeling (quantiles as its ``get_quantile``, the same ``lenient1``
objective and tie-break, the same stopping rule; no pasting): benchmarks/prim_vs_ema.py and
docs/drivers.md.  Batched with numpy: one step costs two partial sorts and a few boolean
reductions of the ``(runs in box, inputs)`` matrix.  The choice of a box on the trajectory and
the covering search are :mod:`rcsim.analysis.results.drivers.boxes`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
