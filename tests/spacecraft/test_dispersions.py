"""Dispersions: Table 5 statistics, jet-pointing geometry, per-run reproducibility."""

import numpy as np
import pandas as pd
import pytest

from rcsim.models.errors import InputError
from rcsim.models.tables import load_dispersions
from rcsim.spacecraft.dispersions import (
    DispersionSigmas,
    draw_runs,
    pointing,
    run_streams,
    standard_draws,
)
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

N_RUNS = 3000
SEED = 12345
# Tolerance for sample statistics: 4 standard errors.  The draws are fixed by the seed, so the
# test is deterministic; 4 SE would be exceeded by a correct sampler with probability 6e-5 per
# check, while a wrong sigma (e.g. 3-sigma used as sigma: 3x) or a biased mean fails by far.
K_SE = 4.0


@pytest.fixture(scope="module")
def nominal(paper):
    return paper.nominal(1)


@pytest.fixture(scope="module")
def table5():
    return load_dispersions()


@pytest.fixture(scope="module")
def runs(nominal, table5):
    return draw_runs(nominal, DispersionSigmas.from_table(table5), SEED, np.arange(N_RUNS))


def _check_normal(samples, mean, sigma):
    """Sample mean within K_SE * sigma / sqrt(n); sample std within K_SE * sigma / sqrt(2(n-1))
    (standard errors of the mean and of the standard deviation of a normal sample)."""
    n = samples.size
    assert abs(samples.mean() - mean) < K_SE * sigma / np.sqrt(n)
    assert abs(samples.std(ddof=1) - sigma) < K_SE * sigma / np.sqrt(2 * (n - 1))


def _scalar(params: RunParameters, name: str) -> np.ndarray:
    """The per-run value Table 5 row ``name`` disperses."""
    return {
        "mass": params.mass_kg,
        "cg_x": params.cg_B[:, 0],
        "ixx": params.inertia_B[:, 0],
        "iyy": params.inertia_B[:, 1],
        "izz": params.inertia_B[:, 2],
    }[name]


@pytest.mark.parametrize("name", ["mass", "cg_x", "ixx", "iyy", "izz"])
def test_scalar_dispersions_match_table5(runs, nominal, table5, name):
    """Oracle: Table 5 three-sigma (normal), about the Table 1 nominal vehicle."""
    three_sigma = float(table5.loc[table5["name"] == name, "three_sigma"].iloc[0])
    _check_normal(_scalar(runs.params, name), _scalar(nominal, name)[0], three_sigma / 3.0)


def test_thrust_is_dispersed_per_jet_with_table5_sigma(runs, nominal, table5):
    """Oracle: Table 5 thrust 3-sigma 2 N about the nominal 22.24 N, independently per jet."""
    sigma = float(table5.loc[table5["name"] == "thrust", "three_sigma"].iloc[0]) / 3.0
    dev = runs.params.thrust_n - nominal.thrust_n  # (n, 16)
    _check_normal(dev.ravel(), 0.0, sigma)
    for j in range(16):
        _check_normal(dev[:, j], 0.0, sigma)
    # Independent per jet: correlation between two jets within 4 SE (SE = 1/sqrt(n)).
    corr = np.corrcoef(dev[:, 0], dev[:, 1])[0, 1]
    assert abs(corr) < K_SE / np.sqrt(N_RUNS)


def test_thruster_angle_matches_table5_and_geometry(runs, nominal, table5):
    """The angle between each dispersed and nominal jet direction is |tilt| (geometry, 1e-9 rad:
    arccos of a dot product near 1 loses ~1e-8 rad, so compare via the cross-product sine), and
    tilt is normal with Table 5's 5 deg three-sigma."""
    sigma = float(table5.loc[table5["name"] == "thruster_angle", "three_sigma"].iloc[0]) / 3.0
    assert sigma == pytest.approx(np.radians(5.0) / 3.0)
    _check_normal(runs.tilt_rad.ravel(), 0.0, sigma)
    d = runs.params.jet_dir_S
    assert np.allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)
    d0 = nominal.jet_dir_S[0]
    sin_angle = np.linalg.norm(np.cross(d, d0), axis=-1)
    assert np.allclose(sin_angle, np.sin(np.abs(runs.tilt_rad)), atol=1e-12)
    # Uniform azimuth: E[cos phi] = E[sin phi] = 0 with SE 1/sqrt(2 n).
    n = runs.azimuth_rad.size
    for f in (np.cos, np.sin):
        assert abs(f(runs.azimuth_rad).mean()) < K_SE / np.sqrt(2 * n)
    assert runs.azimuth_rad.min() >= 0 and runs.azimuth_rad.max() < 2 * np.pi


def test_pointing_is_the_draws_rule(runs, nominal):
    """The draws point their jets with :func:`pointing` (the rule every read-back uses), bit for
    bit; a zero tilt is the nominal direction."""
    np.testing.assert_array_equal(
        pointing(nominal.jet_dir_S, runs.tilt_rad, runs.azimuth_rad), runs.params.jet_dir_S
    )
    straight = pointing(nominal.jet_dir_S, np.zeros((1, 16)), np.ones((1, 16)))
    np.testing.assert_allclose(straight, nominal.jet_dir_S, rtol=0, atol=1e-15)


def test_draws_depend_only_on_seed_and_run_id(nominal, table5):
    sig = DispersionSigmas.from_table(table5)
    all_runs = draw_runs(nominal, sig, 7, np.arange(10))
    some = draw_runs(nominal, sig, 7, [8, 3, 5])
    for field in ("mass_kg", "cg_B", "inertia_B", "thrust_n", "jet_dir_S"):
        np.testing.assert_array_equal(
            getattr(some.params, field), getattr(all_runs.params, field)[[8, 3, 5]]
        )
    np.testing.assert_array_equal(some.tilt_rad, all_runs.tilt_rad[[8, 3, 5]])
    np.testing.assert_array_equal(some.azimuth_rad, all_runs.azimuth_rad[[8, 3, 5]])
    other_seed = draw_runs(nominal, sig, 8, [3])
    assert other_seed.params.mass_kg[0] != all_runs.params.mass_kg[3]


def test_stream_spawn_order_is_fixed():
    """Dispersions come from the first spawned child of SeedSequence(seed, spawn_key=(i,))."""
    disp, noise = run_streams(5, 9)
    expected = np.random.SeedSequence(5, spawn_key=(9,)).spawn(2)
    assert disp.spawn_key == expected[0].spawn_key and noise.spawn_key == expected[1].spawn_key
    z, u = standard_draws(np.random.default_rng(disp), 16)
    z2, _ = standard_draws(np.random.default_rng(expected[0]), 16)
    assert np.array_equal(z, z2)


def test_a_stream_built_directly_is_the_spawned_child():
    """run_stream(seed, i, k) skips making the parent and its sibling: it must be child k of
    run_streams' spawn, state for state, for seeds up to MAX_SEED and large run ids (every
    campaign's draws and effects come through it)."""
    from rcsim.spacecraft.dispersions import MAX_SEED, run_stream

    for seed in (0, 5, 2**32 + 1, MAX_SEED):
        for run_id in (0, 9, 10**9):
            spawned = run_streams(seed, run_id)
            for k in (0, 1):
                direct = run_stream(seed, run_id, k)
                assert direct.spawn_key == spawned[k].spawn_key
                np.testing.assert_array_equal(
                    direct.generate_state(8, np.uint64), spawned[k].generate_state(8, np.uint64)
                )
    assert run_stream(5, 9, 0).generate_state(4)[0] != run_stream(5, 9, 1).generate_state(4)[0]


def test_scale_multiplies_deviations_exactly(nominal, table5):
    """A 3x stress campaign (Figs 13-14) flies the same runs with 3x the deviations."""
    ids = np.arange(50)
    one = draw_runs(nominal, DispersionSigmas.from_table(table5, 1.0), 1, ids)
    three = draw_runs(nominal, DispersionSigmas.from_table(table5, 3.0), 1, ids)
    for name in ("mass_kg", "inertia_B", "thrust_n"):
        d1 = getattr(one.params, name) - getattr(nominal, name)
        d3 = getattr(three.params, name) - getattr(nominal, name)
        assert np.allclose(d3, 3.0 * d1, rtol=1e-9, atol=1e-12)
    assert np.allclose(three.tilt_rad, 3.0 * one.tilt_rad, rtol=1e-12, atol=0)


def test_zero_sigma_is_nominal_and_one_sigma_does_not_move_the_others(nominal, table5):
    none = draw_runs(nominal, DispersionSigmas(), 4, np.arange(5))
    assert np.array_equal(none.params.mass_kg, np.repeat(nominal.mass_kg, 5))
    assert np.allclose(none.params.jet_dir_S, nominal.jet_dir_S, atol=1e-15)
    full = DispersionSigmas.from_table(table5)
    a = draw_runs(nominal, full, 4, np.arange(5))
    no_thrust = draw_runs(
        nominal,
        DispersionSigmas(
            full.mass_kg, full.cg_x_m, full.inertia_kg_m2, 0.0, full.thruster_angle_rad
        ),
        4,
        np.arange(5),
    )
    assert np.array_equal(a.params.inertia_B, no_thrust.params.inertia_B)
    assert np.array_equal(a.tilt_rad, no_thrust.tilt_rad)
    assert np.array_equal(no_thrust.params.thrust_n, np.repeat(nominal.thrust_n, 5, 0))


def test_from_table_rejects_unknown_names_and_negative_scale(table5):
    extra = pd.concat([table5, pd.DataFrame({"name": ["warp"], "three_sigma": [1.0]})])
    with pytest.raises(InputError, match="warp"):
        DispersionSigmas.from_table(extra)
    with pytest.raises(InputError, match="scale"):
        DispersionSigmas.from_table(table5, -1.0)
