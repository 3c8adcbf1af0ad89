"""Figures of the driver analysis: each returns a matplotlib Figure for the report.

Colours follow Gambone Fig. 15: failed runs red, successful runs blue.  Figures are made with
matplotlib's object API (:func:`rcsim.analysis.engine.plots.new_figure`, constrained layout), never
pyplot, so a user's backend is never touched.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from rcsim.analysis.engine.plots import new_figure

FAIL, OK = "#d62728", "#1f77b4"
AXES = ("roll", "pitch", "yaw")


def failures_per_case(cases) -> Figure:
    """Bar chart of failed runs per case (share of the case's runs), with each case's
    Clopper-Pearson 95 % interval as a whisker."""
    from rcsim.analysis.results.proportions import clopper_pearson

    names = [c.case for c in cases]
    pct = [100.0 * c.failed / max(c.runs, 1) for c in cases]
    lo, hi = clopper_pearson([c.failed for c in cases], [c.runs for c in cases])
    fig, ax = new_figure(figsize=(max(6.0, 0.32 * len(names) + 2), 3.2))
    ax.bar(range(len(names)), pct, color=[FAIL if p > 0 else "#bbbbbb" for p in pct])
    err = np.vstack([np.subtract(pct, 100.0 * lo), np.subtract(100.0 * hi, pct)])
    ax.errorbar(
        range(len(names)),
        pct,
        yerr=np.clip(err, 0, None),
        fmt="none",
        ecolor="#333333",
        elinewidth=0.8,
        capsize=2,
    )
    ax.set_xticks(range(len(names)), names, rotation=90, fontsize=8)
    ax.set_ylabel("failed runs [% of case]")
    ax.set_title("Failures per case (whiskers: exact 95 % interval)")
    ax.grid(axis="y", alpha=0.3)
    return fig


def ranking(drivers: pd.DataFrame, top: int = 20) -> Figure:
    """Horizontal bars of the top single-factor scores; flagged ones red."""
    d = drivers.head(top).iloc[::-1]
    fig, ax = new_figure(figsize=(8.0, 0.28 * len(d) + 1.2))
    colors = [FAIL if s else "#999999" for s in d["significant"]]
    ax.barh(range(len(d)), d["score"], color=colors)
    labels = [
        f"{f}  (p={p:.3g}" + (f", kept {s:.0%}" if "stability" in d and pd.notna(s) else "") + ")"
        for f, p, s in zip(
            d["factor"], d["p_value"], d["stability"] if "stability" in d else [np.nan] * len(d)
        )
    ]
    ax.set_yticks(range(len(d)), labels, fontsize=8)
    ax.set_xlabel("score: TV distance failed vs successful, minus its no-effect mean")
    ax.set_title("Single-factor drivers (red: flagged, within the report's false-flag budget)")
    ax.axvline(0, color="k", lw=0.8)
    ax.grid(axis="x", alpha=0.3)
    return fig


def failure_regions(singles, X: pd.DataFrame, factors) -> Figure:
    """P(fail | x) against x for each factor, base rate dashed, failure region shaded."""
    factors = list(factors)
    ncol = min(2, len(factors))
    nrow = int(np.ceil(len(factors) / ncol))
    fig, axes = new_figure(nrow, ncol, figsize=(5.2 * ncol, 3.0 * nrow), squeeze=False)
    names = list(singles.feature_names_in_)
    m = singles.n_bins
    u_mid = (np.arange(m) + 0.5) / m
    for ax, f in zip(axes.ravel(), factors):
        j = names.index(f)
        x_mid = np.quantile(X[f].to_numpy(), u_mid)
        cond = 100.0 * singles.conditional_[j]
        ax.plot(x_mid, cond, color=FAIL, lw=2, label="P(fail | value)")
        ax.axhline(100.0 * singles.base_rate_, color="k", ls="--", lw=1, label="base rate")
        mask = singles.region_mask_[j]
        if mask.any():
            ax.fill_between(
                x_mid,
                0,
                cond,
                where=mask,
                color=FAIL,
                alpha=0.15,
                step="mid",
                label="failure region",
            )
        ax.set_xlabel(f)
        ax.set_ylabel("failure probability [%]")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    for ax in axes.ravel()[len(factors) :]:
        ax.set_visible(False)
    return fig


def knn_map(fmap, X: pd.DataFrame, y: np.ndarray, title: str) -> Figure:
    """Gambone Fig. 15 style: kNN P(fail) shading with runs on top; and its uncertainty."""
    a, b = fmap.feature_names_in_
    fig, (ax1, ax2) = new_figure(1, 2, figsize=(11.5, 4.4))
    extent = [fmap.edges_a_[0], fmap.edges_a_[-1], fmap.edges_b_[0], fmap.edges_b_[-1]]
    im = ax1.imshow(
        100 * fmap.prob_.T,
        origin="lower",
        extent=extent,
        aspect="auto",
        cmap="Reds",
        vmin=0,
        vmax=100,
        alpha=0.85,
    )
    ok = ~y
    ax1.scatter(X[a][ok], X[b][ok], s=4, c=OK, alpha=0.5, label="successful run")
    ax1.scatter(X[a][y], X[b][y], s=10, c=FAIL, edgecolors="k", linewidths=0.3, label="failed run")
    ax1.set_xlabel(a)
    ax1.set_ylabel(b)
    ax1.set_title(f"{title}: P(fail), k = {fmap.k_} neighbours")
    ax1.legend(fontsize=7, loc="upper right")
    fig.colorbar(im, ax=ax1, label="failure probability [%] (blank: no runs)")
    im2 = ax2.imshow(
        100 * fmap.uncertainty_.T,
        origin="lower",
        extent=extent,
        aspect="auto",
        cmap="Greys",
        vmin=0,
    )
    ax2.set_xlabel(a)
    ax2.set_ylabel(b)
    ax2.set_title("uncertainty of the map")
    fig.colorbar(im2, ax=ax2, label="90 % interval half-width [% points]")
    return fig


def rate_error_histogram(
    runs: pd.DataFrame, y: np.ndarray, threshold_deg_s: float | None, title: str
) -> Figure:
    """Gambone Fig. 16 style: final rate error of every axis, binned, failed vs successful."""
    fig, axes = new_figure(1, 3, figsize=(12, 3.2), sharey=True)
    for ax, axis in zip(axes, AXES):
        col = f"final_rate_err_{axis}_deg_s"
        v = runs[col].to_numpy(float)
        bins = np.histogram_bin_edges(v[np.isfinite(v)], bins=30)
        ax.hist(
            [v[~y], v[y]], bins=bins, stacked=True, color=[OK, FAIL], label=["successful", "failed"]
        )
        if threshold_deg_s is not None:
            for s in (-1, 1):
                ax.axvline(s * threshold_deg_s, color="k", ls="--", lw=1)
        ax.set_xlabel(f"final {axis} rate error [deg/s]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("runs")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{title}: final rate errors (dashed: failure threshold)")
    return fig


def map_png_names(res) -> list[str]:
    """File names of the kNN maps of ``res`` (a DriverResults), in the order of ``res.maps``:
    ``map_{k}_{all|case}_{a}__{b}.png``."""
    names = []
    for k, (case, fmap) in enumerate(res.maps, start=1):
        a, b = fmap.feature_names_in_
        names.append(f"map_{k}_{'all' if case is None else case}_{a}__{b}.png")
    return names


def map_title(case) -> str:
    """A kNN map's title: the case it covers, or all cases."""
    return "all cases" if case is None else f"case {case}"


def report_pngs(res) -> dict[str, bytes]:
    """The figures shown both in the HTML report and in ``figures/``, as PNG bytes.

    Rendered on the first call and kept in ``res.pngs``, so that the report's sections and
    the PNG files use the same bytes and each figure is drawn once.

    Parameters
    ----------
    res : DriverResults

    Returns
    -------
    dict
        File name -> PNG bytes: ``failures_per_case.png`` (more than one case),
        ``ranking.png`` and one entry per kNN map (:func:`map_png_names`) when there are
        failures.
    """
    if res.pngs:
        return res.pngs
    # Imported here: the report package imports this module for its sections.
    from rcsim.analysis.results.report.html import png_bytes

    pngs = {}
    if len(res.cases) > 1:
        pngs["failures_per_case.png"] = png_bytes(failures_per_case(res.cases))
    if res.has_failures:
        pngs["ranking.png"] = png_bytes(ranking(res.drivers))
        rs = res.runset
        for name, (case, fmap) in zip(map_png_names(res), res.maps):
            rows = np.ones(rs.y.size, bool) if case is None else rs.strata == case
            pngs[name] = png_bytes(knn_map(fmap, rs.X[rows], rs.y[rows], map_title(case)))
    res.pngs.update(pngs)
    return res.pngs
