"""Controller plug-ins (rcsim.lookup.plugins): the user's flight software flown by rcsim.

Oracles: the built-in lookup controller (a plug-in that wraps it must command exactly what it
commands, bit for bit: the same arithmetic runs); the Controller protocol's contract (on-times
shaped (runs, jets), finite, in [0, cycle]); importlib.metadata's own entry-point discovery.
"""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.engine.campaign.replay import replay
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.analysis.engine.flight import Scenario, fly
from rcsim.lookup.plugins import PluginError, build, load_factory
from rcsim.lookup.registry import (
    check_controller_name,
    controller_names,
    is_plugin,
    make_controller,
)
from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle import Vehicle

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "plugins"
WRAPPED = f"plugin:{EXAMPLES / 'wrapped_lookup.py'}:make_controller"
SWITCHING = f"plugin:{EXAMPLES / 'switching_line.py'}:make_controller"
MANEUVER = Scenario(name="m", duration_s=12.0, att_cmd_rad=np.radians([2.0, -1.0, 3.0]))


def _module(tmp_path: Path, body: str, name: str = "fsw.py") -> str:
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return f"plugin:{path}:make_controller"


# A factory whose controller returns ``ON(nav, n_jets, cycle)``: one contract breach each.
BREACH = """
import numpy as np

class C:
    cycle_s = {cycle}
    def initial_state(self, n):
        return None
    def step(self, nav, state):
        n = nav.rate_err_B.shape[0]
        return {on}, state

def make_controller(vehicle, params):
    return C()
"""


def test_wrapped_lookup_flies_bit_for_bit_as_the_builtin():
    """Oracle: the built-in lookup controller; the plug-in path adds checks, not arithmetic."""
    a = fly(MANEUVER, "lookup")
    b = fly(MANEUVER, WRAPPED)
    assert a.on_time_s.sum() > 0  # the maneuver fires: the comparison is not of zeros
    assert np.array_equal(a.on_time_s, b.on_time_s)
    assert np.array_equal(a.omega_B, b.omega_B)


def test_params_reach_the_factory():
    """The switching-line example's deadband, its attitude term switched off (tau huge): it
    fires whole cycles while a rate error exceeds the band, so each axis ends inside the band
    plus one cycle's rate change with all its jets (torque / inertia x cycle, the vehicle's
    own figures), and a band ten times wider leaves more rate behind."""
    paper = Vehicle.load(None)
    # inertia_B: the principal moments, along B for the paper's vehicle (iquat identity).
    step_deg_s = np.degrees(
        paper.axis_torque_n_m() / paper.nominal(1).inertia_B[0] * paper.control.cycle_s
    )
    assert np.all(np.isfinite(step_deg_s)) and step_deg_s.max() < 0.05
    spin = Scenario(name="d", duration_s=20.0, omega0_rad_s=np.radians([0.3, -0.2, 0.1]))
    tight = fly(spin, SWITCHING, controller_params={"deadband_deg_s": 0.01, "tau_s": 1e6})
    loose = fly(spin, SWITCHING, controller_params={"deadband_deg_s": 0.1, "tau_s": 1e6})
    end_tight = np.abs(np.degrees(tight.omega_B[0, -1]))
    end_loose = np.abs(np.degrees(loose.omega_B[0, -1]))
    assert (end_tight <= 0.01 + step_deg_s).all()
    assert (end_loose <= 0.1 + step_deg_s).all() and end_loose.max() > end_tight.max()
    assert tight.on_time_s.sum() > loose.on_time_s.sum()


def test_record_names_the_source(tmp_path):
    target = _module(tmp_path, BREACH.format(cycle=0.04, on="np.zeros((n, 16))"))
    factory, info = load_factory(target)
    assert callable(factory)
    assert info.target.endswith("fsw.py:make_controller") and info.entry_point is None
    import hashlib

    assert info.source_sha256 == hashlib.sha256((tmp_path / "fsw.py").read_bytes()).hexdigest()


@pytest.mark.parametrize(
    "on, words",
    [
        ("np.zeros((n, 15))", ["shape (2, 15)", "expected (2, 16)"]),
        ("-np.ones((n, 16)) * 0.01", ["run 0 jet 1", "negative"]),
        ("np.full((n, 16), np.nan)", ["not finite"]),
        ("np.full((n, 16), 0.05)", ["longer than the 0.04 s cycle"]),
        ("'text'", ["not numbers"]),
    ],
)
def test_contract_breaches_are_one_line_errors(tmp_path, on, words):
    target = _module(tmp_path, BREACH.format(cycle=0.04, on=on))
    with pytest.raises(PluginError) as err:
        make_controller(target, Vehicle.load(None))
    text = str(err.value)
    assert "\n" not in text and "cycle 0" in text
    for w in words:
        assert w in text


def test_load_and_build_errors(tmp_path):
    paper = Vehicle.load(None)
    cases = {
        "plugin:no_such_module_xyz:f": "not found",
        f"plugin:{tmp_path / 'missing.py'}:f": "not found",
        _module(tmp_path, "raise RuntimeError('boom\\nline two')", "broken.py"): (
            "failed to import: RuntimeError: boom line two"
        ),
        _module(tmp_path, "make_controller = 3", "notcallable.py"): "is not callable",
        _module(tmp_path, "x = 1", "noattr.py"): "has no attribute 'make_controller'",
        _module(
            tmp_path, "def make_controller(v, p):\n    raise KeyError('gain')", "raises.py"
        ): "its factory raised KeyError",
        _module(tmp_path, "def make_controller(v, p):\n    return 3", "noproto.py"): (
            "lacks cycle_s, initial_state, step"
        ),
        _module(tmp_path, BREACH.format(cycle=0.1, on="np.zeros((n, 16))"), "cyc.py"): (
            "built for a 0.1 s cycle"
        ),
        "plugin:nocolon": "'package.module:factory'",
    }
    for target, words in cases.items():
        with pytest.raises(PluginError) as err:
            make_controller(target, paper)
        assert words in str(err.value) and "\n" not in str(err.value), (target, str(err.value))
    with pytest.raises(InputError, match="only for a plug-in"):
        make_controller("lookup", paper, plugin_params={"x": 1})
    with pytest.raises(InputError, match="unknown controller 'theirs'"):
        check_controller_name("theirs")


def test_a_raise_inside_step_names_the_cycle(tmp_path):
    body = BREACH.format(cycle=0.04, on="np.zeros((n, 16))").replace(
        "        n = nav.rate_err_B.shape[0]",
        "        n = nav.rate_err_B.shape[0]\n        if nav.t_s > 0.1:\n"
        "            raise ZeroDivisionError('gain')",
    )
    target = _module(tmp_path, body)
    with pytest.raises(PluginError, match=r"raised at cycle 3 \(t = 0.12 s\): ZeroDivisionError"):
        fly(MANEUVER, target)


def test_registered_entry_point_works_like_a_builtin(tmp_path, monkeypatch):
    """A distribution registers ``theirs`` under ``rcsim.controllers``; importlib.metadata
    finds it on sys.path (a .dist-info directory is what an install writes)."""
    pkg = tmp_path / "their_fsw"
    pkg.mkdir()
    (pkg / "__init__.py").write_text((EXAMPLES / "wrapped_lookup.py").read_text())
    dist = tmp_path / "their_fsw-1.2.3.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: their-fsw\nVersion: 1.2.3\n")
    (dist / "top_level.txt").write_text("their_fsw\n")
    (dist / "RECORD").write_text("their_fsw/__init__.py,,\n")
    (dist / "entry_points.txt").write_text(
        "[rcsim.controllers]\ntheirs = their_fsw:make_controller\n"
        "lookup = their_fsw:make_controller\n"  # may not shadow the built-in
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    assert "theirs" in controller_names() and is_plugin("theirs")
    assert not is_plugin("lookup")
    ctl = build("theirs", Vehicle.load(None), {})
    assert ctl.info.entry_point == "theirs" and ctl.info.distribution == "their-fsw"
    assert ctl.info.version == "1.2.3"
    assert np.array_equal(fly(MANEUVER, "theirs").on_time_s, fly(MANEUVER, "lookup").on_time_s)
    sys.modules.pop("their_fsw", None)


SPEC = """
seed = 5
runs_per_case = 3
chunk_size = 4
[scenario]
cases = [13, 22]
duration_s = 2.0
[controller]
{controller}
[output]
histories = "none"
plots = false
"""


def test_campaign_with_a_plugin_matches_the_builtin_and_replays(tmp_path):
    """The spec's plug-in (path relative to the spec) flies the campaign: every run's outcome
    equals the built-in lookup controller's, the manifest records the plug-in, and a run
    replays from the manifest alone."""
    (tmp_path / "fsw").mkdir()
    (tmp_path / "fsw" / "wrapped.py").write_text((EXAMPLES / "wrapped_lookup.py").read_text())
    plug = tmp_path / "plug.toml"
    plug.write_text(
        SPEC.format(controller='plugin = "fsw/wrapped.py:make_controller"\n[controller.params]\n')
    )
    ref = tmp_path / "ref.toml"
    ref.write_text(SPEC.format(controller='name = "lookup"'))
    run_campaign(load_spec(plug), tmp_path / "a", local_workers=1, progress=False)
    run_campaign(load_spec(ref), tmp_path / "b", local_workers=1, progress=False)
    a = pd.read_parquet(tmp_path / "a" / "runs.parquet")
    b = pd.read_parquet(tmp_path / "b" / "runs.parquet")
    outcomes = [c for c in b.columns if c.startswith(("final_", "max_", "propellant", "failed"))]
    assert outcomes
    pd.testing.assert_frame_equal(a[outcomes], b[outcomes])
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    ctl = manifest["spec"]["controller"]
    assert ctl["name"].startswith("plugin:") and ctl["name"].endswith("wrapped.py:make_controller")
    assert len(ctl["plugin_record"]["source_sha256"]) == 64
    got = replay(tmp_path / "a", 4, tmp_path / "r")
    assert got["matches"] is True


def test_spec_refuses_a_changed_plugin_and_params_for_a_builtin(tmp_path):
    (tmp_path / "w.py").write_text((EXAMPLES / "wrapped_lookup.py").read_text())
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC.format(controller='plugin = "w.py:make_controller"'))
    run_campaign(load_spec(spec), tmp_path / "a", local_workers=1, progress=False)
    (tmp_path / "w.py").write_text((EXAMPLES / "wrapped_lookup.py").read_text() + "\n# edited\n")
    with pytest.raises(InputError, match="changed since the campaign ran"):
        replay(tmp_path / "a", 0, tmp_path / "r")
    bad = tmp_path / "b.toml"
    bad.write_text(SPEC.format(controller='name = "lookup"\n[controller.params]\ngain = 2'))
    with pytest.raises(InputError, match="only for a plug-in controller"):
        load_spec(bad)


def test_dask_workers_that_cannot_build_the_plugin_are_named(tmp_path):
    """A plug-in that builds here but not on the Dask workers (other processes: a library
    only this one has is stood in for by the process id): one line naming a worker, before any
    run and before the campaign directory exists."""
    import os

    (tmp_path / "fsw.py").write_text(
        "import os\n"
        + (EXAMPLES / "wrapped_lookup.py")
        .read_text()
        .replace(
            "    unknown =",
            f"    if os.getpid() != {os.getpid()}:\n"
            "        raise ImportError('libfsw.so: cannot open shared object file')\n"
            "    unknown =",
        )
    )
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC.format(controller='plugin = "fsw.py:make_controller"'))
    with pytest.raises(InputError, match=r"cannot be built on Dask worker .*\(1 of 1 workers\)"):
        run_campaign(load_spec(spec), tmp_path / "out", workers=1, progress=False)
    assert not (tmp_path / "out").exists()
