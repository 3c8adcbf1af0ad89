"""The scenario boxes of a driver analysis: PRIM on its flagged drivers, and a 1-D range for
each flagged driver without a failure region (:mod:`rcsim.analysis.results.drivers.boxes`
searches; this module picks what to search and explains the drivers)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers.boxes import (
    MAX_BOX_RUNS,
    MAX_MIN_SUPPORT,
    BoxResults,
    choose,
    find_boxes,
    limit_text,
    peel,
)


def regions_1d(X: pd.DataFrame, y: np.ndarray, drivers: pd.DataFrame, res: BoxResults):
    """A 1-D PRIM region (that input alone, all runs) for each flagged driver, and, for one
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
        t = peel(x, y, min_support=min(MAX_MIN_SUPPORT, 0.5 * float(y.mean())))
        step = choose(t, int(y.sum()))
        lo, hi = t.lo[step, 0], t.hi[step, 0]
        # Limits printed so that applying them to the runs gives the counts stated.
        lo_t, hi_t = limit_text(lo, x[:, 0], upper=False), limit_text(hi, x[:, 0], upper=True)
        if np.isfinite(lo) and np.isfinite(hi):
            text = f"{lo_t} .. {hi_t}"
        elif np.isfinite(lo):
            text = f">= {lo_t}"
        elif np.isfinite(hi):
            text = f"<= {hi_t}"
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
    """Boxes of a :class:`~rcsim.analysis.results.drivers.pipeline.DriverResults` (its flagged
    drivers, pooled and per case, their ratios and the case), with the 1-D regions of its flagged
    single drivers; None when nothing is flagged (a box is then no finding of this analysis:
    :mod:`~rcsim.analysis.results.drivers.findings`)."""
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
    factors = [f for f in flagged_inputs(res) if X[f].nunique() > 1]
    if not factors:  # no flag: no box (a box describes where flagged drivers act)
        return None
    out = find_boxes(X, y, strata, factors)
    out.regions_1d = regions_1d(X, y, res.drivers, out)
    out.subsample_of = n if n > MAX_BOX_RUNS else None
    return out


def flagged_inputs(res) -> list[str]:
    """The inputs the boxes search: the flagged single drivers (best first), then the inputs
    flagged only per case (in the order of their best per-case p-value), each once."""
    out = list(res.drivers.loc[res.drivers["significant"].astype(bool), "factor"])
    per_case = []
    for c in res.cases:
        if c.singles is None or c.significant is None:
            continue
        names = np.asarray(c.singles.feature_names_in_)
        per_case += [(float(c.p_family[j]), str(names[j])) for j in np.flatnonzero(c.significant)]
    for _, f in sorted(per_case):
        if f not in out and f in res.runset.X.columns:
            out.append(f)
    return out
