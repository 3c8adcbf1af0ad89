"""Fixtures of the lookup-layer tests."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

C_EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "c_fsw"


@pytest.fixture(scope="session")
def c_build():
    """``build(source, out) -> out``: a C flight-software source built as a user builds it
    (``sh examples/c_fsw/build.sh SOURCE OUT`` with this interpreter's rcsim); the test is
    skipped, saying why, on a machine without a C compiler."""
    if shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("no C compiler (cc) to build the C flight-software examples")

    def build(source: Path, out: Path) -> Path:
        subprocess.run(
            ["sh", str(C_EXAMPLES / "build.sh"), str(source), str(out)],
            check=True, capture_output=True, env={**os.environ, "PYTHON": sys.executable},
        )  # fmt: skip
        return out

    return build
