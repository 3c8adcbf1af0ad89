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
