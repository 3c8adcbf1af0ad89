"""The analytic limit states are what they claim (rcsim.analysis.engine.rare.limit_states).

Oracles: Phi(-beta) for a half-space; for the parabolic boundary in two dimensions, the
failure probability by a second, independent route (the integral over u_2 of
Phi(-(beta + kappa u_2^2 / 2)) phi(u_2), by Gauss-Hermite quadrature of 200 nodes, exact to
~1e-12 for this smooth integrand); plain Monte Carlo where P is not small.
"""

import numpy as np
import pytest
from scipy import stats

from rcsim.analysis.engine.rare import limit_states


@pytest.mark.parametrize("p", [1e-3, 1e-5, 1e-6])
def test_linear_beta_gives_its_probability(p):
    limit = limit_states.linear(86, p)
    assert stats.norm.sf(limit.beta) == pytest.approx(p, rel=1e-12)
    # The margin along the direction is beta - t: a point at t = beta sits on the boundary.
    assert limit(limit.beta * limit.direction[None]) == pytest.approx(0.0, abs=1e-12)


def test_series_has_two_regions_of_half_the_probability_each():
    limit = limit_states.series(10, 1e-5)
    assert 2 * stats.norm.sf(limit.beta) == pytest.approx(1e-5, rel=1e-12)
    e1 = np.eye(10)[0]
    assert limit(np.stack([1.01 * limit.beta * e1, -1.01 * limit.beta * e1])).max() < 0


@pytest.mark.parametrize("kappa", [-0.3, 0.2])
def test_parabolic_probability_by_a_second_route_in_two_dimensions(kappa):
    x, w = np.polynomial.hermite_e.hermegauss(200)  # weight exp(-x^2 / 2)
    beta = 2.5
    direct = float(np.sum(w * stats.norm.sf(beta + 0.5 * kappa * x**2)) / np.sqrt(2 * np.pi))
    assert limit_states.parabolic_probability(2, beta, kappa) == pytest.approx(direct, rel=1e-9)


def test_parabolic_probability_against_plain_monte_carlo_in_ten_dimensions():
    # P ~ 2e-2 (beta 2.5, kappa -0.1 in d = 10): 2e5 draws give a binomial sd of 1.5 %; the
    # tolerance is 5 sds.
    limit = limit_states.parabolic(10, 2.5, -0.1)
    u = np.random.default_rng(np.random.SeedSequence(1)).standard_normal((200_000, 10))
    p_mc = float(np.mean(limit(u) < 0))
    sd = np.sqrt(limit.probability * (1 - limit.probability) / u.shape[0])
    assert abs(p_mc - limit.probability) < 5 * sd
