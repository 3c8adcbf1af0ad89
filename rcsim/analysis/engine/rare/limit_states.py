"""Analytic limit states in standard-normal space whose failure probability is known: the
oracles of the rare-event tests and of ``benchmarks/rare_event.py``.

Each is a :class:`LimitState` with ``margins(u, ids)`` (the estimators' ``g``), its dimension
and its exact ``probability``:

* :func:`linear` -- ``g = beta - a.u / |a|``: a half-space at distance ``beta``,
  ``P = Phi(-beta)`` (``u`` projected on a unit vector is N(0, 1));
* :func:`series` -- ``g = min(beta - u_1, beta + u_1)``: two half-spaces on opposite sides, two
  failure regions with one design point each, ``P = 2 Phi(-beta)``;
* :func:`parabolic` -- ``g = beta - u_1 + (kappa / 2) sum_{i >= 2} u_i^2``: a curved boundary;
  given ``s = sum_{i >= 2} u_i^2 ~ chi^2_{d-1}``, failure is ``u_1 > beta + kappa s / 2``, so
  ``P = E_s[Phi(-(beta + kappa s / 2))]``, one integral over the chi-square density computed by
  adaptive quadrature (``scipy.integrate.quad``, relative tolerance 1e-10).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate, stats


@dataclass(frozen=True)
class LimitState:
    """An analytic limit state: ``margins(u, ids)``, its dimension and exact probability."""

    name: str
    dim: int
    probability: float
    beta: float
    kind: str
    direction: np.ndarray
    kappa: float = 0.0

    def __call__(self, u: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
        """Margins of points ``u`` (n, dim); ``ids`` unused (the analytic ``g`` has no noise)."""
        u = np.asarray(u, dtype=float)
        if self.kind == "linear":
            return self.beta - u @ self.direction
        if self.kind == "series":
            return np.minimum(self.beta - u[:, 0], self.beta + u[:, 0])
        return self.beta - u[:, 0] + 0.5 * self.kappa * np.sum(u[:, 1:] ** 2, axis=1)


def beta_of(probability: float) -> float:
    """``beta = -Phi^-1(P)``: the reliability index of a probability."""
    return float(-stats.norm.ppf(probability))


def linear(dim: int, probability: float, direction: np.ndarray | None = None) -> LimitState:
    """``g = beta - a.u/|a|`` with ``Phi(-beta) = probability``; ``a`` defaults to all ones
    (every coordinate matters equally)."""
    a = np.ones(dim) if direction is None else np.asarray(direction, dtype=float)
    a = a / np.linalg.norm(a)
    beta = beta_of(probability)
    return LimitState(f"linear d={dim}", dim, float(probability), beta, "linear", a)


def series(dim: int, probability: float) -> LimitState:
    """Two failure regions ``|u_1| > beta``, ``2 Phi(-beta) = probability``."""
    beta = beta_of(probability / 2.0)
    e1 = np.eye(dim)[0]
    return LimitState(f"series d={dim}", dim, float(probability), beta, "series", e1)


def parabolic_probability(dim: int, beta: float, kappa: float) -> float:
    """``E_s[Phi(-(beta + kappa s / 2))]``, ``s ~ chi^2_{dim-1}`` (module docstring)."""
    if dim == 1 or kappa == 0.0:
        return float(stats.norm.sf(beta))
    chi2 = stats.chi2(dim - 1)

    def integrand(s: float) -> float:
        return float(stats.norm.sf(beta + 0.5 * kappa * s) * chi2.pdf(s))

    # The density's bulk lies within its 1e-14 quantiles; quad on that range.
    hi = float(chi2.isf(1e-14))
    value, _ = integrate.quad(integrand, 0.0, hi, epsrel=1e-10, epsabs=0.0, limit=200)
    return float(value)


def parabolic(dim: int, beta: float, kappa: float) -> LimitState:
    """``g = beta - u_1 + (kappa / 2) sum_{i >= 2} u_i^2`` (module docstring)."""
    p = parabolic_probability(dim, beta, kappa)
    e1 = np.eye(dim)[0]
    return LimitState(
        f"parabolic d={dim} kappa={kappa:g}", dim, p, float(beta), "parabolic", e1, kappa
    )


@dataclass(frozen=True)
class CriteriaLimitState:
    """A failure with several criteria: half-spaces along distinct coordinates,
    ``g_i = scale_i (1 - u_{axis_i} / beta_i)``, failing when any does.

    ``margins(u, ids)`` gives the (n, k) criteria's margins (what
    :func:`~rcsim.analysis.engine.rare.series.series_subset_simulation` takes); calling the
    state gives their minimum, the single margin a campaign's ``margin`` column is.  The
    coordinates are independent standard normals, so ``P = 1 - prod_i (1 - Phi(-beta_i))``.
    The scales make a criterion look closer at nominal (``g_i(0) = scale_i``) than its
    probability says: the trap of a single margin (``docs/rare_events.md``, "Several
    criteria").
    """

    name: str
    dim: int
    betas: tuple[float, ...]
    scales: tuple[float, ...]
    axes: tuple[int, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f"c{i}" for i in range(len(self.betas)))

    @property
    def probabilities(self) -> tuple[float, ...]:
        """Each criterion's ``Phi(-beta_i)``."""
        return tuple(float(stats.norm.sf(b)) for b in self.betas)

    @property
    def probability(self) -> float:
        """``1 - prod_i (1 - p_i)``, without cancellation."""
        return float(-np.expm1(np.sum(np.log1p(-np.array(self.probabilities)))))

    def margins(self, u: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
        """(n, k) the criteria's margins of points ``u`` (n, dim)."""
        u = np.asarray(u, dtype=float)
        cols = [s * (1.0 - u[:, a] / b) for s, a, b in zip(self.scales, self.axes, self.betas)]
        return np.stack(cols, axis=1)

    def __call__(self, u: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
        """The single margin ``min_i g_i`` (n,)."""
        return np.min(self.margins(u, ids), axis=1)


def criteria(
    dim: int, betas: tuple[float, ...], scales: tuple[float, ...], name: str = ""
) -> CriteriaLimitState:
    """Criterion ``i`` along coordinate ``i`` (:class:`CriteriaLimitState`)."""
    if len(betas) != len(scales) or not 1 <= len(betas) <= dim:
        raise ValueError(f"betas and scales must have 1 to {dim} equal lengths")
    label = name or (f"{len(betas)} criteria d={dim} beta=" + ",".join(f"{b:g}" for b in betas))
    return CriteriaLimitState(
        label, dim, tuple(map(float, betas)), tuple(map(float, scales)), tuple(range(len(betas)))
    )


def far_criterion(dim: int = 10) -> CriteriaLimitState:
    """``min(0.3 (1 - u_1 / 10), 1 - u_2 / 4.5)``: the criterion closest at nominal (0.3)
    fails at 10 sigma (7.6e-24), the other at 4.5 (3.4e-6) -- what one margin's chains miss."""
    return criteria(dim, (10.0, 4.5), (0.3, 1.0), f"far criterion d={dim}")


def two_criteria(dim: int = 86) -> CriteriaLimitState:
    """``min(0.25 (1 - u_1 / 4.75), 1 - u_2 / 4.26)``: both criteria fail within reach (1.0e-6
    and 1.0e-5), the rarer one closer at nominal."""
    return criteria(dim, (4.75, 4.26), (0.25, 1.0), f"two criteria d={dim}")
