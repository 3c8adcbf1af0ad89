"""A plug-in that declares its lookup table refines it with the plug-in flying every candidate
(rcsim/lookup/table_plugins.py; docs/flight_software.md, "Refining your table").

The oracle is rcsim's own refinement: a plug-in that flies the same logic (the wrapped
built-in controller, the plain-C lookup example) must choose the same rows, with the same
evidence, on the same runs, because each candidate's flights are bit for bit the built-in's
(tests/lookup/test_c_lookup_example.py shows the C example commands the built-in's on-times).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.apps.refinement.outputs import run_refinement
from rcsim.analysis.apps.refinement.parameters import load_refinable_table
from rcsim.lookup.table_plugins import TablePlugin, declared_table_param
from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle import Vehicle

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
WRAPPED = f"plugin:{EXAMPLES / 'plugins' / 'wrapped_lookup.py'}:make_controller"
SWITCHING = f"plugin:{EXAMPLES / 'plugins' / 'switching_line.py'}:make_controller"
# Cases 3 and 7 of Table 6: with 40 runs both change (yaw one cycle shorter) on seed 1; a
# refinement that changes nothing could not tell two controllers apart.
SETTINGS = dict(
    runs_per_case=40,
    seed=1,
    cases=[2, 6],
    max_iterations=1,
    search_runs_per_case=40,
    duration_s=20.0,
    threads=1,
    progress=False,
)


def _refine(plugin_name: str | None, **params):
    table = load_refinable_table("table6")
    plugin = None
    if plugin_name is not None:
        plugin = TablePlugin.for_refinement(plugin_name, params, Vehicle.load("paper"), table)
    return run_refinement(table, plugin=plugin, **SETTINGS)


@pytest.fixture(scope="module")
def builtin():
    return _refine(None)


def _same_refinement(a, b) -> None:
    np.testing.assert_array_equal(a.table.firing_time_s, b.table.firing_time_s)
    pd.testing.assert_frame_equal(a.changelog, b.changelog)
    pd.testing.assert_frame_equal(a.fresh_after, b.fresh_after)


def test_the_builtin_changes_rows_here(builtin):
    """The comparison below can fail: the built-in changes at least one row on these runs."""
    assert int(builtin.changelog["changed"].sum()) >= 1


def test_a_python_plugin_wrapping_the_builtin_refines_bit_for_bit(builtin):
    """``wrapped_lookup`` declares ``table_param`` and records its rows: the same refinement,
    the same runs flown."""
    ref = _refine(WRAPPED)
    _same_refinement(builtin, ref)
    assert ref.result.runs_flown == builtin.result.runs_flown
    assert ref.plugin is not None and ref.plugin.key == "table"


def test_the_c_lookup_refines_bit_for_bit(builtin, c_build, tmp_path):
    """The plain-C lookup example, with ``rcsim_fsw_table_param`` and
    ``rcsim_fsw_rows_fired``: the same refinement, the same runs flown."""
    lib = c_build(EXAMPLES / "c_fsw" / "lookup.c", tmp_path / "liblookup.so")
    assert declared_table_param(f"library:{lib}") == "table"
    ref = _refine(f"library:{lib}")
    _same_refinement(builtin, ref)
    assert ref.result.runs_flown == builtin.result.runs_flown


def test_a_plugin_that_records_no_rows_is_judged_on_every_case(builtin, tmp_path):
    """Without ``rows_fired`` every run counts as firing every row: each candidate is flown on
    every searched case (more runs), and the decisions stay the built-in's (a candidate's
    runs on a case that does not fire its row fly the same either way)."""
    source = tmp_path / "no_rows.py"
    source.write_text(
        "from rcsim.lookup.registry import make_controller as builtin\n\n"
        "class Hidden:\n"
        "    def __init__(self, inner):\n"
        "        self.inner = inner\n"
        "        self.cycle_s = inner.cycle_s\n"
        "    def initial_state(self, n):\n"
        "        return self.inner.initial_state(n)\n"
        "    def step(self, nav, state):\n"
        "        return self.inner.step(nav, state)\n\n"
        "def make(vehicle, params):\n"
        "    return Hidden(builtin('lookup', vehicle, table=params['table']))\n\n"
        "make.table_param = 'table'\n"
    )
    ref = _refine(f"plugin:{source}:make")
    np.testing.assert_array_equal(builtin.table.firing_time_s, ref.table.firing_time_s)
    cols = ["case", "changed", "decision", "failed_fresh_before", "failed_fresh_after"]
    pd.testing.assert_frame_equal(builtin.changelog[cols], ref.changelog[cols])
    assert ref.result.runs_flown > builtin.result.runs_flown


def test_a_plugin_that_declares_no_table_is_refused():
    table = load_refinable_table("table6")
    with pytest.raises(InputError, match="declares no lookup-table parameter"):
        TablePlugin.for_refinement(SWITCHING, {}, Vehicle.load("paper"), table)


def test_the_table_parameter_is_the_refinements_to_set():
    table = load_refinable_table("table6")
    with pytest.raises(InputError, match="passes each candidate through"):
        TablePlugin.for_refinement(WRAPPED, {"table": "x.csv"}, Vehicle.load("paper"), table)


def test_a_declared_table_parameter_must_be_a_name(tmp_path):
    source = tmp_path / "bad_decl.py"
    source.write_text("def make(vehicle, params):\n    return None\n\nmake.table_param = 3\n")
    with pytest.raises(InputError, match="declares its table parameter as 3"):
        declared_table_param(f"plugin:{source}:make")


def test_cli_refine_with_a_plugin_writes_its_name_into_the_changelog(tmp_path, capsys):
    out = tmp_path / "r.csv"
    argv = ["lookup", "refine", "--table", "table6", "--cases", "3", "--runs", "10"]
    argv += ["--search-runs", "10", "--max-iterations", "1", "--duration-s", "6"]
    assert main([*argv, "--controller", WRAPPED, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"every table flown by {WRAPPED}" in printed
    log = pd.read_csv(tmp_path / "r_changelog.csv")
    assert set(log["controller"]) == {f"{WRAPPED} ({_digest(WRAPPED)})"}


def _digest(name: str) -> str:
    from rcsim.lookup.plugins import load_factory

    return str(load_factory(name)[1].source_sha256)[:12]


def test_the_loop_flown_by_the_c_lookup_is_the_builtins_loop(c_build, tmp_path):
    """`rcsim loop --controller library:...`: every campaign and the refinement flown by the C
    example give the built-in loop's runs and refined table, bit for bit; the specs name the
    library and the report says it flew."""
    import html

    from rcsim.analysis.apps.loop.run import LoopSettings, run_loop

    lib = c_build(EXAMPLES / "c_fsw" / "lookup.c", tmp_path / "liblookup.so")
    base = dict(runs_per_case=6, duration_s=8.0, plots=False, search_runs_per_case=6)
    a = run_loop(LoopSettings(**base), tmp_path / "a", echo=lambda _: None)
    b = run_loop(
        LoopSettings(**base, controller=f"library:{lib}"), tmp_path / "b", echo=lambda _: None
    )
    for name in ("campaign_before", "campaign_after", "campaign_check"):
        pd.testing.assert_frame_equal(
            pd.read_parquet(a.out / name / "runs.parquet"),
            pd.read_parquet(b.out / name / "runs.parquet"),
        )
    assert (a.out / "refined_table.csv").read_text() == (b.out / "refined_table.csv").read_text()
    spec = (b.out / "spec_before.toml").read_text()
    assert f'library = "{lib}"' in spec and f'table = "{b.out / "table6.csv"}"' in spec
    report = html.unescape((b.out / "report.html").read_text())
    assert f"library:{lib} (sha256 " in report
    assert "rcsim's lookup controller" in html.unescape((a.out / "report.html").read_text())
