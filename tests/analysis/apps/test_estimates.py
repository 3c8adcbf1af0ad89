"""Estimates before work for the commands that grow (issue 31, "What to build" 5).

Oracle: the cost models in :mod:`rcsim.analysis.apps.estimates`, recomputed here by hand from
their stated constants, and the house rule they enforce: memory over half of the machine's is
refused whatever ``--yes`` says; time over 30 minutes is refused without ``--yes``; both before
any work.  The constants themselves are measurements (their docstrings say which); what is
tested is that the command uses them as stated and refuses in one line.
"""

from __future__ import annotations

import pytest

import rcsim.analysis.apps.estimates as estimates
import rcsim.spacecraft.guards as guards
from rcsim.analysis.apps.cli import main
from rcsim.models.errors import InputError

GIB = 1 << 30


def test_database_memory_is_refused_whatever_yes_says(monkeypatch):
    # The paper's 16 jets x 6 on-times x 1,000 vehicles = 96,000 flights, each 16 x 500 bytes:
    # 768,000,000 bytes, over a budget of 0.5 GiB (536,870,912 bytes).
    monkeypatch.setattr(guards, "memory_budget_bytes", lambda: GIB // 2)
    with pytest.raises(InputError) as err:
        estimates.check_database_cost("paper", 1000, yes=True)
    assert err.value.parameter == "n_vehicles"
    assert "96,000 flights" in str(err.value) and "732 MiB" in str(err.value)  # 768e6 B
    estimates.check_database_cost("paper", 600, yes=False)  # 460.8e6 B: under the budget


def test_database_time_needs_yes(monkeypatch, capsys):
    # 16 x 6 x 200,000 = 19,200,000 flights: 6 s + 19.2e6 x 150 us = 2,886 s = 48 min.
    monkeypatch.setattr(guards, "memory_budget_bytes", lambda: 1 << 50)
    with pytest.raises(InputError, match=r"about 48 min .* pass --yes"):
        estimates.check_database_cost("paper", 200_000, yes=False)
    estimates.check_database_cost("paper", 200_000, yes=True)  # announced, then allowed
    assert "about 48 min" in capsys.readouterr().err


def test_lookup_database_cli_refuses_before_flying(tmp_path, capsys, monkeypatch):
    import rcsim.analysis.engine.response_files as response_files

    monkeypatch.setattr(response_files, "response_database", lambda *a, **k: pytest.fail("flew"))
    argv = ["lookup", "database", "--vehicle", "paper", "--out", str(tmp_path / "db.parquet")]
    assert main([*argv, "--vehicles", "1000000000", "--yes"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--vehicles 1000000000" in err and "memory" in err
    assert list(tmp_path.iterdir()) == []


def test_refine_memory_is_refused_before_flying(tmp_path, capsys, monkeypatch):
    # 4,096 bytes per run of a case: 26 cases x 100,000 runs = 10,649,600,000 bytes.
    monkeypatch.setattr(guards, "memory_budget_bytes", lambda: 8 * GIB)
    import rcsim.analysis.apps.refinement.outputs as outputs

    monkeypatch.setattr(outputs, "run_refinement", lambda *a, **k: pytest.fail("flew"))
    out = str(tmp_path / "R.csv")
    argv = ["lookup", "refine", "--table", "table6", "--runs", "100000", "--yes", "--out", out]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--runs 100000" in err and "9.92 GiB" in err
