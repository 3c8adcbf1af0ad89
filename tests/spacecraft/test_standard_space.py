"""A run's dispersions as a standard-normal vector u (rcsim.spacecraft.standard_space).

Oracles: the seeded draws themselves (rcsim.spacecraft.dispersions.draw_runs, unchanged): the
vehicles flown from a run's exposed u must be its seeded vehicles bit for bit; the 53-bit grid
of Generator.random (a uniform is k 2^-53); Phi(w) for the law of the uniforms a normal maps to
(a uniform's cell must hold Phi(w): scipy's ndtr to 1e-15 in the tails); the decimal module for
1/sqrt(2 pi).
"""

from decimal import Decimal, localcontext

import numpy as np
import pytest
from scipy import stats
from scipy.special import ndtr

from rcsim.models.tables import load_dispersions
from rcsim.spacecraft import standard_space as ss
from rcsim.spacecraft.dispersions import DispersionSigmas, draw_runs, n_normals
from rcsim.spacecraft.vehicle import Vehicle

GRID = 2.0**53


def _uniforms(n, seed, lo=0.0, hi=1.0):
    """Uniforms of the generator's grid in [lo, hi)."""
    x = np.random.default_rng(np.random.SeedSequence(seed)).random(n)
    return np.floor((lo + (hi - lo) * x) * GRID) / GRID


EDGES = np.array([0, 1, 2, 3, 2**52 - 1, 2**52, 2**52 + 1, 2**53 - 2, 2**53 - 1]) / GRID


def test_the_constant_is_one_over_sqrt_two_pi_to_thirty_digits():
    with localcontext() as ctx:
        ctx.prec = 40
        # phi(0) = 1/sqrt(2 pi) to 40 digits, the normal density's peak as tabulated.
        expected = Decimal("0.3989422804014326779399460599343818684759")
        got = Decimal(ss._C_HI) + Decimal(ss._C_LO)
        assert abs(got - expected) < Decimal("1e-32")


def test_the_double_double_cdf_is_the_normal_cdf():
    # Against scipy's ndtr, good to a few 1e-16 relative where Phi is not small: the series
    # must agree to that (a wrong term or constant shows at 1e-10 or worse).
    a = np.linspace(-3.0, 0.0, 3001)
    hi, lo = ss._phi_series(a)
    assert np.max(np.abs(hi - ndtr(a)) / ndtr(a)) < 3e-15
    assert hi[-1] == 0.5 and lo[-1] == 0.0


@pytest.mark.parametrize(
    "uniforms",
    [
        _uniforms(20_000, 1),
        # Where float ndtr leaves cells unreachable (Phi in 0.05-0.18 and its mirror).
        _uniforms(10_000, 2, 0.05, 0.18),
        _uniforms(10_000, 3, 0.82, 0.95),
        EDGES,
    ],
    ids=["random", "low body", "high body", "edges"],
)
def test_a_uniforms_normal_score_maps_back_to_it_exactly(uniforms):
    w = ss.normal_score(uniforms)
    assert np.all(np.isfinite(w)) and np.all(w != 0)
    assert np.array_equal(ss.uniform_of_normal(w), uniforms)
    # The score is the quantile of the cell's midpoint, to float precision.
    mid = (np.floor(uniforms * GRID) + 0.5) / GRID
    assert np.allclose(ndtr(w), mid, rtol=1e-14, atol=1e-18)


def test_float_cdf_cells_would_not_do():
    # The guard of the double-double: with scipy's float ndtr, some of these cells are lost
    # (measured: 20 % of these uniforms), so the test above can fail.
    u = _uniforms(10_000, 2, 0.05, 0.18)
    w = ss.normal_score(u)
    naive = np.floor(ndtr(w) * GRID) / GRID
    assert np.sum(naive != u) > 50


def test_normals_map_to_the_generators_uniform_law():
    w = np.random.default_rng(np.random.SeedSequence(4)).standard_normal(50_000)
    u = ss.uniform_of_normal(w)
    assert np.all((u >= 0) & (u < 1)) and np.array_equal(u * GRID, np.floor(u * GRID))
    # Kolmogorov-Smirnov against U(0, 1): a correct map fails at 0.001 one time in a thousand.
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    # Monotone: larger normals never give smaller uniforms.
    order = np.argsort(w)
    assert np.all(np.diff(u[order]) >= 0)
    # Each uniform's cell holds Phi(w) (float ndtr, within its 1e-15 relative accuracy).
    assert np.all(np.abs(u + 0.5 / GRID - ndtr(w)) <= 0.5 / GRID + 1e-15 * ndtr(w) + 1e-18)


def test_off_grid_values_are_not_uniforms():
    with pytest.raises(ValueError, match="uniforms of Generator.random"):
        ss.normal_score(np.array([0.1 + 1e-17, 0.5]))
    with pytest.raises(ValueError):
        ss.normal_score(np.array([1.0]))


def _same_vehicles(a, b):
    for name in ("mass_kg", "cg_B", "inertia_B", "thrust_n", "jet_dir_S"):
        assert np.array_equal(getattr(a.params, name), getattr(b.params, name)), name
    assert (a.params.iquat is None) == (b.params.iquat is None)
    if a.params.iquat is not None:
        assert np.array_equal(a.params.iquat, b.params.iquat)
    assert np.array_equal(a.tilt_rad, b.tilt_rad)
    assert np.array_equal(a.azimuth_rad, b.azimuth_rad)
    assert np.array_equal(a.run_ids, b.run_ids)


@pytest.mark.parametrize("extras", [False, True], ids=["Table 5 x3", "with CG y, z and products"])
def test_runs_flown_from_their_u_are_their_seeded_runs_bit_for_bit(extras):
    nominal = Vehicle.load().nominal(1)  # the paper's
    sigmas = DispersionSigmas.from_table(load_dispersions(), scale=3.0)
    if extras:
        sigmas = DispersionSigmas(
            **{
                **sigmas.__dict__,
                "cg_y_m": 0.02 / 3,
                "cg_z_m": 0.03 / 3,
                "products_kg_m2": (30.0, 45.0, 60.0),
            }
        )
    run_ids = np.arange(7_000, 9_000)
    u = ss.run_standard_normals(2024, run_ids, 16, sigmas.has_mass_extras)
    assert u.shape == (2_000, ss.n_standard(16, extras)) == (2_000, 53 + 5 * extras)
    _same_vehicles(
        ss.vehicles_from_standard(nominal, sigmas, u, run_ids),
        draw_runs(nominal, sigmas, 2024, run_ids),
    )


def test_u_holds_the_drawn_normals_as_drawn():
    run_ids = np.array([0, 5, 12345])
    u = ss.run_standard_normals(7, run_ids, 16, False)
    for row, i in zip(u, run_ids):
        rng = np.random.default_rng(np.random.SeedSequence(7, spawn_key=(int(i), 0)))
        assert np.array_equal(row[: n_normals(16)], rng.standard_normal(n_normals(16)))
        assert np.array_equal(ss.uniform_of_normal(row[n_normals(16) :]), rng.random(16))


def test_names_and_active_coordinates():
    names = ss.standard_names(16, True)
    assert len(names) == ss.n_standard(16, True) == 58
    assert names[:6] == ["mass", "cg_x", "ixx", "iyy", "izz", "thrust_01"]
    assert names[21] == "tilt_01" and names[37] == "azimuth_01" and names[-1] == "iyz"
    only_thrust = DispersionSigmas(thrust_n=1.0)
    active = ss.active_coordinates(only_thrust, 16)
    assert active.shape == (53,)
    assert [n for n, a in zip(ss.standard_names(16, False), active) if a] == [
        f"thrust_{j:02d}" for j in range(1, 17)
    ]


def test_a_u_of_the_wrong_width_is_refused():
    with pytest.raises(ValueError, match="does not fit a vehicle of 16 jets"):
        ss.draws_from_standard(np.zeros((2, 52)), 16, False)
