"""examples/c_fsw/lookup.c: the lookup controller in plain C, back to back with rcsim's own.

Oracle: rcsim's lookup controller (rcsim/lookup/pattern_recognition.py) flying the same runs.
The C code does the same arithmetic in the same order, so every on-time of every cycle of
every run must be equal, bit for bit (`rcsim compare controllers` counts the runs that
differ).  A copy with one threshold changed (the rate dead band quartered, 0.06 -> 0.015
deg/s) must be caught at the first cycle where two independent flights of a run differ,
recomputed here.  Built with the machine's C compiler; skipped, with the reason, without one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rcsim.analysis.apps.back_to_back import Side, compare
from rcsim.analysis.engine.campaign.chunk import fly_runs
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.lookup.pattern_recognition import default_table_path

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "examples" / "c_fsw" / "lookup.c"
TABLE = {"table": str(default_table_path())}


def _einsum_pairs_roll_and_yaw() -> bool:
    """Whether this numpy sums three squares as (x0^2 + x2^2) + x1^2, the order the C
    example copies (numpy's einsum on x86-64); another build may pair them otherwise."""
    e = np.random.default_rng(0).normal(size=(20000, 3))
    pairs = (e[:, 0] * e[:, 0] + e[:, 2] * e[:, 2]) + e[:, 1] * e[:, 1]
    return bool(np.array_equal(np.einsum("ij,ij->i", e, e), pairs))


@pytest.fixture(scope="module")
def library(tmp_path_factory, c_build) -> Path:
    if not _einsum_pairs_roll_and_yaw():
        pytest.skip("this numpy sums the attitude error's squares in another order than the C")
    return c_build(SOURCE, tmp_path_factory.mktemp("c") / "liblookup.so")


def _spec(tmp_path: Path, body: str):
    path = tmp_path / "s.toml"
    path.write_text(body + '\n[controller]\nname = "lookup"\n[output]\nhistories = "none"\n')
    return load_spec(path)


@pytest.mark.slow
def test_the_c_lookup_flies_bit_for_bit_over_26_x_100_runs(tmp_path, library):
    """The 26 rate cases of Table 3, 100 Table 5 dispersed runs each."""
    spec = _spec(tmp_path, "seed = 1\nruns_per_case = 100\n[scenario]\nduration_s = 20.0")
    s = compare(spec, Side("lookup"), Side(f"library:{library}", TABLE))["summary"]
    assert s["runs"] == 2600 and s["diverged"] == 0
    assert s["failed_a"] == s["failed_b"] and s["propellant_diff_kg"] == 0.0


def test_the_c_lookup_flies_maneuvers_with_hysteresis_bit_for_bit(tmp_path, library):
    """Maneuvers above the maneuver limit (the maneuver rate, the no-firing band) with a
    hysteresis from the spec's [control] (the state's last-cycle flag)."""
    spec = _spec(
        tmp_path,
        'seed = 3\nruns_per_case = 12\n[scenario]\nkind = "maneuver"\n'
        "attitude_deg = [3.0, -2.0, 4.0]\nduration_s = 40.0\n[control]\n"
        "maneuver_hysteresis_deg = 0.1",
    )
    s = compare(spec, Side("lookup"), Side(f"library:{library}", TABLE))["summary"]
    assert s["runs"] == 12 and s["diverged"] == 0


def test_a_changed_threshold_is_caught_at_its_first_divergent_cycle(tmp_path, library, c_build):
    text = SOURCE.read_text()
    old = "err = fabs(err) < rate_limit ? 0.0 : err;"
    assert old in text
    changed = tmp_path / "changed.c"
    changed.write_text(text.replace(old, "err = fabs(err) < 0.25 * rate_limit ? 0.0 : err;"))
    lib = c_build(changed, tmp_path / "libchanged.so")
    spec = _spec(tmp_path, "seed = 2\nruns_per_case = 6\n[scenario]\nduration_s = 20.0")
    b = Side(f"library:{lib}", TABLE)
    runs = compare(spec, Side("lookup"), b)["runs"]
    assert runs["diverged"].sum() >= 1
    ids = runs["run_id"].to_numpy()
    ha, _ = fly_runs(Side("lookup").spec_for(spec), ids)
    hb, _ = fly_runs(b.spec_for(spec), ids)
    differ = (ha.on_time_s != hb.on_time_s).any(axis=2)
    for i, row in runs.iterrows():
        assert row["diverged"] == differ[i].any()
        if row["diverged"]:
            k = int(differ[i].argmax())
            assert row["first_cycle"] == k
            assert np.array_equal(ha.on_time_s[i, :k], hb.on_time_s[i, :k])
            # Where they part, the rate error lies between the two dead bands on some axis.
            err = np.abs(np.degrees(ha.rate_err_B[i, k]))
            assert np.any((err >= 0.015 - 1e-12) & (err < 0.06 + 1e-12))
