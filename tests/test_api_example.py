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
