"""Importing rcsim, or plotting with it, never touches pyplot or the user's matplotlib backend.

Oracle: the issue "importing a plotting module calls matplotlib.use('Agg'), which switches the
backend of the user's notebook".  rcsim draws with matplotlib's object API
(:func:`rcsim.analysis.engine.plots.new_figure`), so ``matplotlib.pyplot`` is never imported and a
backend chosen by the user before importing rcsim is still the backend after plotting.
"""

import subprocess
import sys
import textwrap


def test_import_and_plot_leave_the_backend_alone(tmp_path):
    code = textwrap.dedent(f"""
        import importlib, pkgutil, sys
        import matplotlib
        matplotlib.use("svg")  # a user's choice, set before rcsim is imported
        import rcsim
        from rcsim import models, spacecraft, lookup, analysis
        for pkg in (models, spacecraft, lookup, analysis):
            for info in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + "."):
                if not info.name.endswith("__main__"):
                    importlib.import_module(info.name)
        import numpy as np, pandas as pd
        from rcsim.analysis.engine.plots import plot_attitude_error
        frame = pd.DataFrame({{"t_s": np.arange(3.0), **{{f"att_err_{{a}}_deg": np.zeros(3)
                              for a in ("roll", "pitch", "yaw")}}}})
        plot_attitude_error(frame, r"{tmp_path / "a.png"}", title="probe")
        print(matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["svg", "False"]
    assert (tmp_path / "a.png").stat().st_size > 1000  # a real PNG was written
