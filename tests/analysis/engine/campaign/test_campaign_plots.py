"""Campaign plot titles stay on the figure (issue 18 review: a long table file name ran off
both edges of ``plots/case-*.png``, a centred title cut at both ends).

Oracle: geometry -- the drawn title's bounding box (matplotlib's own text layout, at the
saved resolution) lies inside the figure's, and every character of it is drawn.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.engine.campaign.plots import plot_case, plot_summary

AXES = ("roll", "pitch", "yaw")
LONG = "lookup (mybus10_channel_table_refined_after_loop_two_with_jet_1_off_and_trimmed_v2.csv)"


def _inside(fig) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)  # the figures are detached from pyplot: draw them here
    canvas.draw()
    renderer = canvas.get_renderer()
    box, title = fig.bbox, fig._suptitle
    extent = title.get_window_extent(renderer)
    assert box.x0 <= extent.x0 and extent.x1 <= box.x1, (extent, box)
    assert extent.y1 <= box.y1
    # Every character is drawn (a name longer than a line is broken inside, not dropped).
    assert "".join(LONG.split()) in "".join(title.get_text().split())


def test_a_long_table_name_wraps_inside_the_case_plot(tmp_path):
    t = np.arange(0.0, 2.0, 0.04)
    env = {"t_s": t, "n_runs": np.full(t.size, 3)}
    for axis in AXES:
        for kind in ("rate_{}_deg_s", "att_err_{}_deg"):
            for stat in ("min", "max", "mean"):
                env[f"{kind.format(axis)}_{stat}"] = np.zeros(t.size)
        env[f"firing_{axis}_runs"] = np.zeros(t.size)
    fig = plot_case(pd.DataFrame(env), "rate-01", tmp_path / "c.png", title=f"{LONG}: rate-01")
    _inside(fig)


def test_a_long_table_name_wraps_inside_the_summary_plot(tmp_path):
    runs = pd.DataFrame({f"final_rate_err_{a}_deg_s": [0.01, 0.02] for a in AXES})
    cases = pd.DataFrame(
        {"case": ["rate-01"], "failed_pct": [0.0], "firings_per_run_mean": [2.0],
         "firings_per_run_max": [3.0]}
    )  # fmt: skip
    fig = plot_summary(runs, cases, tmp_path / "s.png", title=f"{LONG}: rate-01: 2 runs")
    _inside(fig)


def test_propellant_delta_v_plot_shows_means_intervals_and_the_budget(tmp_path):
    """The plotted case means are cases.csv's in g and mm/s (x 1e3, exact), the budget line
    sits at the spec's budget in the same unit, and a panel without a budget draws none."""
    from rcsim.analysis.engine.campaign.budget_plots import plot_propellant_delta_v

    runs = pd.DataFrame(
        {
            "case_index": [0, 0, 1],
            "propellant_kg": [0.006, 0.007, 0.01],
            "delta_v_N_m_s": [1e-4, 2e-4, 3e-4],
        }
    )
    cases = pd.DataFrame({"case_index": [0, 1], "case": ["rate-01", "rate-02"]})
    for col, m in (("propellant_kg", [0.0065, 0.01]), ("delta_v_N_m_s", [1.5e-4, 3e-4])):
        cases[f"{col}_mean"], cases[f"{col}_lo95"], cases[f"{col}_hi95"] = m, m, m
    fig = plot_propellant_delta_v(
        runs, cases, tmp_path / "p.png", budgets={"max_delta_v_m_s": 2.5e-4}
    )
    prop_ax, dv_ax = fig.axes
    means = [line for line in dv_ax.get_lines() if line.get_marker() == "o"][0]
    assert means.get_ydata().tolist() == [1.5e-4 * 1e3, 3e-4 * 1e3]
    budget = [line for line in dv_ax.get_lines() if line.get_linestyle() == "--"]
    assert [line.get_ydata()[0] for line in budget] == [2.5e-4 * 1e3]
    assert not [line for line in prop_ax.get_lines() if line.get_linestyle() == "--"]
    assert (tmp_path / "p.png").stat().st_size > 0
