"""The allocator in a campaign: its solver counts reach the manifest, and a run's outcome
does not depend on which runs share its chunk (the allocator keeps no state across commands
but a plan per distinct command, a function of the command alone)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import parse_dict


def _spec(chunk_size: int):
    return parse_dict(
        {
            "seed": 5,
            "runs_per_case": 2,
            "chunk_size": chunk_size,
            "vehicle": "canted16",
            "scenario": {"kind": "rate-cases", "cases": [3, 19], "duration_s": 6.0},
            "controller": {"name": "allocator"},
            "output": {"histories": "none", "plots": False},
        },
        source="a test",
    )


def test_solver_counts_in_the_manifest_and_runs_independent_of_chunking(tmp_path):
    frames = {}
    for size in (1, 4):
        out = tmp_path / f"c{size}"
        run_campaign(_spec(size), out, progress=False, local_workers=1)
        manifest = json.loads((out / "manifest.json").read_text())
        counts = manifest["solver_counts"]
        # canted16's 10 ms minimum binds on the corrections: searches happen, and every
        # search is either finished by the branch and bound or solved exactly (HiGHS).
        assert counts["searched"] > 0 and counts["nodes"] >= counts["searched"]
        assert 0 <= counts["exact"] <= counts["searched"]
        assert manifest["last_session"]["solver_counts"] == counts
        frames[size] = pd.read_parquet(out / "runs.parquet").sort_values("run_id")
    a, b = frames[1], frames[4]
    cols = [c for c in a.columns if a[c].dtype.kind == "f"]
    assert len(cols) > 5
    # Bit for bit: one run per chunk against four.
    for col in cols:
        np.testing.assert_array_equal(a[col].to_numpy(), b[col].to_numpy(), err_msg=col)
