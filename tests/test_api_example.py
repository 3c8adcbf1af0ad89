"""docs/api.md is true: every ``python`` block of it runs, in order, in a fresh directory.

Oracle: the page itself -- its own assertions (e.g. the maneuver ends inside the lookup
controller's attitude band) and the absence of any exception.  The blocks share one namespace,
as cells of a notebook do.
"""

import os
import re
from pathlib import Path

import matplotlib

DOC = Path(__file__).resolve().parents[1] / "docs" / "api.md"


def test_every_python_block_of_the_api_page_runs(tmp_path, capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)
    assert len(blocks) >= 4, "docs/api.md should show flying, a campaign, drivers, refinement"
    matplotlib.use("Agg")  # a notebook would draw inline; a test writes files only
    namespace: dict = {}
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        for k, block in enumerate(blocks, start=1):
            exec(compile(block, f"{DOC.name} block {k}", "exec"), namespace)  # noqa: S102
    finally:
        os.chdir(cwd)
    printed = capsys.readouterr().out
    assert "runs," in printed and (tmp_path / "drivers" / "report.html").is_file()


def test_the_pages_driver_block_survives_a_campaign_without_failures(tmp_path):
    """Issue 27 item 5: the documented drivers block on runs of which none failed: the result
    says so (no ``singles``, ``has_failures`` false), the page's ``else`` branch is taken and
    the report is still written.  Oracle: a runs table whose outcome column is all False."""
    import numpy as np

    import rcsim
    from rcsim.analysis.results.drivers.synthetic import planted_campaign

    X, _ = planted_campaign("one-sided", seed=3, n_runs=300, n_noise=4)
    runs = X.assign(failed=np.zeros(len(X), bool))
    result = rcsim.analyze(runs, rcsim.DriverSettings(n_permutations=19))
    assert not result.has_failures and result.singles is None
    assert any("no physics-aware factors" in note for note in result.runset.notes)
    rcsim.write_analysis(result, tmp_path / "drivers")
    assert (tmp_path / "drivers" / "report.html").is_file()
