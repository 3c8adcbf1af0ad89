"""The report section, figure and files of the PRIM boxes
(:mod:`rcsim.analysis.results.drivers.boxes`).

Files written into the analysis directory: ``boxes.csv`` (one row per box), ``box_limits.csv``
(one row per restriction, with its quasi-p-value), ``trajectory.csv`` (every peeling step),
``driver_regions.csv`` (a 1-D region or the reason there is none, per flagged driver) and
``figures/prim_trajectory.png`` (the same bytes as the report's figure).
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from rcsim.analysis.engine.plots import new_figure
from rcsim.analysis.results.drivers.boxes import CASE_RULE, CHOICE_RULE, MIN_LIFT, BoxResults
from rcsim.analysis.results.drivers.probabilities import pct, rate_text, share_text
from rcsim.analysis.results.report.html import (
    Section,
    figure_block,
    png_bytes,
    table_block,
    text_block,
)

FIGURE = "prim_trajectory.png"
_COLORS = ("#d62728", "#9467bd", "#ff7f0e")


def trajectory_figure(b: BoxResults) -> Figure:
    """Density against coverage along each peeling trajectory, the chosen boxes starred."""
    fig, ax = new_figure(figsize=(8.0, 4.6))
    for k, (t, step) in enumerate(zip(b.trajectories, b.chosen)):
        reported = k < len(b.boxes)
        color = _COLORS[k % len(_COLORS)] if reported else "#999999"
        label = f"search {k + 1}" + (" (box reported)" if reported else " (no box: too weak)")
        ax.plot(100 * t.coverage, 100 * t.density, "-o", ms=3, color=color, label=label)
        if reported:
            box = b.boxes[k]
            # The step chosen on the trajectory (ring) and the box reported (star): the same
            # box less the limits that did not matter, its cases set by the case rule.
            ax.plot(
                100 * t.coverage[step],
                100 * t.density[step],
                "o",
                ms=11,
                mfc="none",
                color=color,
                zorder=5,
            )
            ax.plot(
                100 * box.coverage,
                100 * box.density,
                "*",
                ms=16,
                color=color,
                markeredgecolor="k",
                zorder=6,
            )
            ax.annotate(
                f"box {box.number}: {pct(box.coverage)} % of failures,\n"
                f"P(fail) {pct(box.density)} % ({pct(box.p_lo)}-{pct(box.p_hi)} %)",
                (100 * box.coverage, 100 * box.density),
                xytext=(10, 10),
                textcoords="offset points",
                fontsize=8,
                bbox={"boxstyle": "round", "fc": "white", "ec": color, "alpha": 0.9},
                zorder=7,
            )
    ax.axhline(100 * b.base_rate, color="k", ls="--", lw=1, label="overall failure rate")
    ax.axvline(50, color="#777777", ls=":", lw=1, label="half of all failures (box 1's rule)")
    ax.set_xlabel("coverage: failed runs inside the box [% of all failed runs]")
    ax.set_ylabel("density: failure probability inside the box [%]")
    ax.set_title(
        "PRIM peeling trajectories: each point is a box\n"
        "(ring: box chosen on the trajectory; star: the box reported -- limits that do not "
        "matter dropped, cases by the case rule)",
        fontsize=10,
    )
    ax.set_xlim(0, 102)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    return fig


def trajectory_png(b: BoxResults) -> bytes:
    """The figure's PNG, drawn once and kept on ``b`` (report and figures/ share the bytes)."""
    png = getattr(b, "_png", None)
    if png is None:
        png = png_bytes(trajectory_figure(b))
        b._png = png  # type: ignore[attr-defined]
    return png


def box_sentence(b: BoxResults, box) -> str:
    """One box in words, every number from the box's counts (``box.runs``, ``box.failed``
    among the runs searched, ``b.total_runs``, ``b.total_failed``): what a test counts again
    by applying the box's limits to the runs."""
    where = b.limits_text(box) or "no input limit"
    cases = b.cases_text(box)
    if cases != "all":
        where += f"; case in {{{cases}}}"
    earlier = " and ".join(str(k) for k in range(1, box.number))
    after = f", among the runs outside box{'es' if box.number > 2 else ''} {earlier}"
    return (
        f"Box {box.number} ({where}) holds {share_text(box.failed, b.total_failed)} of all "
        f"failed runs in {box.runs:,} runs ({pct(box.runs / b.total_runs)} % of all runs"
        f"{after if box.number > 1 else ''}): a run in it fails at "
        f"{rate_text(box.failed, box.runs)}, {box.density / b.base_rate:.3g}x the overall "
        f"{rate_text(b.total_failed, b.total_runs)}."
    )


def _conclusion(b: BoxResults) -> str:
    if not b.boxes:
        return (
            f"No box reaches {MIN_LIFT:g}x the overall failure rate with at least half of the "
            "failures: the failures are not concentrated in a box of these inputs."
        )
    return " ".join(box_sentence(b, box) for box in b.boxes)


def section(res) -> Section:
    """The "Scenario boxes" section."""
    b = res.boxes
    if b is None or not b.trajectories:
        return Section(
            "Scenario boxes",
            [
                text_block(
                    "No input is flagged, so no box is searched: a box describes where flagged "
                    "drivers make runs fail, and is no finding of its own."
                )
            ],
            "boxes",
        )
    dims = len(b.names)
    n_ratio = len(b.ratio_parts)
    blocks = [
        text_block(
            "PRIM (Friedman and Fisher 1999) searches for boxes -- limits on a few inputs at "
            "once, and a set of cases -- where runs fail much more often than overall. It "
            f"searched {dims - n_ratio} flagged inputs (pooled or per case), {n_ratio} ratios of "
            "pairs of them (so that a driver acting through a ratio gets a band)"
            + (" and the case" if b.case_names else "")
            + ", peeling 5 % of the box's runs at a time down to the smallest box that could "
            "hold half of all failures (at most 5 % of all runs). A box describes where the "
            "flagged drivers act; it is not a test of its own. "
            "Coverage is the share of all failed runs inside a box, density the failure "
            "probability inside, support the share of runs inside. The box reported is "
            f"{CHOICE_RULE}; limits that do not raise its failure probability significantly "
            "(quasi-p > 0.05) are dropped. Boxes 2 and 3 are searched among the runs outside "
            f"the earlier boxes, and reported while at least {MIN_LIFT:g}x the overall rate. "
            f"Cases: {CASE_RULE}; a case left out keeps its runs for the next box."
            + (
                f" Searched on a seeded uniform random subsample of {b.total_runs:,} of the "
                f"{b.subsample_of:,} runs; the counts are the subsample's."
                if b.subsample_of
                else ""
            )
        ),
        figure_block(
            trajectory_png(b),
            _conclusion(b) + " Every point of a curve is a box you can choose instead: more "
            "failures explained (right) for a lower failure probability (down); trajectory.csv "
            "gives each one's limits and cases.",
            alt="PRIM peeling trajectory: density against coverage",
        ),
    ]
    if b.boxes:
        t = b.table()
        blocks.append(table_block(t.drop(columns=["trajectory_step"]), "Boxes (boxes.csv)"))
        blocks.append(
            table_block(
                b.limits_table(),
                "Limits of each box, with the quasi-p-value of keeping the limit (box_limits.csv)",
            )
        )
    r = b.regions_1d
    if r is not None and len(r):
        missing = r[~r["region_note"].str.startswith("1-D failure region")]
        if len(missing):
            blocks.append(
                text_block(
                    f"{len(missing)} flagged inputs have no 1-D failure region (their "
                    f"P(fail | x) never reaches {MIN_LIFT:g}x the base rate). Each gets its best "
                    "1-D range (PRIM on that input alone, same rule) and the reason: it acts "
                    "jointly (it is a limit of a box) or weakly over all runs."
                )
            )
            blocks.append(
                table_block(
                    missing[
                        [
                            "rank",
                            "factor",
                            "region_1d",
                            "region_1d_density",
                            "region_1d_coverage",
                            "region_note",
                        ]
                    ],
                    "Flagged inputs without a 1-D region (driver_regions.csv)",
                    max_rows=40,
                )
            )
    return Section("Scenario boxes", blocks, "boxes")


def write_files(res, folder) -> None:
    """Write the box files into the analysis directory ``folder`` (see the module doc)."""
    b = res.boxes
    if b is None:
        return
    folder = Path(folder)
    b.table().to_csv(folder / "boxes.csv", index=False)
    b.limits_table().to_csv(folder / "box_limits.csv", index=False)
    b.trajectory_table().to_csv(folder / "trajectory.csv", index=False)
    if b.regions_1d is not None:
        b.regions_1d.to_csv(folder / "driver_regions.csv", index=False)
    if b.trajectories:
        (folder / "figures").mkdir(exist_ok=True)
        (folder / "figures" / FIGURE).write_bytes(trajectory_png(b))
