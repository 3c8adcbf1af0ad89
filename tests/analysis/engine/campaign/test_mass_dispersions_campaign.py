"""CG y/z and products of inertia in campaigns (issue 18): the spec keys, the runs they draw,
what runs.parquet records, the replay, the failure drivers' inputs, and vehicle files.

The physics and the draws themselves are tested in tests/spacecraft/test_mass_dispersions.py;
the digest of a spec written before these keys is pinned in test_faults_campaign.py
(``test_spec_without_effect_tables_resolves_as_before``: the keys absent, nothing is recorded).

Inertia in B (a vehicle file whose moments MuJoCo sorts otherwise, with products: the
``unsorted_vehicle`` fixture, whose tensor the fixture writes out): the recorded ``ixx`` ...
``iyz`` are that tensor's entries plus the run's diagonal draws (its standard normals rebuilt
from its dispersion stream), and the authority factors are each jet group's torque, from the
file's own jet matrix (``VehicleDef.force_torque``: positions, directions, thrust, CG), over
the recorded moment about the axis.
"""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rcsim.analysis.apps.cli import main
from rcsim.analysis.engine.campaign import chunk as chunk_mod
from rcsim.analysis.engine.campaign.replay import replay
from rcsim.analysis.engine.campaign.spec import load_spec
from rcsim.analysis.engine.runs_table import PRODUCT_NAMES, input_names, outcome_names
from rcsim.analysis.results.drivers.inputs import load_runs
from rcsim.models.errors import InputError
from rcsim.spacecraft.dispersions import n_normals, run_streams
from rcsim.spacecraft.vehicle import load_vehicle
from rcsim.spacecraft.vehicle.authority import torque_signs
from rcsim.spacecraft.vehicle.file_schema import packaged_vehicle
from rcsim.spacecraft.vehicle.mjcf import force_torque

BASE = """
seed = 5
runs_per_case = {runs}
[scenario]
cases = [13, 22]
duration_s = 3.0
[controller]
name = "lookup"
[output]
histories = "none"
plots = false
"""
EXTRAS = """
[dispersions.three_sigma]
cg_y_m = 0.02
cg_z_m = 0.03
ixy_kg_m2 = 30.0
ixz_kg_m2 = 45.0
iyz_kg_m2 = 60.0
"""


def _spec(tmp_path: Path, extra: str = "", *, runs: int = 3, name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(BASE.format(runs=runs) + extra)
    return path


def test_new_keys_leave_the_table5_draws_unchanged(tmp_path):
    """The extras draw from a child of each run's dispersion stream: the same spec with them
    records the same mass, CG x, thrust, tilt and azimuth bit for bit, and the moments as the
    tensor's diagonal to 1e-12 relative (rebuilt from the flown principal moments and frame);
    CG y, z and the products are dispersed, and the products' columns follow the vehicle
    inputs.  The spec resolves the keys as written (the manifest rebuilds the same sigmas)."""
    plain = load_spec(_spec(tmp_path, name="plain.toml"))
    extra = load_spec(_spec(tmp_path, EXTRAS, name="extra.toml"))
    assert extra.sigmas.cg_y_m == pytest.approx(0.02 / 3)
    assert extra.sigmas.products_kg_m2 == pytest.approx((10.0, 15.0, 20.0))
    assert extra.resolved["dispersions"]["three_sigma"]["iyz_kg_m2"] == 60.0
    ids = chunk_mod.Chunk(0, plain.n_runs)
    a = chunk_mod.simulate_chunk(plain, ids).runs
    b = chunk_mod.simulate_chunk(extra, ids).runs
    inputs = list(input_names(16))  # the packaged vehicle's 16 jets
    assert list(b.columns) == list(a.columns[:4]) + inputs + list(PRODUCT_NAMES) + list(
        outcome_names(16)
    )
    inertia = ["ixx_kg_m2", "iyy_kg_m2", "izz_kg_m2"]
    same = [c for c in inputs if c not in inertia + ["cg_y_m", "cg_z_m"]]
    pd.testing.assert_frame_equal(a[same], b[same], check_exact=True)
    np.testing.assert_allclose(b[inertia], a[inertia], rtol=1e-12, atol=0)
    assert (a[["cg_y_m", "cg_z_m"]] == 0.0).all().all()
    assert (b[["cg_y_m", "cg_z_m"]] != 0.0).all().all()
    assert (b[list(PRODUCT_NAMES)].abs() > 0).all().all()
    assert not b["sim_failed"].any()


def test_replay_of_a_run_with_products_matches_its_row(tmp_path):
    """A run with its own principal frame is a function of (spec, run id): the replay matches
    its runs.parquet row exactly, and a resumed spec resolves to the same digest."""
    spec_file = _spec(tmp_path, EXTRAS)
    out = tmp_path / "mc"
    assert main(["campaign", "run", str(spec_file), "--out", str(out), "--no-progress"]) == 0
    for run_id in (1, 4):
        assert replay(out, run_id, tmp_path / f"replay-{run_id}")["matches"] is True


def test_failure_drivers_take_the_new_inputs(tmp_path):
    """``rcsim analyze`` (load_runs) takes the CG y, z and the products as inputs of a campaign
    that dispersed them, beside Table 5's."""
    spec_file = _spec(tmp_path, EXTRAS, runs=6)
    out = tmp_path / "mc"
    assert main(["campaign", "run", str(spec_file), "--out", str(out), "--no-progress"]) == 0
    runset = load_runs(out)
    assert {"cg_y_m", "cg_z_m", *PRODUCT_NAMES, "mass_kg", "ixx_kg_m2"} <= set(runset.raw_inputs)
    assert set(PRODUCT_NAMES) <= set(runset.X.columns)


def _vehicle_file(tmp_path: Path, dispersions: str) -> Path:
    text = packaged_vehicle("paper").read_text()
    head, _, tail = text.partition("[dispersions]")
    assert tail, "the paper vehicle file has a [dispersions] table"
    path = tmp_path / "v.toml"
    path.write_text(head + "[dispersions]\n" + dispersions + "\n" + tail.split("\n", 1)[1])
    return path


def test_a_vehicle_files_extras_are_flown(tmp_path):
    """A vehicle file's [dispersions] may give CG y, z and products (beyond Table 5's rows): a
    campaign on it disperses them, its ranges are the vehicle's."""
    vehicle = _vehicle_file(tmp_path, "cg_y_m = 0.015\nixy_kg_m2 = 24.0")
    spec_file = tmp_path / "with_vehicle.toml"
    spec_file.write_text(f'vehicle = "{vehicle.name}"\n' + BASE.format(runs=2))
    spec = load_spec(spec_file)
    assert spec.sigmas.cg_y_m == pytest.approx(0.005)
    assert spec.sigmas.products_kg_m2 == pytest.approx((8.0, 0.0, 0.0))
    assert spec.sigmas.mass_kg == pytest.approx(73.6 / 3)  # Table 5's rows as the file has them
    runs = chunk_mod.simulate_chunk(spec, chunk_mod.Chunk(0, 2)).runs
    assert set(PRODUCT_NAMES) <= set(runs.columns) and (runs["cg_y_m"] != 0).all()
    # Scaled, the file's own inertia values meet the vehicle's inertia rule (slack 1017.095
    # kg m^2, spread sqrt(241.757^2 + 24^2) = 242.945: scale < 4.187).
    spec_file.write_text(
        f'vehicle = "{vehicle.name}"\n' + BASE.format(runs=2) + "[dispersions]\nscale = 4.19\n"
    )
    with pytest.raises(InputError, match=r"dispersions.scale: must be < 4.187"):
        load_spec(spec_file)


# ------------------------------------------------------------------------- inertia in B --
INERTIA = ["ixx_kg_m2", "iyy_kg_m2", "izz_kg_m2"]
_ENTRIES = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
UNSORTED = """
seed = 9
vehicle = "{vehicle}"
runs_per_case = {runs}
[scenario]
cases = [13]
duration_s = 0.4
[controller]
name = "allocator"
[output]
histories = "none"
plots = false
"""


def test_undispersed_inertia_is_recorded_as_the_files_tensor(tmp_path, unsorted_vehicle):
    """The vehicle's own dispersions but no inertia entry (the reviewer's campaign had no
    product dispersion): every run records ``ixx`` ... ``izz`` and the products (recorded for
    a vehicle with products even when they are not dispersed, so the flown tensor is in the
    table) equal to the tensor the file states, to 1e-9 kg m^2 (the eigen round trip: MuJoCo's
    compiled moments and frame give back the file's entries to ~1e-12).  Before the fix the
    columns held MuJoCo's sorted moments (3590, 3155, 2452 here) and no products."""
    spec_file = tmp_path / "spec.toml"
    zero = "\n".join(f"{k} = 0.0" for k in (*INERTIA, *PRODUCT_NAMES))
    spec_file.write_text(
        UNSORTED.format(vehicle=unsorted_vehicle.path, runs=4)
        + "[dispersions.three_sigma]\n"
        + zero
        + "\n"
    )
    spec = load_spec(spec_file)
    runs = chunk_mod.simulate_chunk(spec, chunk_mod.Chunk(0, 4)).runs
    assert runs["mass_kg"].nunique() == 4  # the rest of the vehicle is dispersed
    for col, (a, b) in zip([*INERTIA, *PRODUCT_NAMES], _ENTRIES):
        np.testing.assert_allclose(runs[col], unsorted_vehicle.tensor_B[a, b], rtol=0, atol=1e-9)


def test_analyze_authority_uses_the_moments_about_the_body_axes(tmp_path, unsorted_vehicle):
    """Only Ixx, Iyy, Izz dispersed (3-sigma 300, 250, 200 kg m^2; thrust, pointing and CG
    nominal): runs.parquet's ``ixx`` ... ``izz`` are the file's diagonal plus sigma z (z the
    run's normals 2..4) to 1e-9 kg m^2, and the authority factors ``rcsim analyze`` takes
    (``load_runs``) are, per axis and sign, the torque of the jets whose torque has that sign
    (the file's jet matrix at nominal thrust) over the recorded moment about that axis, to
    1e-9 relative (MuJoCo's site frames against the file's directions: rounding).  The
    products, recorded but not dispersed, are left out as constant."""
    (tmp_path / "inertia.csv").write_text(
        "name,distribution,three_sigma,unit,source\n"
        "ixx,normal,300,kg*m^2,test\niyy,normal,250,kg*m^2,test\nizz,normal,200,kg*m^2,test\n"
    )
    spec_file = tmp_path / "spec.toml"
    spec_file.write_text(
        UNSORTED.format(vehicle=unsorted_vehicle.path, runs=12)
        + '[dispersions]\ntable = "inertia.csv"\n'
    )
    out = tmp_path / "mc"
    assert main(["campaign", "run", str(spec_file), "--out", str(out), "--no-progress"]) == 0
    runs = pd.read_parquet(out / "runs.parquet")
    definition = load_vehicle(unsorted_vehicle.path)
    z = np.array(
        [
            np.random.default_rng(run_streams(9, i)[0]).standard_normal(
                n_normals(definition.n_jets)
            )[2:5]
            for i in runs["run_id"]
        ]
    )
    expect = np.diag(unsorted_vehicle.tensor_B) + np.array([300.0, 250.0, 200.0]) / 3 * z
    np.testing.assert_allclose(runs[INERTIA], expect, rtol=0, atol=1e-9)

    runset = load_runs(out)
    torque = force_torque(definition)[3:].T  # (n_jets, 3) about the CG [N m]
    signs = torque_signs(definition)
    for a, axis in enumerate(("roll", "pitch", "yaw")):
        for sign, name in ((1, "pos"), (-1, "neg")):
            group = sign * torque[signs[:, a] == sign, a].sum()
            np.testing.assert_allclose(
                runset.X[f"authority_{axis}_{name}_rad_s2"], group / expect[:, a], rtol=1e-9
            )
    assert not set(PRODUCT_NAMES) & set(runset.X.columns)
    assert any("ixy_kg_m2" in note for note in runset.notes)
