"""The campaign's derived tables against its own runs: cases.csv, envelopes.parquet and the
manifest counts recomputed from runs.parquet and the kept histories, for campaigns of many
chunks; the one runs.parquet schema; inputs recorded as the physics flew them."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.engine import runs_table as schema
from rcsim.analysis.engine.campaign import chunk as chunk_mod
from rcsim.analysis.engine.campaign import results as R
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec

# Two rate cases with short runs.  runs_per_case = 35 and chunk_size = 1 make the 70 chunks of
# the report: more than results.MERGE_EVERY (32) twice over, so partial statistics and
# envelopes are merged with each other and with raw chunks.
SPEC = """
seed = 7
runs_per_case = {runs}
chunk_size = {chunk}
[scenario]
cases = [13, 20]
duration_s = {duration}
[controller]
name = "phase-plane"
[failure]
rate_error_deg_s = {threshold}
[output]
histories = "all"
plots = false
"""
AXES = ("roll", "pitch", "yaw")


def _spec(tmp_path, *, runs=35, chunk=1, duration=0.6, threshold=0.04, name="spec.toml"):
    path = tmp_path / name
    path.write_text(SPEC.format(runs=runs, chunk=chunk, duration=duration, threshold=threshold))
    return load_spec(path)


@pytest.fixture(scope="module")
def many_chunks(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("many")
    # At 0.6 s the final rate errors of these runs spread over 0.002-0.03 deg/s (measured when
    # this test was written); a 0.01 deg/s threshold makes failures and successes in both
    # cases, which the counts must add up (the test asserts both occur).
    spec = _spec(tmp, threshold=0.01)
    assert len(chunk_mod.plan_chunks(spec)) == 70 > 2 * R.MERGE_EVERY
    run_campaign(spec, tmp / "out", local_workers=2, progress=False)
    return spec, tmp / "out"


def test_cases_csv_and_manifest_counts_equal_runs_parquet(many_chunks):
    """Oracle: the per-case statistics recomputed here directly from runs.parquet with pandas
    (an independent computation: one groupby over all rows).  Counts are exact integers;
    means and maxima are compared to 1e-12 relative (cases.csv prints 6 significant digits,
    so to its last printed digit: rtol 5e-6)."""
    _, out = many_chunks
    runs = pd.read_parquet(out / "runs.parquet")
    cases = pd.read_csv(out / "cases.csv")
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(runs) == 70
    assert 0 < runs["failed"].sum() < 70  # the campaign exercises both outcomes
    g = runs.groupby("case_index", sort=True)
    to_rate = runs[[f"firings_to_rate_{a}" for a in AXES]].max(axis=1)
    expect = pd.DataFrame(
        {
            "runs": g.size(),
            "failed": g["failed"].sum(),
            "sim_failed": g["sim_failed"].sum(),
            "failed_pct": 100.0 * g["failed"].mean(),
            "firings_per_run_mean": g["firings_total"].mean(),
            "firings_per_run_max": g["firings_total"].max(),
            "firings_to_rate_mean": to_rate.groupby(runs["case_index"]).mean(),
            "one_firing_pct": 100.0 * (to_rate <= 1).groupby(runs["case_index"]).mean(),
            "max_abs_final_rate_err_deg_s": runs[[f"final_rate_err_{a}_deg_s" for a in AXES]]
            .abs()
            .max(axis=1)
            .groupby(runs["case_index"])
            .max(),
        }
    ).reset_index()
    assert list(cases["case"]) == ["rate-13", "rate-20"]
    for col in ("case_index", "runs", "failed", "sim_failed"):
        assert cases[col].tolist() == expect[col].astype(int).tolist(), col
    for col in expect.columns[4:]:
        np.testing.assert_allclose(cases[col], expect[col], rtol=5e-6, err_msg=col)
    assert (cases["failed_pct"] <= 100.0).all()
    counts = manifest["counts"]
    assert counts["runs"] == len(runs) == manifest["spec"]["runs_per_case"] * 2
    assert counts["failed"] == int(runs["failed"].sum())
    assert counts["sim_failed"] == int(runs["sim_failed"].sum())
    assert counts["by_case"] == {
        name: {"runs": int(len(rows)), "failed": int(rows["failed"].sum())}
        for name, rows in runs.groupby("case")
    }


def test_envelopes_equal_the_kept_histories(many_chunks):
    """Oracle: min / max / mean over the kept per-run histories (every run is kept), cycle by
    cycle, computed here with pandas.  Min and max are exact (the same float64 values);
    means to 1e-12 relative (summation order differs between merges and one groupby)."""
    spec, out = many_chunks
    env = pd.read_parquet(out / "envelopes.parquet")
    hist = pd.concat(
        [
            pd.read_parquet(p).assign(run_id=int(p.stem[4:]), cycle=lambda f: np.arange(len(f)))
            for p in sorted((out / "histories").glob("run-*.parquet"))
        ],
        ignore_index=True,
    )
    assert hist["run_id"].nunique() == 70
    hist["case_index"] = hist["run_id"] // spec.runs_per_case
    g = hist.groupby(["case_index", "cycle"], sort=True)
    # The envelope also has the end-of-run sample (cycle K), which histories do not record.
    env = env.set_index(["case_index", "cycle"]).loc[g.size().index]
    assert (env["n_runs"] == g.size()).all() and (env["n_runs"] == 35).all()
    for axis in AXES:
        for name in (f"att_err_{axis}_deg", f"rate_{axis}_deg_s"):
            np.testing.assert_array_equal(env[f"{name}_min"], g[name].min())
            np.testing.assert_array_equal(env[f"{name}_max"], g[name].max())
            np.testing.assert_allclose(env[f"{name}_mean"], g[name].mean(), rtol=1e-12, atol=1e-15)


def test_merging_is_independent_of_chunking(many_chunks, tmp_path):
    """The same campaign in 4 chunks (no merge of partial statistics at all) gives the same
    cases.csv and envelopes.parquet as in 70 chunks: merges are associative.  Envelope sums
    are compared to 1e-12 relative (float addition order)."""
    spec, out = many_chunks
    coarse = _spec(tmp_path, chunk=512, threshold=0.01)
    assert len(chunk_mod.plan_chunks(coarse)) == 4
    run_campaign(coarse, tmp_path / "out", local_workers=2, progress=False)
    pd.testing.assert_frame_equal(
        pd.read_csv(tmp_path / "out" / "cases.csv"),
        pd.read_csv(out / "cases.csv"),
        check_exact=True,
    )
    pd.testing.assert_frame_equal(
        pd.read_parquet(tmp_path / "out" / "envelopes.parquet"),
        pd.read_parquet(out / "envelopes.parquet"),
        rtol=1e-12,
    )


def test_runs_parquet_follows_the_schema(many_chunks):
    _, out = many_chunks
    runs = pd.read_parquet(out / "runs.parquet")
    columns = schema.run_columns(n_jets=16)  # the packaged vehicle's 16 jets
    assert tuple(runs.columns) == tuple(c.name for c in columns)
    for col in columns:
        kind = {"int64": "i", "float64": "f", "bool": "b"}.get(col.dtype)
        if kind is None:  # strings: object or pandas' string dtype, whichever pandas infers
            assert pd.api.types.is_string_dtype(runs[col.name]), col.name
        else:
            assert runs[col.name].dtype.kind == kind, col.name
    # A run whose flight raised gets the same columns and dtypes as a flown one.
    missing = schema.missing_outcomes(2, "exception: X", 16)
    flown = runs[list(schema.outcome_names(16))]
    assert list(missing.columns) == list(flown.columns)
    assert [missing[c].dtype.kind for c in missing] == [flown[c].dtype.kind for c in flown]
    assert missing.drop(columns=["sim_failed", "failed", "reason", "failed_by"]).isna().all().all()
    assert (missing["failed_by"] == "simulation").all()


def test_outcome_frame_refuses_columns_outside_the_schema():
    values = {name: np.zeros(1) for name in schema.outcome_names(16)}
    values["settling_time_s"] = np.zeros(1)
    with pytest.raises(KeyError, match="undefined \\['settling_time_s'\\]"):
        schema.outcome_frame(values, 16)
    del values["settling_time_s"], values["rate_settled_time_s"]
    with pytest.raises(KeyError, match="missing \\['rate_settled_time_s'\\]"):
        schema.outcome_frame(values, 16)
    # A jet the vehicle does not have is a column outside the schema too.
    values["rate_settled_time_s"] = np.zeros(1)
    with pytest.raises(KeyError, match="undefined \\['jet_13_on_time_s'"):
        schema.outcome_frame(values, 12)


def test_docs_carry_the_schema_table():
    """docs/campaigns.md documents every runs.parquet column with the schema's own table."""
    docs = Path(__file__).resolve().parents[4] / "docs" / "campaigns.md"
    assert schema.markdown_table() in docs.read_text()


def test_recorded_inputs_are_the_flown_values(paper, tmp_path, monkeypatch):
    """runs.parquet records the vehicle read back from MuJoCo's per-run model (issue 9).

    1. Unpatched, the read-back equals the draw bit for bit (rcsim.spacecraft.simulation
       BatchSimulation.flown_params: MuJoCo stores float64 as written), so the recorded
       inputs equal draw_runs' values exactly.
    2. With the read-back planted to differ from the draw (+1 kg, x1.5 thrust on jet 3), the
       recorded values follow the read-back, not the draw.
    3. The direction MuJoCo flies each jet along is tilted from the nominal one by the
       recorded |tilt| (rcsim.spacecraft.dispersions: misalignment = |theta|), to 1e-12 rad (the
       angle from atan2 of float64 cross and dot products is accurate to ~1e-16).
    """
    from rcsim.spacecraft.dispersions import draw_runs

    spec = _spec(tmp_path, runs=3, chunk=8, duration=0.2)
    ids = np.arange(spec.n_runs)
    drawn = draw_runs(paper.nominal(1), spec.sigmas, spec.seed, ids).params
    real = chunk_mod.fly_runs
    seen = {}

    def keep(spec_, run_ids, **kw):
        history, dispersed = real(spec_, run_ids, **kw)
        seen.update({int(i): history.flown_params.jet_dir_S[k] for k, i in enumerate(run_ids)})
        return history, dispersed

    monkeypatch.setattr(chunk_mod, "fly_runs", keep)
    run_campaign(spec, tmp_path / "plain", local_workers=1, progress=False)
    runs = pd.read_parquet(tmp_path / "plain" / "runs.parquet")
    np.testing.assert_array_equal(runs["mass_kg"], drawn.mass_kg)
    np.testing.assert_array_equal(runs[["ixx_kg_m2", "iyy_kg_m2", "izz_kg_m2"]], drawn.inertia_B)
    np.testing.assert_array_equal(runs[[f"cg_{a}_m" for a in "xyz"]], drawn.cg_B)
    np.testing.assert_array_equal(
        runs[[f"jet_{j:02d}_thrust_n" for j in range(1, 17)]], drawn.thrust_n
    )
    # 3: the flown jet direction is tilted from the nominal one by |recorded tilt|.
    flown_dir = np.stack([seen[i] for i in runs["run_id"]])  # (n, 16, 3)
    tilt = np.radians(runs[[f"jet_{j:02d}_tilt_deg" for j in range(1, 17)]].to_numpy())
    nominal_dir = paper.nominal(1).jet_dir_S  # (1, 16, 3)
    cos = (flown_dir * nominal_dir).sum(-1)
    sin = np.linalg.norm(np.cross(flown_dir, nominal_dir), axis=-1)
    np.testing.assert_allclose(np.arctan2(sin, cos), np.abs(tilt), rtol=0, atol=1e-12)

    def planted(spec_, run_ids, **kw):
        history, dispersed = real(spec_, run_ids, **kw)
        f = history.flown_params
        thrust = f.thrust_n.copy()
        thrust[:, 2] *= 1.5
        history.flown_params = type(f)(
            f.mass_kg + 1.0, f.cg_B, f.inertia_B, thrust, f.jet_dir_S, f.isp_s
        )
        return history, dispersed

    monkeypatch.setattr(chunk_mod, "fly_runs", planted)
    run_campaign(spec, tmp_path / "planted", local_workers=1, progress=False)
    runs = pd.read_parquet(tmp_path / "planted" / "runs.parquet")
    np.testing.assert_array_equal(runs["mass_kg"], drawn.mass_kg + 1.0)
    np.testing.assert_array_equal(runs["jet_03_thrust_n"], drawn.thrust_n[:, 2] * 1.5)
    np.testing.assert_array_equal(runs["jet_04_thrust_n"], drawn.thrust_n[:, 3])


def test_an_invalid_run_records_its_draw(tmp_path, monkeypatch):
    """A run with invalid parameters is not flown (the simulation flies the nominal vehicle in
    its place, with no commands): its row keeps the draw that made it invalid."""
    real = chunk_mod.draw_runs

    def nan_inertia(nominal, sigmas, seed, run_ids):
        runs = real(nominal, sigmas, seed, run_ids)
        runs.params.inertia_B[np.asarray(run_ids) == 1, 0] = np.nan
        return runs

    monkeypatch.setattr(chunk_mod, "draw_runs", nan_inertia)
    spec = _spec(tmp_path, runs=2, chunk=8, duration=0.2)
    run_campaign(spec, tmp_path / "out", local_workers=1, progress=False)
    runs = pd.read_parquet(tmp_path / "out" / "runs.parquet").set_index("run_id")
    assert np.isnan(runs.loc[1, "ixx_kg_m2"]) and runs.loc[1, "sim_failed"]
    assert np.isfinite(runs.drop(index=1)["ixx_kg_m2"]).all()


@pytest.mark.parametrize("runs_kind", ["slice", "ids"])
def test_group_on_time_is_the_numpy_envelope_bit_for_bit(monkeypatch, runs_kind):
    """Issue 19: the envelope's per-axis on-time sums and firing counts come from a compiled
    pass over the flight's cycle-major record; they must be the numpy form's to the last bit.
    The numpy form adds jet after jet and, within a jet, run after run (the layout numpy's
    advanced indexing gives the gathered jets): a run-major order would change the last bits,
    and groups of 1 to 9 jets, zeros, -0.0 and values nine decades apart make it show."""
    from types import SimpleNamespace

    from rcsim.spacecraft import cycle_kernel

    if cycle_kernel._cycle_kernel is None:
        pytest.skip("the compiled passes were not built")
    rng = np.random.default_rng(11)
    n_cycles, n_runs, n_jets = 41, 37, 16
    record = rng.random((n_cycles, n_runs, n_jets)) * (rng.random((n_cycles, n_runs, n_jets)) < 0.5)
    record[rng.random(record.shape) < 0.2] *= 1e-9
    record[rng.random(record.shape) < 0.05] = -0.0
    history = SimpleNamespace(on_time_s=record.swapaxes(0, 1))  # as the flight returns it
    groups = np.zeros((4, n_jets), bool)
    for g, size in enumerate((1, 4, 8, 9)):
        groups[g, rng.choice(n_jets, size, replace=False)] = True
    ids = np.arange(n_runs) if runs_kind == "slice" else np.sort(rng.choice(n_runs, 23, False))
    runs = slice(0, n_runs) if runs_kind == "slice" else ids
    monkeypatch.setenv("RCSIM_NUMPY_CYCLE", "1")
    ref_sums, ref_firing = chunk_mod._group_on_time(history, runs, ids, groups)
    monkeypatch.setenv("RCSIM_NUMPY_CYCLE", "0")
    sums, firing = chunk_mod._group_on_time(history, runs, ids, groups)
    assert sums.tobytes() == ref_sums.tobytes()
    np.testing.assert_array_equal(firing, ref_firing)
    assert firing.dtype == np.int64 and ref_firing.max() > 0
    # The order matters: the same numbers summed in memory order (numpy then adds pairwise),
    # some cycle's total differs in its last bits.
    other = np.array(
        [np.ascontiguousarray(record[:, ids][:, :, g]).sum(axis=(1, 2)) for g in groups]
    )
    assert other.tobytes() != ref_sums.tobytes()
