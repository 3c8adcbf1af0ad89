"""A run's dispersions as one vector ``u`` of independent standard normals, and back: what a
rare-event estimator moves in, exposed from the draws campaigns already make.

The vector
----------
Run ``i`` of a campaign draws from its dispersion stream (:mod:`rcsim.spacecraft.dispersions`,
"Reproducibility"), in this order: :func:`~rcsim.spacecraft.dispersions.n_normals` standard
normals (mass, CG x, Ixx, Iyy, Izz, then a thrust and a tilt normal per jet), then one uniform
per jet (the tilt azimuths); and, when a campaign disperses CG y or z or a product of inertia,
five normals from the mass-extras child stream (cg_y, cg_z, ixy, ixz, iyz).  Its ``u``
(:func:`run_standard_normals`) is those normals as drawn, the azimuth uniforms' normal scores,
then the mass extras' normals (:func:`standard_names`): ``5 + 3 n_jets`` coordinates (53 for the
paper's 16 jets), ``+ 5`` with the extras.  Everything the noise stream draws -- sensor noise
and biases, valve delays, jet faults (:mod:`rcsim.spacecraft.effect_draws`) -- is *not* in
``u``: a rare-event estimator treats it as a random nuisance (``docs/rare_events.md``).

Uniforms and their normal scores, exactly
-----------------------------------------
A uniform from ``Generator.random`` is ``k 2^-53`` for a whole ``k`` in ``[0, 2^53)``: cell ``k``
of the 53-bit grid.  A normal ``w`` maps back to the cell holding ``Phi(w)``
(:func:`uniform_of_normal`; mirrored, ``1 - Phi(-w)``, above 1/2, so both tails keep their
precision), which for ``w ~ N(0, 1)`` is exactly the generator's law: the iso-probabilistic
transform a Markov chain's new points fly through.  The score of a drawn uniform
(:func:`normal_score`) is the float ``w`` nearest ``Phi^-1`` of its cell's midpoint.  That maps
back to the same cell: ``|Phi(w) - mid| <= ulp(w) phi(w) / 2 <= 2^-53 max(|w| phi(w)) <
2^-55``, a quarter of a cell, so any ``Phi`` computed to better than another quarter cell finds
it.  scipy's ``ndtr`` is that accurate in the tails (``|w| >= 3``, ``Phi < 1.4e-3``: relative
1e-15), not in the body, where rounding leaves 0.6 % of cells unreachable; there ``Phi`` is
summed in double-double arithmetic (its Taylor series, ~30 digits).  So a campaign run flown
from its exposed ``u`` is its seeded flight bit for bit
(``tests/spacecraft/test_standard_space.py``), and ``dispersions.draw_runs`` is unchanged.
"""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np
from scipy.special import ndtr, ndtri

from rcsim.spacecraft.dispersions import (
    N_MASS_EXTRAS,
    DispersedRuns,
    DispersionSigmas,
    apply_draws,
    mass_extra_draws,
    n_normals,
    n_uniforms,
    run_stream,
    standard_draws,
)
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

_GRID = 2.0**53  # cells of Generator.random
_HALF = 2.0**52  # cells below 1/2
#: Below this |w|, Phi is summed in double-double; beyond it scipy's ndtr is accurate enough.
_SERIES_LIMIT = 3.0
_SERIES_TERMS = 64  # 3 * 4.5^64 / 64! < 1e-40: the series' tail at |w| = 3
#: The series stops once its terms are below this: 1e-25 absolute is 1e-8 of the quarter cell
#: (2^-55 = 2.8e-17) the exactness needs, and a term only shrinks from there (n > a^2 / 2).
_SERIES_TOL = 1e-25
_SPLIT = 134217729.0  # 2^27 + 1 (Dekker)


def _inv_sqrt_2pi() -> tuple[float, float]:
    """``1 / sqrt(2 pi)`` as a double-double, from 40-digit decimal arithmetic (the decimal
    module's documented series for pi)."""
    with localcontext() as ctx:
        ctx.prec = 45
        three = Decimal(3)
        lasts, t, s, n, na, d, da = Decimal(0), three, three, 1, 0, 0, 24
        while s != lasts:
            lasts = s
            n, na = n + na, na + 8
            d, da = d + da, da + 32
            t = (t * n) / d
            s += t
        value = 1 / (2 * s).sqrt()
        hi = float(value)
        return hi, float(value - Decimal(hi))


_C_HI, _C_LO = _inv_sqrt_2pi()


def _two_sum(a, b):
    s = a + b
    v = s - a
    return s, (a - (s - v)) + (b - v)


def _fast_two_sum(a, b):
    s = a + b
    return s, b - (s - a)


def _two_prod(a, b):
    p = a * b
    t = _SPLIT * a
    ah = t - (t - a)
    al = a - ah
    t = _SPLIT * b
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _dd_add(ah, al, bh, bl):
    s, e = _two_sum(ah, bh)
    return _fast_two_sum(s, e + al + bl)


def _dd_mul(ah, al, bh, bl):
    p, e = _two_prod(ah, bh)
    return _fast_two_sum(p, e + ah * bl + al * bh)


def _dd_div(ah, al, b):
    q = ah / b
    p, e = _two_prod(q, b)
    s, f = _two_sum(ah, -p)
    return _fast_two_sum(q, (s + (f - e + al)) / b)


def _phi_series(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Phi(a)`` as a double-double ``(hi, lo)`` for ``|a| < 3``:
    ``1/2 + (1 / sqrt(2 pi)) sum_n (-1)^n a^(2n+1) / (2^n n! (2n+1))``."""
    a = np.asarray(a, dtype=float)
    a2h, a2l = _two_prod(a, a)
    th, tl = a.copy(), np.zeros_like(a)  # a^(2n+1) / (2^n n!)
    sh, sl = a.copy(), np.zeros_like(a)
    for n in range(1, _SERIES_TERMS):
        ph, pl = _dd_mul(th, tl, a2h, a2l)
        th, tl = _dd_div(ph, pl, 2.0 * n)
        qh, ql = _dd_div(th, tl, 2.0 * n + 1.0)
        sign = -1.0 if n % 2 else 1.0
        sh, sl = _dd_add(sh, sl, sign * qh, sign * ql)
        if n > 5 and float(np.max(np.abs(qh), initial=0.0)) < _SERIES_TOL:
            break
    ph, pl = _dd_mul(sh, sl, _C_HI, _C_LO)
    return _dd_add(0.5, 0.0, ph, pl)


def _lower_cell(a: np.ndarray) -> np.ndarray:
    """The cell ``floor(Phi(a) 2^53)`` of points ``a <= 0``, as floats (module docstring)."""
    a = np.asarray(a, dtype=float)
    body = np.abs(a) < _SERIES_LIMIT
    cell = np.floor(ndtr(a) * _GRID)
    if body.any():
        hi, lo = _phi_series(a[body])
        hi, lo = hi * _GRID, lo * _GRID  # exact scaling
        f = np.floor(hi)
        cell[body] = np.where((f == hi) & (lo < 0.0), f - 1.0, f)
    return np.clip(cell, 0.0, _HALF - 1.0)


def uniform_of_normal(w) -> np.ndarray:
    """The 53-bit uniforms whose cells hold ``Phi(w)`` (module docstring); same shape as ``w``.
    For ``w ~ N(0, 1)`` they are distributed as ``Generator.random``'s draws."""
    w = np.asarray(w, dtype=float)
    m = _lower_cell(-np.abs(w))
    return np.where(w > 0.0, _GRID - 1.0 - m, m) / _GRID


def normal_score(uniform) -> np.ndarray:
    """The normal scores of uniforms on the 53-bit grid: the float nearest ``Phi^-1`` of each
    cell's midpoint (one Newton step from scipy's ``ndtri`` with ``Phi`` in double-double:
    nearest up to the step's own rounding, and within an ulp in any case, which the exactness
    argument allows), never 0, never infinite; :func:`uniform_of_normal` maps it back to the
    uniform exactly (module docstring).

    Raises
    ------
    ValueError
        A value is not a uniform of ``Generator.random`` (off the grid or outside [0, 1)).
    """
    x = np.asarray(uniform, dtype=float)
    k = x * _GRID
    if not (np.all((x >= 0.0) & (x < 1.0)) and np.all(k == np.floor(k))):
        raise ValueError("normal_score takes uniforms of Generator.random (k 2^-53, 0 <= k < 2^53)")
    upper = k >= _HALF
    m = np.where(upper, _GRID - 1.0 - k, k)
    mid = (m + 0.5) / _GRID  # exact: below 1/2 the grid has room for half cells
    a = ndtri(mid)
    # One Newton step from scipy's ndtri to the nearest float of the true quantile.
    body = np.abs(a) < _SERIES_LIMIT
    err = ndtr(a) - mid
    if body.any():
        hi, lo = _phi_series(a[body])
        err[body] = _dd_add(hi, lo, -mid[body], 0.0)[0]
    a = a - err / (np.exp(-0.5 * a * a) * _C_HI)
    for _ in range(4):  # the proof says none is needed; guard the arithmetic anyway
        cell = _lower_cell(a)
        if np.array_equal(cell, m):
            break
        a = np.where(
            cell < m, np.nextafter(a, np.inf), np.where(cell > m, np.nextafter(a, -np.inf), a)
        )
    else:
        raise AssertionError("normal_score: a uniform's score does not map back to it")
    return np.where(upper, -a, a)


def n_standard(n_jets: int, mass_extras: bool) -> int:
    """Coordinates of a run's ``u``: ``n_normals + n_uniforms (+ N_MASS_EXTRAS)``."""
    return n_normals(n_jets) + n_uniforms(n_jets) + (N_MASS_EXTRAS if mass_extras else 0)


def standard_names(n_jets: int, mass_extras: bool) -> list[str]:
    """Names of ``u``'s coordinates in order: ``mass, cg_x, ixx, iyy, izz, thrust_01 ..,
    tilt_01 .., azimuth_01 ..`` and, with the extras, ``cg_y, cg_z, ixy, ixz, iyz``."""
    jets = [f"{j:02d}" for j in range(1, n_jets + 1)]
    names = ["mass", "cg_x", "ixx", "iyy", "izz"]
    names += [f"thrust_{j}" for j in jets] + [f"tilt_{j}" for j in jets]
    names += [f"azimuth_{j}" for j in jets]
    if mass_extras:
        names += ["cg_y", "cg_z", "ixy", "ixz", "iyz"]
    return names


def active_coordinates(sigmas: DispersionSigmas, n_jets: int) -> np.ndarray:
    """Which coordinates of ``u`` change the vehicle (bool, ``n_standard``): those whose sigma
    is not 0 (an azimuth matters only when the tilt is dispersed)."""
    jet = np.ones(n_jets, bool)
    active = [
        sigmas.mass_kg > 0,
        sigmas.cg_x_m > 0,
        *(s > 0 for s in sigmas.inertia_kg_m2),
        *(jet * (sigmas.thrust_n > 0)),
        *(jet * (sigmas.thruster_angle_rad > 0)),
        *(jet * (sigmas.thruster_angle_rad > 0)),
    ]
    if sigmas.has_mass_extras:
        active += [sigmas.cg_y_m > 0, sigmas.cg_z_m > 0, *(s > 0 for s in sigmas.products_kg_m2)]
    return np.array(active, dtype=bool)


def run_standard_normals(seed: int, run_ids, n_jets: int, mass_extras: bool) -> np.ndarray:
    """The ``u`` of campaign runs ``run_ids`` (n, :func:`n_standard`): the standard variates
    their dispersion streams draw, the uniforms as their normal scores (module docstring)."""
    run_ids = np.asarray(run_ids, dtype=np.int64).reshape(-1)
    z = np.empty((run_ids.size, n_normals(n_jets)))
    uniforms = np.empty((run_ids.size, n_uniforms(n_jets)))
    for k, i in enumerate(run_ids):
        z[k], uniforms[k] = standard_draws(np.random.default_rng(run_stream(seed, i, 0)), n_jets)
    parts = [z, normal_score(uniforms)]
    if mass_extras:
        parts.append(mass_extra_draws(seed, run_ids))
    return np.concatenate(parts, axis=1)


def draws_from_standard(
    u: np.ndarray, n_jets: int, mass_extras: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Split ``u`` (n, :func:`n_standard`) into :func:`~rcsim.spacecraft.dispersions.apply_draws`'
    ``(z, uniforms, x)`` (``x`` None without the extras)."""
    u = np.asarray(u, dtype=float)
    if u.ndim != 2 or u.shape[1] != n_standard(n_jets, mass_extras):
        raise ValueError(
            f"u of shape {u.shape} does not fit a vehicle of {n_jets} jets "
            f"({n_standard(n_jets, mass_extras)} coordinates per run)"
        )
    a, b = n_normals(n_jets), n_normals(n_jets) + n_uniforms(n_jets)
    x = u[:, b:].copy() if mass_extras else None
    return u[:, :a].copy(), uniform_of_normal(u[:, a:b]), x


def vehicles_from_standard(
    nominal: RunParameters, sigmas: DispersionSigmas, u: np.ndarray, run_ids=None
) -> DispersedRuns:
    """The dispersed vehicles of points ``u`` (n, :func:`n_standard` with the extras when
    ``sigmas.has_mass_extras``), through the same
    :func:`~rcsim.spacecraft.dispersions.apply_draws` as the seeded draws; ``run_ids`` label
    them (default ``0 .. n-1``)."""
    z, uniforms, x = draws_from_standard(u, nominal.n_jets, sigmas.has_mass_extras)
    params, tilt, azimuth = apply_draws(nominal, sigmas, z, uniforms, x)
    ids = np.arange(z.shape[0]) if run_ids is None else np.asarray(run_ids, np.int64)
    return DispersedRuns(run_ids=ids, params=params, tilt_rad=tilt, azimuth_rad=azimuth)
