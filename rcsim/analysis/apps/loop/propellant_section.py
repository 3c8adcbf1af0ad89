"""The loop report's "Propellant and translation" section.

The refinement's held-out seed is flown with the table before (``campaign_check``) and after
(``campaign_after``) refinement: the same dispersed runs, so per case the two means differ by
the table alone.  Per case: mean propellant per run with a Student-t 95 % interval over the
case's runs (:func:`rcsim.analysis.apps.refinement.propellant.mean_interval`), before and
after, as a plot and a table; and, when the runs table records them, the net delta-v (inertial
``delta_v_N_m_s`` and body ``delta_v_B_m_s``, [m/s]) and the pulse counts (``pulses``,
``min_pulses``) the same way.  A column the campaign's code version did not record is said to
be so, never shown as zero.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pandas as pd

from rcsim.analysis.apps.refinement.propellant import mean_interval, rule_text
from rcsim.analysis.results.report.html import Section, figure_block, table_block, text_block

#: Optional per-run outcomes shown when both campaigns recorded them: column -> (label, unit
#: shown, its factor from the stored SI value; attitude-control delta-v reads in mm/s).
OPTIONAL = {
    "delta_v_N_m_s": ("net delta-v, inertial", "mm/s", 1e3),
    "delta_v_B_m_s": ("net delta-v, body", "mm/s", 1e3),
    "pulses": ("pulses", "per run", 1.0),
    "min_pulses": ("minimum pulses", "per run", 1.0),
}

#: The propellant column of the runs table [kg per run].
PROPELLANT = "propellant_kg"

NOT_RECORDED = "not recorded by this code version"


def case_means(before: pd.DataFrame, after: pd.DataFrame, column: str) -> pd.DataFrame:
    """Per case (``case_index`` 0-based), the mean of ``column`` over the runs before and
    after with t 95 % intervals: ``case, runs, before, before_lo, before_hi, after, after_lo,
    after_hi, change_pct``."""
    rows = []
    for c in sorted(set(before["case_index"]) | set(after["case_index"])):
        b = mean_interval(before.loc[before["case_index"] == c, column])
        a = mean_interval(after.loc[after["case_index"] == c, column])
        rows.append(
            {
                "case": int(c) + 1,
                "runs": int((before["case_index"] == c).sum()),
                "before": b[0],
                "before_lo": b[1],
                "before_hi": b[2],
                "after": a[0],
                "after_lo": a[1],
                "after_hi": a[2],
                "change_pct": 100.0 * (a[0] / b[0] - 1.0) if b[0] > 0 else np.nan,
            }
        )
    return pd.DataFrame(rows)


def recorded(before: pd.DataFrame, after: pd.DataFrame) -> dict[str, bool]:
    """Per optional column, whether both runs tables have it."""
    return {col: col in before and col in after for col in OPTIONAL}


def _plot(means: pd.DataFrame, changed: set[int], ylabel: str, title: str) -> bytes:
    from rcsim.analysis.engine.plots import new_figure

    fig, ax = new_figure(1, 1, figsize=(12, 4.0))
    x = means["case"].to_numpy()
    for shift, what, color in ((-0.18, "before", "tab:red"), (0.18, "after", "tab:blue")):
        y = means[what].to_numpy(float)
        err = np.vstack([y - means[f"{what}_lo"], means[f"{what}_hi"] - y])
        ax.errorbar(
            x + shift, y, yerr=np.nan_to_num(err), fmt="o", ms=4, capsize=2, color=color,
            label=f"{what} refinement",
        )  # fmt: skip
    ax.set_xticks(x, [f"{c}*" if c in changed else str(c) for c in x], fontsize=8)
    ax.set_xlabel("rate case (* row changed by the refinement)")
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


def _table(means: pd.DataFrame, scale: float, unit: str) -> pd.DataFrame:
    """``means`` for a reader: values in ``unit`` (``scale`` times the stored), interval as
    ``lo-hi`` text."""
    out = pd.DataFrame({"case": means["case"], "runs": means["runs"]})
    for what in ("before", "after"):
        out[f"{what} [{unit}]"] = means[what] * scale
        out[f"{what} 95 % CI [{unit}]"] = [
            f"{lo * scale:.4g}-{hi * scale:.4g}" if np.isfinite(lo) else "n/a"
            for lo, hi in zip(means[f"{what}_lo"], means[f"{what}_hi"])
        ]
    out["change [%]"] = means["change_pct"].round(1)
    return out


def propellant_blocks(
    before: pd.DataFrame,
    after: pd.DataFrame,
    changed: set[int],
    seed: int,
    max_rise_pct: float,
    verdicts: dict[int, str] | None = None,
    failures: dict[int, tuple[int, int]] | None = None,
) -> list[str]:
    """The section's blocks from the two runs tables of the held-out seed (``case_index`` and
    the outcome columns), the changed cases (1-based) and the rule's limit [%]; ``verdicts``
    and ``failures`` (per case: failed runs before, after), the changelog's, for the changed
    rows' table."""
    means = case_means(before, after, PROPELLANT)
    total_b, total_a = float(before[PROPELLANT].sum()), float(after[PROPELLANT].sum())
    blocks = [
        text_block(
            f"Held-out seed {seed}, the same dispersed runs flown with the table before and "
            f"after refinement: propellant over all {len(before):,} runs "
            f"{total_b:.4g} kg before, {total_a:.4g} kg after "
            f"({100 * (total_a / total_b - 1):+.1f} %)."
            if total_b > 0
            else f"Held-out seed {seed}: no propellant used before refinement."
        ),
        text_block(
            f"The refinement's propellant rule (--max-propellant-rise-pct {max_rise_pct:g}): "
            + rule_text(max_rise_pct / 100.0)
        ),
        figure_block(
            _plot(
                means.assign(
                    **{k: means[k] * 1e3 for k in means if k.startswith(("before", "after"))}
                ),
                changed,
                "mean propellant per run [g]",
                f"Propellant per run by case, held-out seed {seed} (bars: t 95 % interval)",
            ),
            "Mean propellant per run of each rate case before (red) and after (blue) "
            "refinement on the held-out seed, with Student-t 95 % intervals; * marks the rows "
            "the refinement changed.",
        ),
    ]
    # A correction firing picks its row by the signs of the rate error, so a changed row can
    # fly in another case's runs: say which unchanged rows' propellant rose beyond the limit.
    spill = means[~means["case"].isin(changed) & (means["change_pct"] > max_rise_pct)]
    if changed and not spill.empty:
        listed = ", ".join(
            f"{int(c)} ({p:+.1f} %)" for c, p in zip(spill["case"], spill["change_pct"])
        )
        blocks.append(
            text_block(
                f"Rows the refinement did not change whose mean propellant rose more than "
                f"{max_rise_pct:g} % on the held-out seed: case {listed}. A correction firing "
                f"picks its row by the signs of the rate error, so a changed row also flies "
                f"in other cases' runs; the refinement's rule weighs only the changed case."
            )
        )
    table = _table(means, 1e3, "g")
    shown = table[table["case"].isin(changed)].copy() if changed else table.iloc[0:0]
    if failures:
        shown["failed before"] = [failures[int(c)][0] for c in shown["case"]]
        shown["failed after"] = [failures[int(c)][1] for c in shown["case"]]
    if verdicts:
        shown["held-out verdict"] = [verdicts.get(int(c), "") for c in shown["case"]]
    blocks.append(
        table_block(
            shown,
            "Changed rows on the held-out seed: mean propellant per run before and after "
            "(Student-t 95 % interval), failed runs before and after, and the verdict (worse: "
            "more failures, or propellant beyond the limit without a failure gain that pays)",
            max_rows=30,
            float_format="{:.4g}",
        )
        if not shown.empty
        else text_block("No row changed: the propellant of every case is the table's own.")
    )
    blocks.append(
        table_block(
            table,
            "Every case: mean propellant per run before and after on the held-out seed",
            max_rows=30,
            float_format="{:.4g}",
        )
    )
    have = recorded(before, after)
    for col, (label, unit, scale) in OPTIONAL.items():
        if not have[col]:
            blocks.append(text_block(f"{label.capitalize()} ({col}): {NOT_RECORDED}."))
            continue
        m = case_means(before, after, col)
        blocks.append(
            table_block(
                _table(m, scale, unit),
                f"{label.capitalize()} ({col}) per run before and after on the held-out seed "
                "(Student-t 95 % interval)",
                max_rows=30,
                float_format="{:.4g}",
            )
        )
    return blocks


def _read_runs(campaign: Path) -> pd.DataFrame:
    """The columns of a campaign's runs table the section reads (those it has)."""
    import pyarrow.parquet as pq

    from rcsim.analysis.engine import runs_table

    path = campaign / runs_table.RUNS
    names = set(pq.read_schema(path).names)
    want = ["case_index", PROPELLANT, *OPTIONAL]
    return pd.read_parquet(path, columns=[c for c in want if c in names])


def propellant_section(out: Path, log: pd.DataFrame, settings, seed: int) -> Section:
    """The section, from the loop directory ``out`` (the held-out seed's two campaigns) and
    the refinement's changelog ``log``."""
    before = _read_runs(out / "campaign_check")
    after = _read_runs(out / "campaign_after")
    changed = {int(c) for c in log.loc[log["changed"], "case"]}
    verdicts = (
        {int(c): str(v) for c, v in zip(log["case"], log["held_out"].astype(object).fillna(""))}
        if "held_out" in log
        else None
    )
    blocks = propellant_blocks(
        before,
        after,
        changed,
        seed,
        float(getattr(settings, "max_propellant_rise_pct", 10.0)),
        verdicts,
        {
            int(c): (int(b), int(a))
            for c, b, a in zip(log["case"], log["failed_fresh_before"], log["failed_fresh_after"])
        },
    )
    return Section("Propellant and translation", blocks, "propellant")
