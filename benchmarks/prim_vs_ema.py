"""rcsim's PRIM (rcsim/analysis/results/drivers/boxes.py) against EMA Workbench's ``prim.Prim``.

Usage (EMA Workbench is not an rcsim dependency: run this from an environment that has it and
numpy, pandas and scipy, with the repository root on ``PYTHONPATH``)::

    python -m venv ema-env && ema-env/bin/pip install ema_workbench
    PYTHONPATH=. ema-env/bin/python benchmarks/prim_vs_ema.py

On each data set both peel with ``peel_alpha = 0.05``, ``mass_min = 0.05`` and the ``lenient1``
objective (EMA's default).  EMA is run twice: peeling only (its pasting phase switched off, which
rcsim does not have) -- the trajectories must agree step for step: same number of steps, same
coverage and density at every step, same limits of the last box -- and as ``find_box`` runs it
(peeling then pasting), to show what pasting changes.  Prints one Markdown row per data set for
docs/drivers.md and exits non-zero on a mismatch.

``--rcsim-only`` runs rcsim's side alone (no EMA Workbench needed): the same data sets peeled
by rcsim, one row each with its steps and last box (the smoke test in ``tests/benchmarks/``
runs it in rcsim's own environment; the comparison runs there when ``ema_workbench`` imports).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers.boxes import peel


def planted_box(seed: int, n: int = 5000):
    """Five U(0, 1) inputs and four cases; fails with probability 0.6 in
    ``x1 > 0.7 & x2 < 0.4`` within cases A and B, 0.02 elsewhere."""
    rng = np.random.default_rng(seed)
    X = pd.DataFrame(rng.random((n, 5)), columns=[f"x{k + 1}" for k in range(5)])
    case = rng.choice(list("ABCD"), n)
    inside = (X["x1"] > 0.7) & (X["x2"] < 0.4) & np.isin(case, ["A", "B"])
    y = rng.random(n) < np.where(inside, 0.6, 0.02)
    return X, case, y


def ratio_band(seed: int, n: int = 5000):
    """Thrust and inertia with physical units, three noise inputs; fails when thrust/inertia
    is low (the planted one-sided campaign's mechanism)."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((n, 5))
    X = pd.DataFrame(z, columns=["thrust", "inertia", "n1", "n2", "n3"])
    X["thrust"] = 22.0 + 2.0 / 3.0 * X["thrust"]
    X["inertia"] = 1400.0 + 322.0 / 3.0 * X["inertia"]
    X["thrust/inertia"] = X["thrust"] / X["inertia"]
    y = (z[:, 0] - z[:, 1]) / np.sqrt(2) + 0.3 * rng.standard_normal(n) < -1.5
    return X, None, y


def ema_run(X, case, y, paste: bool):
    from ema_workbench.analysis import prim

    x = X.copy()
    if case is not None:
        x["case"] = pd.Categorical(case)
    cls = prim.Prim
    saved = cls._paste
    if not paste:
        cls._paste = lambda self, box: box
    try:
        p = cls(x, y.astype(int), threshold=0.0, peel_alpha=0.05, mass_min=0.05)
        t0 = time.perf_counter()
        box = p.find_box()
        dt = time.perf_counter() - t0
    finally:
        cls._paste = saved
    return box, dt


def compare(name, X, case, y) -> tuple[bool, str]:
    codes, k = None, 0
    cats = []
    if case is not None:
        cats = sorted(set(case))
        codes, k = np.searchsorted(cats, case), len(cats)
    t0 = time.perf_counter()
    ours = peel(X.to_numpy(float), y, codes, k)
    dt_ours = time.perf_counter() - t0
    ema, dt_ema = ema_run(X, case, y, paste=False)
    ema_pasted, _ = ema_run(X, case, y, paste=True)
    tr = ema.peeling_trajectory
    ok = len(tr) == ours.runs.size
    dcov = dden = np.inf
    if ok:
        # EMA's own coverage / density columns count y >= threshold; use its mean and n.
        dcov = float(np.abs(tr["mean"] * tr["n"] / y.sum() - ours.coverage).max())
        dden = float(np.abs(tr["mean"].to_numpy() - ours.density).max())
        ok = dcov < 1e-12 and dden < 1e-12
    # Limits of the last box: EMA keeps the data's min / max where rcsim keeps -inf / inf.
    lims = ema.box_lims[-1]
    dlim = 0.0
    for j, col in enumerate(X.columns):
        init = ema.prim.box_init[col]
        for side, mine in ((0, ours.lo[-1, j]), (1, ours.hi[-1, j])):
            theirs = float(lims.loc[side, col])
            if np.isfinite(mine):
                dlim = max(dlim, abs(theirs - mine))
            elif theirs != float(init.iloc[side]):
                dlim = np.inf
    if case is not None:
        theirs_cats = set(lims.loc[0, "case"])
        mine_cats = {c for c, keep in zip(cats, ours.cats[-1]) if keep}
        ok = ok and theirs_cats == mine_cats
    ok = ok and dlim < 1e-12
    last = len(ours.runs) - 1
    pt = ema_pasted.peeling_trajectory.iloc[-1]
    row = (
        f"| {name} | {len(y):,} | {int(y.sum())} | {len(tr)} / {ours.runs.size} | "
        f"{dcov:.1e} | {dden:.1e} | {dlim:.1e} | "
        f"{ours.coverage[last]:.3f} / {ours.density[last]:.3f} | "
        f"{len(ema_pasted.peeling_trajectory) - len(tr)} steps: "
        f"{pt['mean'] * pt['n'] / y.sum():.3f} / {pt['mean']:.3f} | "
        f"{1e3 * dt_ours:.0f} / {1e3 * dt_ema:.0f} |"
    )
    return ok, row


def _datasets():
    for seed in range(3):
        for name, make in (("planted box + 2 of 4 cases", planted_box), ("ratio band", ratio_band)):
            yield f"{name}, seed {seed}", make(seed)


def rcsim_only() -> int:
    """rcsim's peeling alone on the data sets: steps, last box coverage and density, time."""
    print("| data set | runs | failed | steps rcsim | last box coverage / density | time [ms] |")
    print("|---|---|---|---|---|---|")
    for name, (X, case, y) in _datasets():
        codes, k = None, 0
        if case is not None:
            cats = sorted(set(case))
            codes, k = np.searchsorted(cats, case), len(cats)
        t0 = time.perf_counter()
        ours = peel(X.to_numpy(float), y, codes, k)
        dt = time.perf_counter() - t0
        last = ours.runs.size - 1
        print(
            f"| {name} | {len(y):,} | {int(y.sum())} | {ours.runs.size} | "
            f"{ours.coverage[last]:.3f} / {ours.density[last]:.3f} | {1e3 * dt:.0f} |"
        )
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rcsim-only", action="store_true", help="rcsim's side alone (no EMA)")
    if ap.parse_args(argv).rcsim_only:
        return rcsim_only()
    print(
        "| data set | runs | failed | steps EMA / rcsim | max coverage diff | "
        "max density diff | max limit diff (last box) | last box coverage / density | "
        "EMA pasting adds | time rcsim / EMA [ms] |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    bad = 0
    for name, (X, case, y) in _datasets():
        ok, row = compare(name, X, case, y)
        print(row + ("" if ok else " **MISMATCH**"))
        bad += not ok
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
