"""C flight code through rcsim's C ABI (rcsim/lookup/c_library.py, rcsim_fsw.h).

Oracles: the Python switching-line example (examples/plugins/switching_line.py), which the C
example implements with the same arithmetic in the same order, so their on-times must be
equal bit for bit; the ABI's own contract for the refusals; a process's exit signal for a
crash.  Compiled with the machine's C compiler; skipped, with the reason, without one.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.analysis.engine.flight import Scenario, fly
from rcsim.lookup.c_library import header_path
from rcsim.models.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE_C = ROOT / "examples" / "c_fsw" / "switching_line.c"
PYTHON_TWIN = f"plugin:{ROOT / 'examples' / 'plugins' / 'switching_line.py'}:make_controller"
SCENARIO = Scenario(
    name="m", duration_s=30.0, att_cmd_rad=np.radians([1.0, -2.0, 2.0]),
    omega0_rad_s=np.radians([0.1, 0.0, -0.05]),
)  # fmt: skip


def _variant(c_build, tmp_path: Path, name: str, old: str, new: str) -> Path:
    text = EXAMPLE_C.read_text()
    assert old in text
    src = tmp_path / f"{name}.c"
    src.write_text(text.replace(old, new))
    return c_build(src, tmp_path / f"lib{name}.so")


@pytest.fixture(scope="module")
def library(tmp_path_factory, c_build) -> Path:
    return c_build(EXAMPLE_C, tmp_path_factory.mktemp("c") / "libswitching_line.so")


def test_the_header_ships_with_the_package():
    assert "RCSIM_FSW_ABI_VERSION 1" in header_path().read_text()


def test_c_example_commands_what_its_python_twin_commands(library):
    params = {"deadband_deg_s": 0.02, "tau_s": 15.0}
    a = fly(SCENARIO, PYTHON_TWIN, controller_params=params)
    b = fly(SCENARIO, f"library:{library}", controller_params=params)
    assert a.on_time_s.sum() > 0
    assert np.array_equal(a.on_time_s, b.on_time_s)


def test_refusals(tmp_path, library, c_build):
    def variant(name, old, new):
        return f"library:{_variant(c_build, tmp_path, name, old, new)}"

    cases = {
        f"library:{tmp_path / 'nope.so'}": "not found",
        f"library:{EXAMPLE_C}": "not a loadable shared library",
        variant("v2", "return RCSIM_FSW_ABI_VERSION;", "return 2;"): "built for C ABI version 2",
        variant("nosym", "int32_t rcsim_fsw_init(", "int32_t init_("): "lacks rcsim_fsw_init",
        variant("status", "status[i] = 0;", "status[i] = 7;"): "run 0 status 7",
        variant("nan", "out[j] = 0.0;", "out[j] = NAN;"): "not finite",
    }
    for name, words in cases.items():
        with pytest.raises(InputError) as err:
            fly(SCENARIO, name)
        assert words in str(err.value) and "\n" not in str(err.value), str(err.value)
    with pytest.raises(InputError, match="must be a number or a string for a C library"):
        fly(SCENARIO, f"library:{library}", controller_params={"mode": [1, 2]})


SPEC = """
seed = 2
runs_per_case = 3
chunk_size = 3
[scenario]
cases = [13, 22]
duration_s = 3.0
[controller]
{controller}
[controller.params]
deadband_deg_s = 0.02
[output]
histories = "none"
plots = false
"""


def test_a_campaign_with_c_flight_code_matches_its_python_twin(tmp_path, library):
    (tmp_path / "c.toml").write_text(SPEC.format(controller=f'library = "{library}"'))
    (tmp_path / "p.toml").write_text(
        SPEC.format(controller=f'plugin = "{PYTHON_TWIN.removeprefix("plugin:")}"')
    )
    run_campaign(load_spec(tmp_path / "c.toml"), tmp_path / "c", local_workers=1, progress=False)
    run_campaign(load_spec(tmp_path / "p.toml"), tmp_path / "p", local_workers=1, progress=False)
    c = pd.read_parquet(tmp_path / "c" / "runs.parquet")
    p = pd.read_parquet(tmp_path / "p" / "runs.parquet")
    cols = [k for k in p.columns if k.startswith(("final_", "max_", "propellant"))]
    pd.testing.assert_frame_equal(c[cols], p[cols])
    record = json.loads((tmp_path / "c" / "manifest.json").read_text())["spec"]["controller"]
    assert len(record["plugin_record"]["source_sha256"]) == 64


@pytest.mark.parametrize("where", ["local", "dask"])
def test_a_crash_fails_only_its_run_and_names_the_cycle(tmp_path, capfd, where, c_build):
    """A library that dereferences NULL from t = 0.2 s (cycle 5 of 40 ms) in any run whose yaw
    rate error still exceeds 1e-3 rad/s: case 13's runs (a 0.3 deg/s yaw rate case: the
    switching line removes at most 0.03 deg/s a cycle, so 0.15 deg/s = 2.6e-3 rad/s is left at
    cycle 5), not case 22's (roll: its yaw error is cross-coupling, far below).  The campaign
    records exactly those runs failed, with the signal and cycle, and flies the others."""
    lib = _variant(
        c_build,
        tmp_path,
        "crash",
        "    for (int64_t i = 0; i < n_runs; i++) {",
        "    if (t_s >= 0.2) for (int64_t i = 0; i < n_runs; i++)\n"
        "        if (fabs(rate[3 * i + 2]) > 1e-3) { volatile int *p = 0; *p = 1; }\n"
        "    for (int64_t i = 0; i < n_runs; i++) {",
    )
    (tmp_path / "s.toml").write_text(SPEC.format(controller=f'library = "{lib}"'))
    # Locally in worker processes (even one); on Dask in a child of the worker.
    where_kw = {"local_workers": 1} if where == "local" else {"workers": 1}
    run_campaign(load_spec(tmp_path / "s.toml"), tmp_path / "out", progress=False, **where_kw)
    runs = pd.read_parquet(tmp_path / "out" / "runs.parquet")
    crashed = runs[runs["reason"].fillna("").str.contains("crashed")]
    assert len(runs) == 6
    assert sorted(crashed["run_id"]) == [0, 1, 2]  # case 13's runs, nothing else lost
    assert crashed["reason"].str.contains(r"crashed \(SIGSEGV\) at cycle 5 \(t = 0.2 s\)").all()
    assert not runs.loc[runs["run_id"] >= 3, "reason"].fillna("").str.contains("crash").any()
    err = capfd.readouterr().err
    assert err.count("rcsim: warning: run ") == 3 and "Traceback" not in err, err


def test_maneuver_with_a_crashing_library_is_one_line(tmp_path, c_build):
    lib = _variant(c_build, tmp_path, "crash0", "    for (int64_t i = 0; i < n_runs; i++) {",
        "    if (t_s >= 0.2) { volatile int *p = 0; *p = 1; }\n"
        "    for (int64_t i = 0; i < n_runs; i++) {",
    )  # fmt: skip
    res = subprocess.run(
        [sys.executable, "-m", "rcsim", "maneuver", "--controller", f"library:{lib}",
         "--attitude-deg", "0", "0", "2", "--duration-s", "2", "--out", str(tmp_path / "o")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert "crashed (SIGSEGV) at cycle 5 (t = 0.2 s)" in lines[0]
    assert not (tmp_path / "o").exists()


def test_per_run_flight_code_through_the_shipped_shim(tmp_path, library, c_build):
    """examples/c_fsw/switching_line_per_run.c steps one vehicle at a time; the shim
    (rcsim_fsw_per_run.h) batches it.  Its on-times equal the batched example's, bit for bit,
    over a dispersed campaign's runs (same arithmetic per run)."""
    from rcsim.analysis.apps.back_to_back import Side, compare

    per_run = c_build(ROOT / "examples" / "c_fsw" / "switching_line_per_run.c", tmp_path / "p.so")
    (tmp_path / "s.toml").write_text(SPEC.format(controller=f'library = "{library}"'))
    spec = load_spec(tmp_path / "s.toml")
    params = {"deadband_deg_s": 0.02}
    s = compare(spec, Side(f"library:{library}", params), Side(f"library:{per_run}", params))
    assert s["summary"]["runs"] == 6 and s["summary"]["diverged"] == 0
    assert s["runs"]["cycles_differing"].sum() == 0
