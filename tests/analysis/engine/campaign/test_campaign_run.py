"""Running campaigns: identical results whatever the execution, resume after a kill, failures
recorded without stopping the campaign, replay of one run."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.engine.campaign import chunk as chunk_mod
from rcsim.analysis.engine.campaign import limits as limits_mod
from rcsim.analysis.engine.campaign.outcomes import _axes_of, _jet_bits, axis_firings, firing_starts
from rcsim.analysis.engine.campaign.runner import run_campaign
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.spacecraft.guards import history_bytes

# Two rate cases (yaw-only 13, roll-only 22), short runs: enough for a firing and its settling.
SPEC = """
seed = 11
runs_per_case = {runs}
chunk_size = {chunk}
[scenario]
cases = [13, 22]
duration_s = {duration}
[controller]
name = "phase-plane"
[output]
histories = "{histories}"
first_k = 1
plots = {plots}
"""


def _spec(
    tmp_path, *, runs=5, chunk=4, duration=2.0, histories="none", plots="false", name="spec.toml"
):
    path = tmp_path / name
    path.write_text(
        SPEC.format(runs=runs, chunk=chunk, duration=duration, histories=histories, plots=plots)
    )
    return path


def _runs(out) -> pd.DataFrame:
    return pd.read_parquet(Path(out) / "runs.parquet")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The campaign flown serially, one chunk at a time (local_workers=1)."""
    tmp = tmp_path_factory.mktemp("ref")
    spec = load_spec(_spec(tmp))
    run_campaign(spec, tmp / "out", local_workers=1, progress=False)
    return _runs(tmp / "out")


def test_outputs_and_columns(reference):
    assert list(reference["run_id"]) == list(range(10))
    assert list(reference["case"]) == ["rate-13"] * 5 + ["rate-22"] * 5
    for col in (
        "seed",
        "mass_kg",
        "cg_x_m",
        "ixx_kg_m2",
        "jet_16_thrust_n",
        "jet_01_tilt_deg",
        "final_rate_err_yaw_deg_s",
        "final_att_err_deg",
        "firings_to_rate_yaw",
        "jet_13_on_time_s",
        "propellant_kg",
        "rate_settled_time_s",
        "failed",
        "reason",
    ):
        assert col in reference.columns
    # Yaw-only case: the rate is reached by one yaw firing event, roll and pitch need none.
    yaw = reference[reference["case"] == "rate-13"]
    assert (yaw["firings_to_rate_yaw"] >= 1).all() and (yaw["firings_to_rate_roll"] == 0).all()


def test_same_results_for_chunk_sizes_and_threads(tmp_path, reference):
    spec = load_spec(_spec(tmp_path, chunk=1))
    reference_plan = chunk_mod.plan_chunks(load_spec(_spec(tmp_path, name="ref.toml")))
    assert len(chunk_mod.plan_chunks(spec)) == 10 != len(reference_plan)  # really another chunking
    run_campaign(spec, tmp_path / "out", local_workers=2, progress=False)
    pd.testing.assert_frame_equal(_runs(tmp_path / "out"), reference, check_exact=True)


def test_dask_local_cluster_one_and_two_workers(tmp_path, reference):
    """A real Dask LocalCluster (worker processes) gives the same table as local mode.

    With Dask's default HTTP port taken (another campaign's cluster, issue 31: a 4-line "Port
    8787 is already in use" warning though the dashboard is off), nothing is said."""
    import socket
    import warnings

    spec = load_spec(_spec(tmp_path))
    with socket.socket() as taken, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            taken.bind(("127.0.0.1", 8787))
            taken.listen()
        except OSError:
            pass  # taken already: the same situation
        for workers in (1, 2):
            out = tmp_path / f"dask{workers}"
            report = run_campaign(spec, out, workers=workers, progress=False)
            assert report.mode == "dask-local"
            pd.testing.assert_frame_equal(_runs(out), reference, check_exact=True)
    assert not [w for w in caught if "already in use" in str(w.message)]


def test_killed_campaign_resumes_to_the_same_result(tmp_path):
    """SIGKILL mid-campaign, then --resume: the table equals an uninterrupted campaign's."""
    spec_path = _spec(tmp_path, runs=8, chunk=2, duration=20.0)
    out = tmp_path / "killed"
    cli = [sys.executable, "-m", "rcsim", "campaign", "run", str(spec_path), "--out", str(out)]
    proc = subprocess.Popen(cli, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if len(list((out / "chunks").glob("runs-*.parquet"))) >= 2 or proc.poll() is not None:
                break
            time.sleep(0.02)
        assert proc.poll() is None, "campaign finished before it could be killed"
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not (out / "runs.parquet").exists()
    committed = len(list((out / "chunks").glob("runs-*.parquet")))
    assert 2 <= committed < 8
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "running"

    spec = load_spec(spec_path)
    report = run_campaign(spec, out, resume=True, local_workers=2, progress=False)
    assert report.resumed_chunks == committed and report.runs_flown == 16 - 2 * committed
    run_campaign(spec, tmp_path / "whole", local_workers=2, progress=False)
    pd.testing.assert_frame_equal(_runs(out), _runs(tmp_path / "whole"), check_exact=True)
    assert not (out / "chunks").exists()
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    # A second --resume has nothing to do and changes nothing.
    again = run_campaign(spec, out, resume=True, progress=False)
    assert again.runs_flown == 0


def test_nan_run_is_recorded_failed_and_the_rest_complete(tmp_path, reference, monkeypatch):
    real = chunk_mod.draw_runs

    def planted(nominal, sigmas, seed, run_ids):
        runs = real(nominal, sigmas, seed, run_ids)
        runs.params.inertia_B[np.asarray(run_ids) == 3, 2] = np.nan
        return runs

    monkeypatch.setattr(chunk_mod, "draw_runs", planted)
    spec = load_spec(_spec(tmp_path, histories="failures"))
    run_campaign(spec, tmp_path / "out", local_workers=1, progress=False)
    runs = _runs(tmp_path / "out")
    bad = runs["run_id"] == 3
    assert runs.loc[bad, "failed"].all() and runs.loc[bad, "sim_failed"].all()
    assert "invalid parameter inertia_B" in runs.loc[bad, "reason"].iloc[0]
    assert runs.loc[bad, "final_rate_err_yaw_deg_s"].isna().all()
    # Every other run is exactly the reference run.
    pd.testing.assert_frame_equal(
        runs[~bad].reset_index(drop=True), reference[~bad].reset_index(drop=True), check_exact=True
    )
    kept = sorted(p.name for p in (tmp_path / "out" / "histories").iterdir())
    assert kept == [f"run-{i:07d}.parquet" for i in runs.loc[runs["failed"], "run_id"]]


def test_a_run_that_raises_is_isolated(tmp_path, reference, monkeypatch):
    real = chunk_mod.fly_runs

    def flaky(spec, run_ids, **kw):
        if 7 in run_ids:
            raise FloatingPointError("planted controller error")
        return real(spec, run_ids, **kw)

    monkeypatch.setattr(chunk_mod, "fly_runs", flaky)
    run_campaign(load_spec(_spec(tmp_path)), tmp_path / "out", local_workers=1, progress=False)
    runs = _runs(tmp_path / "out")
    bad = runs["run_id"] == 7
    assert (
        runs.loc[bad, "reason"].iloc[0] == "exception: FloatingPointError: planted controller error"
    )
    assert runs.loc[bad, "failed"].all()
    pd.testing.assert_frame_equal(
        runs[~bad].reset_index(drop=True), reference[~bad].reset_index(drop=True), check_exact=True
    )


def test_replay_reproduces_a_run_alone(tmp_path, capsys):
    from rcsim.analysis.apps.cli import main

    spec = _spec(tmp_path, histories="first", plots="true")
    out = tmp_path / "out"
    assert main(["campaign", "run", str(spec), "--out", str(out), "--no-progress"]) == 0
    assert "10 runs" in capsys.readouterr().out
    assert sorted(p.name for p in (out / "plots").iterdir()) == [
        "case-rate-13.png",
        "case-rate-22.png",
        "propellant_delta_v.png",
        "summary.png",
    ]
    assert sorted(p.name for p in (out / "histories").iterdir()) == [
        "run-0000000.parquet",
        "run-0000005.parquet",
    ]
    assert main(["campaign", "replay", str(out), "6"]) == 0
    assert "matches the campaign's runs.parquet row exactly" in capsys.readouterr().out
    replayed = out / "replays" / "run-0000006"
    assert (replayed / "history.parquet").exists() and (replayed / "rates_jets.png").exists()
    # The kept history of run 5 is the same flight a replay writes.
    assert main(["campaign", "replay", str(out), "5", "--out", str(tmp_path / "r5")]) == 0
    pd.testing.assert_frame_equal(
        pd.read_parquet(out / "histories" / "run-0000005.parquet"),
        pd.read_parquet(tmp_path / "r5" / "history.parquet"),
    )
    assert main(["campaign", "replay", str(out), "10"]) == 2
    capsys.readouterr()
    # The replay's directory names its command: replayed again only with --overwrite, and
    # other commands refuse it.
    from rcsim.analysis.engine.output import directory_owner

    assert directory_owner(replayed) == "campaign replay"
    assert main(["campaign", "replay", str(out), "6"]) == 2
    assert "use --overwrite" in capsys.readouterr().err
    assert main(["campaign", "replay", str(out), "6", "--overwrite"]) == 0
    assert directory_owner(replayed) == "campaign replay"
    maneuver = ["maneuver", "--attitude-deg", "0", "0", "1", "--duration-s", "1", "--overwrite"]
    assert main([*maneuver, "--out", str(tmp_path / "r5")]) == 2
    assert "holds the outputs of `rcsim campaign replay`" in capsys.readouterr().err
    # Inside the campaign only a replay writes (its replays/ folder): issue 31.
    assert main([*maneuver, "--out", str(replayed)]) == 2
    assert "inside a campaign directory" in capsys.readouterr().err


def test_firing_starts_counts_new_firings_only():
    cycle = 0.04
    on = np.array([[[0.04], [0.04], [0.01], [0.0], [0.02], [0.04], [0.0]]])  # (1, 7, 1)
    starts = firing_starts(on, cycle)[0, :, 0]
    # One firing over cycles 0-2 (it continues while the previous cycle was full); cycle 4 is a
    # new one, and since it was partial the jet was off at its end, so cycle 5 starts another
    # (the rule of rcsim.spacecraft.propulsion.apply_valve_limits).
    assert starts.tolist() == [True, False, False, False, True, True, False]


@pytest.mark.parametrize("n_jets", [5, 12, 16, 17, 33, 64, 70, 130])
def test_packed_jet_masks_say_which_axes_fire(n_jets):
    """outcomes() asks "is some jet of this axis on?" of jets packed into 8- to 64-bit words
    (one AND per cycle and run).  Oracle: the same question asked jet by jet with numpy's
    any() on the unpacked masks, for jet counts that fill a word exactly, leave one partly
    empty, or need several words, and a jet map in which jets serve several axes or none."""
    rng = np.random.default_rng(n_jets)
    on = rng.random((7, 11, n_jets)) < 0.1  # (K, n, n_jets), cycle-major as histories are
    jets = rng.random((3, n_jets)) < 0.3
    jets[:, -1] = True  # the last jet (a partly filled word's top) serves every axis
    on[0, 0, -1] = True
    expect = (on[:, :, None, :] & jets[None, None]).any(axis=-1).swapaxes(0, 1)  # (n, K, 3)
    got = _axes_of(_jet_bits(on), jets)
    assert got.shape == (11, 7, 3)
    np.testing.assert_array_equal(got, expect)
    assert got[0, 0].all()


@pytest.mark.parametrize("numpy_form", ["1", "0"])
def test_axis_firings_are_the_per_jet_rule_per_axis(monkeypatch, numpy_form):
    """outcomes() counts an axis's firing events and its mid-firing samples from packed jet
    masks on the history's cycle-major layout (numpy form, ``RCSIM_NUMPY_CYCLE=1``) or in one
    compiled pass over it (rcsim.spacecraft.cycle_kernel.group_firings, where it is built).  Oracle:
    the per-jet rule asked jet by jet --
    :func:`firing_starts` for a start, "filled the previous cycle and still on" for a firing
    going on -- then any() over each axis's jets, on random commands with full cycles, short
    pulses, zeros, a cycle a rounding short of full (1e-14 s under: full, as
    rcsim.spacecraft.propulsion counts it, to 1e-12 of the cycle) and one short of full (1e-13 s
    under: not full)."""
    rng = np.random.default_rng(5)
    cycle = 0.04
    choices = np.array([0.0, 0.0, 0.0, 0.012, cycle, cycle, cycle - 1e-14, cycle - 1e-13, 0.03])
    buf = rng.choice(choices, size=(40, 9, 16))  # (K, n, jets), as a history writes it
    on = buf.swapaxes(0, 1)
    jets = rng.random((3, 16)) < 0.35
    monkeypatch.setenv("RCSIM_NUMPY_CYCLE", numpy_form)
    starts, going_on = axis_firings(on, cycle, jets)
    full = on >= cycle * (1.0 - 1e-12)
    per_jet_going = full[:, :-1] & (on[:, 1:] > 0)
    expect_starts = (firing_starts(on, cycle)[:, :, None, :] & jets).any(axis=-1)
    expect_going = (per_jet_going[:, :, None, :] & jets).any(axis=-1)
    np.testing.assert_array_equal(starts, expect_starts)
    np.testing.assert_array_equal(going_on, expect_going)
    assert starts.any() and going_on.any() and not starts.all()


def test_lookup_controller_campaign(tmp_path):
    spec_path = _spec(tmp_path)
    spec_path.write_text(spec_path.read_text().replace('"phase-plane"', '"lookup"'))
    spec = load_spec(spec_path)
    run_campaign(spec, tmp_path / "out", local_workers=2, progress=False)
    runs = _runs(tmp_path / "out")
    assert len(runs) == 10 and not runs["sim_failed"].any()


def test_firings_to_rate_ignores_a_mid_firing_zero_crossing(paper):
    """Synthetic yaw history: a firing over cycles 0-3 overshoots the command (its error sweeps
    through 0 at sample 3, mid-firing), ends at +0.1 deg/s; an opposite pulse in cycle 5 brings
    it to 0.02 deg/s at sample 6.  The rate is reached at sample 6 after 2 firing events, not
    at sample 3 after 1."""
    from types import SimpleNamespace

    from rcsim.analysis.engine.campaign.outcomes import outcomes
    from rcsim.spacecraft.navigation import NavState
    from rcsim.spacecraft.propulsion import PropulsionState
    from rcsim.spacecraft.simulation import History

    cycle, K = 0.04, 8
    yaw_err = np.radians([-0.3, -0.2, -0.1, 0.0, 0.1, 0.1, 0.02, 0.02])
    rate = np.zeros((1, K, 3))
    rate[0, :, 2] = yaw_err
    on = np.zeros((1, K, 16))
    on[0, 0:4, [12, 14]] = cycle  # jets 13 and 15 (-yaw per Table 2), four full cycles
    on[0, 5, [13, 15]] = 0.01  # jets 14 and 16 (+yaw), one short pulse
    q = np.tile([1.0, 0, 0, 0], (1, K, 1))
    final = NavState(
        K * cycle, q[:, -1], rate[:, -1], np.zeros((1, 3)), rate[:, -1], np.zeros((1, 3))
    )
    hist = History(
        cycle_s=cycle,
        t_s=np.arange(K) * cycle,
        q_BN=q,
        omega_B=rate,
        att_err_B=np.zeros((1, K, 3)),
        rate_err_B=rate,
        on_time_s=on,
        final=final,
        propulsion=PropulsionState.zeros(1, 16),
        failed=np.zeros(1, bool),
        reason=[""],
        flown_params=paper.nominal(1),
    )
    spec = SimpleNamespace(
        rate_threshold_rad_s=np.radians(0.04), attitude_threshold_rad=None, vehicle=paper
    )  # the paper's vehicle: Table 2's axis jets
    row = outcomes(hist, spec).iloc[0]
    assert row["firings_to_rate_yaw"] == 2
    assert row["time_to_rate_yaw_s"] == pytest.approx(6 * cycle)
    assert row["firings_yaw"] == 2
    assert row["firings_to_rate_roll"] == 0 and row["time_to_rate_roll_s"] == 0.0
    assert row["rate_settled_time_s"] == pytest.approx(6 * cycle)
    assert not row["failed"]


def test_long_runs_get_chunks_within_the_history_budget(tmp_path):
    """Oracle: the record of one chunk is what rcsim.spacecraft.guards.history_bytes counts for
    its runs and cycles (History's arrays, at least 29 float64 per run and cycle); a 500 s case
    (12,500 cycles of 40 ms) must be split so that it stays under the budget, while short cases
    keep the spec's chunk size."""
    long_spec = load_spec(_spec(tmp_path, runs=300, chunk=256, duration=500.0, name="long.toml"))
    chunks = chunk_mod.plan_chunks(long_spec)
    largest = max(c.stop - c.first for c in chunks)
    assert history_bytes(largest, 12_500, n_jets=16) <= limits_mod.HISTORY_BUDGET_BYTES
    # Not needlessly small either: one run more than the per-chunk limit would not fit.
    limit = chunk_mod.max_chunk_runs(long_spec, 500.0)
    assert largest <= limit
    assert history_bytes(limit + 1, 12_500, n_jets=16) > limits_mod.HISTORY_BUDGET_BYTES
    assert largest < 256
    # Every run is planned exactly once, in order.
    assert np.array_equal(np.concatenate([c.run_ids for c in chunks]), np.arange(600))
    short_spec = load_spec(_spec(tmp_path, runs=300, chunk=256, duration=2.0, name="short.toml"))
    # 600 runs in chunks of at most 256: 3 chunks, rounded up to a multiple of
    # CHUNK_COUNT_MULTIPLE (4) for balance across workers, sizes as equal as possible.
    assert [c.stop - c.first for c in chunk_mod.plan_chunks(short_spec)] == [150] * 4


def test_progress_phases_and_the_flying_rate(tmp_path, capsys):
    """With progress: a bar for flying and for assembling, a status line for plotting; the
    runs/s of the summary is over the flying time alone (plots take time after it)."""
    from rcsim.analysis.apps.cli import main
    from rcsim.analysis.engine.campaign.runner import summary_text

    spec = load_spec(_spec(tmp_path, plots="true"))
    report = run_campaign(spec, tmp_path / "out", local_workers=2, progress=True)
    err = capsys.readouterr().err
    assert "flying" in err and "assembling" in err and "campaign: plotting" in err
    assert 0 < report.fly_s < report.wall_s
    text = summary_text(report, spec)
    assert f"flew 10 runs in {report.fly_s:.1f} s ({10 / report.fly_s:.1f} runs/s" in text
    # Not a terminal (CI, a pipe) and no --progress: nothing on stderr.
    assert (
        main(
            [
                "campaign",
                "run",
                str(_spec(tmp_path, name="q.toml")),
                "--out",
                str(tmp_path / "quiet"),
            ]
        )
        == 0
    )
    assert capsys.readouterr().err == ""


def test_paper_table_by_name_flies_replays_and_resumes(tmp_path, capsys):
    """A spec's ``table = "table6"`` flies exactly as a byte copy of the packaged file given
    by path; replay re-flies a run from the name, resume accepts it, and a manifest whose
    recorded SHA-256 differs from the packaged table's is refused."""
    import json
    import shutil

    from rcsim.analysis.apps.cli import main
    from rcsim.models.tables import PAPER_LOOKUP_TABLES, lookup_table_source

    text = SPEC.format(runs=3, chunk=4, duration=20.0, histories="none", plots="false")
    text = text.replace("cases = [13, 22]", "cases = [3]")
    by_name = tmp_path / "name.toml"
    by_name.write_text(text.replace('"phase-plane"', '"lookup"\ntable = "table6"'))
    shutil.copyfile(lookup_table_source("table6"), tmp_path / "t6.csv")
    by_path = tmp_path / "path.toml"
    by_path.write_text(text.replace('"phase-plane"', '"lookup"\ntable = "t6.csv"'))
    for spec, out in ((by_name, "a"), (by_path, "b")):
        assert main(["campaign", "run", str(spec), "--out", str(tmp_path / out)]) == 0
    pd.testing.assert_frame_equal(_runs(tmp_path / "a"), _runs(tmp_path / "b"), check_exact=True)
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    assert manifest["spec"]["controller"]["table"] == "table6"
    assert PAPER_LOOKUP_TABLES["table6"] == "table6_lookup_original.csv"
    capsys.readouterr()
    assert main(["campaign", "replay", str(tmp_path / "a"), "2"]) == 0
    assert "matches the campaign's runs.parquet row exactly" in capsys.readouterr().out
    assert main(["campaign", "run", str(by_name), "--out", str(tmp_path / "a"), "--resume"]) == 0
    assert "already complete" in capsys.readouterr().out
    manifest["spec"]["controller"]["table_sha256"] = "0" * 64
    (tmp_path / "a" / "manifest.json").write_text(json.dumps(manifest))
    assert main(["campaign", "replay", str(tmp_path / "a"), "2", "--out", str(tmp_path / "r")]) == 2
    assert "packaged paper table changed since the campaign ran" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_the_summary_names_every_failure_criterion(tmp_path):
    """The console's "failure: ..." line left out the attitude criterion and propellant
    exhaustion (issue 38, section 4): it names every criterion outcomes() fails a run on,
    with its threshold -- the spec's [failure] keys and, when the vehicle's tank is tracked
    (its [propellant] mass_kg), running dry."""
    import shutil

    from rcsim.analysis.engine.campaign.runner import failure_words

    plain = load_spec(_spec(tmp_path))
    assert failure_words(plain) == "final |rate error| >= 0.04 deg/s"
    shutil.copy(
        Path(__file__).parents[3] / "analysis/apps/cli/corpus/files/smallsat8.toml", tmp_path
    )
    text = _spec(tmp_path, name="all.toml").read_text()
    text = 'vehicle = "smallsat8.toml"\n' + text.replace('"phase-plane"', '"allocator"')
    text += "[failure]\nattitude_error_deg = 0.5\nmax_delta_v_m_s = 0.2\n"
    (tmp_path / "all.toml").write_text(text)
    words = failure_words(load_spec(tmp_path / "all.toml"))
    assert words == (
        "final |rate error| >= 0.04 deg/s, or final attitude error > 0.5 deg, or propellant "
        "exhausted (2 kg loaded), or 0.2 m/s exceeded (max_delta_v_m_s)"
    )
