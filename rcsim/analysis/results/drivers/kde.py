"""Binned kernel density estimates on the rank scale and the permutation engine behind them.

Why the rank scale
------------------
Every input is replaced by its probability-integral transform ``u = (rank - 1/2) / n`` (average
ranks for ties), so that units, skew and outliers do not change the comparison: in ``u`` the
pooled sample is uniform on (0, 1) and a density difference between failed and successful runs
is a difference of *where in the distribution* they sit.

Densities
---------
``u`` is binned into ``m`` equal bins (``m = 32`` for one input, ``m = 16`` per axis for a pair)
and the bin counts are smoothed by a Gaussian kernel with reflection at 0 and 1 (so the edges do
not lose mass).  Bandwidth rule: Scott's rule for the uniform pooled scale,
``h = n_s ** (-1 / (d + 4)) / sqrt(12)`` with ``d`` the dimension (1 or 2) and ``n_s`` the size of
the smaller class (failed or successful runs) -- the density that is hardest to estimate sets
the smoothing, and both classes share it so that a difference is never a bandwidth artefact.
The bin width adds to the smoothing; at ``m = 32`` (1-D) it is below ``h`` whenever
``n_s < 2e4``.

Separation score
----------------
Total-variation distance between the failed and successful densities,
``TV = 1/2 sum_cells |P_fail - P_ok|`` (0: same distribution, 1: disjoint).  Finite samples give
``TV > 0`` under no effect, so the reported score is ``TV`` minus its mean under label
permutation (its null bias), which makes singles, pairs and cases comparable.

Permutations
------------
Failure labels are permuted within strata (rate cases), keeping each stratum's failure count.
Only the smaller class's counts are recounted per permutation (``np.bincount`` over its rows);
the other class is the pooled count minus it, so a permutation costs ``n_s x n_tests``
integer operations.  Family-wise error is controlled by Westfall-Young max-T on the
standardised score ``z = (TV - mean) / sd`` (mean and sd over the observed and the ``B``
permuted values, which keeps them exchangeable, see :func:`standardise`): the adjusted p-value of
test ``j`` is ``(1 + #{b : max_k z_kb >= z_j}) / (B + 1)``, which accounts for the number of
tests (and their correlation) without Holm's need for ``B >> n_tests``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.special import ndtr
from scipy.stats import rankdata

#: Bins per axis of the 1-D and 2-D rank-scale histograms.
N_BINS_1D = 32
N_BINS_2D = 16
_SQRT12 = np.sqrt(12.0)


def rank_scale(X: np.ndarray) -> np.ndarray:
    """Probability-integral transform of every column: ``(rank - 1/2) / n``, shape (n, p)."""
    X = np.asarray(X, dtype=float)
    if X.ndim != 2:
        return (rankdata(X, axis=0, method="average") - 0.5) / X.shape[0]
    # Column by column: rankdata over the whole table held ~6 tables of temporaries at once
    # (~300 MB at 10^5 runs x 60 inputs); a column's ranks are its own, so this changes none.
    U = np.empty(X.shape)
    for j in range(X.shape[1]):
        U[:, j] = rankdata(X[:, j], method="average")
    U -= 0.5
    U /= X.shape[0]
    return U


def bin_codes(U: np.ndarray, n_bins: int) -> np.ndarray:
    """Bin index of every rank-scale value, int32 (n, p) in ``0 .. n_bins - 1``."""
    return np.minimum((np.asarray(U) * n_bins).astype(np.int32), n_bins - 1)


def bandwidth(n_small: int, dim: int) -> float:
    """Half Scott's rule on the uniform rank scale (sd ``1/sqrt(12)``), see the module docstring."""
    return 0.5 * float(max(n_small, 1)) ** (-1.0 / (dim + 4)) / _SQRT12


def smoothing_matrix(n_bins: int, h: float) -> np.ndarray:
    """Kernel matrix ``K[i, j]``: share of bin ``j``'s mass a Gaussian of sd ``h`` puts in bin
    ``i``.

    Reflection at 0 and 1 (images at ``-c`` and ``2 - c``) keeps the mass in (0, 1); columns are
    renormalised to sum to one (the images beyond the first miss < 1e-6 of the mass for
    ``h < 0.3``).
    """
    edges = np.linspace(0.0, 1.0, n_bins + 1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    K = np.zeros((n_bins, n_bins))
    for image in (centres, -centres, 2.0 - centres):
        K += ndtr((edges[1:, None] - image[None]) / h) - ndtr((edges[:-1, None] - image[None]) / h)
    return K / K.sum(axis=0, keepdims=True)


#: Strata up to which :meth:`Strata.draw` sorts each stratum on its own (beyond, one lexsort).
_FEW_STRATA = 64


@dataclass
class Strata:
    """Row layout for permuting labels within strata.

    ``order`` sorts rows by stratum; ``start``/``size`` locate each stratum's block in it and
    ``take[s]`` is how many rows of the smaller class stratum ``s`` holds.
    """

    labels: np.ndarray
    start: np.ndarray
    size: np.ndarray
    take: np.ndarray
    # Rows of each stratum (ascending), built on the first per-stratum draw.
    _blocks: list | None = field(default=None, init=False, repr=False, compare=False)

    @classmethod
    def build(cls, strata: np.ndarray, minority: np.ndarray) -> Strata:
        labels, inverse = np.unique(strata, return_inverse=True)
        size = np.bincount(inverse, minlength=labels.size)
        take = np.bincount(inverse, weights=minority.astype(float), minlength=labels.size)
        start = np.concatenate([[0], np.cumsum(size)[:-1]])
        return cls(labels=inverse, start=start, size=size, take=take.astype(int))

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """Rows of one permuted smaller class (each stratum keeps its count)."""
        keys = rng.random(self.labels.size)
        if self.start.size <= _FEW_STRATA:
            return self._draw_per_stratum(keys)
        order = np.lexsort((keys, self.labels))
        # Position of each sorted row inside its stratum block; keep the first take[s].
        pos = np.arange(order.size) - np.repeat(self.start, self.size)
        return order[pos < np.repeat(self.take, self.size)]

    def _draw_per_stratum(self, keys: np.ndarray) -> np.ndarray:
        """What :meth:`draw` returns, the same rows in the same order, by one stable sort per
        stratum instead of a lexsort of all rows (~5x faster for a few dozen strata: the
        permutations of every estimator spend most of their time here)."""
        if self._blocks is None:
            by_stratum = np.argsort(self.labels, kind="stable")  # rows ascending in each block
            self._blocks = [by_stratum[a : a + n] for a, n in zip(self.start, self.size)]
        parts = [
            rows[np.argsort(keys[rows], kind="stable")[:take]]
            for rows, take in zip(self._blocks, self.take)
        ]
        return np.concatenate(parts) if parts else np.empty(0, dtype=np.intp)


@dataclass
class JointStrata:
    """Row layout for permuting *several* label vectors by the same permutation within strata.

    :class:`Strata` draws each test's permuted smaller class on its own.  Analyses of several
    outcomes over the same runs (per axis, a second threshold) need one family-wise correction
    over all of them, and a max-T over them is exact only when every outcome sees the *same*
    permutation of the runs: then the observed statistics of every outcome and each permuted
    copy stay jointly exchangeable.  A draw here is a permutation ``pi`` of the rows within
    each stratum, given by the ``keys`` of one ``rng.random(n)`` call (the rows of a stratum in
    ascending key order are the images of its rows in ascending index order); the permuted
    smaller class is ``pi^-1`` of this outcome's smaller class.  Fits of several outcomes that
    each draw from a Generator with the same seed therefore see the same ``pi``.  For one
    outcome alone a draw is, like :class:`Strata`'s, a uniformly random subset of each
    stratum with its count kept.
    """

    labels: np.ndarray
    blocks: list  # rows of each stratum, ascending
    mask_sorted: np.ndarray  # the smaller class, rows laid out stratum after stratum

    @classmethod
    def build(cls, strata: np.ndarray, minority: np.ndarray) -> JointStrata:
        _, inverse = np.unique(strata, return_inverse=True)
        by_stratum = np.argsort(inverse, kind="stable")
        sizes = np.bincount(inverse)
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        blocks = [by_stratum[a : a + n] for a, n in zip(starts, sizes)]
        return cls(labels=inverse, blocks=blocks, mask_sorted=np.asarray(minority)[by_stratum])

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """Rows of this outcome's smaller class under one permutation within strata."""
        keys = rng.random(self.labels.size)
        order = np.concatenate([r[np.argsort(keys[r], kind="stable")] for r in self.blocks])
        return order[self.mask_sorted]


#: Bytes of flat cell indices one bincount pass of :class:`BinnedTV` may hold.
COUNT_PASS_BYTES = 16 * 2**20


class BinnedTV:
    """Total-variation distances of many single inputs or pairs, for any set of "minority" rows.

    Parameters
    ----------
    codes : ndarray of int32, (n, p)
        Bin codes of the inputs (:func:`bin_codes`).
    n_bins : int
    pairs : ndarray of int, (P, 2), optional
        Column pairs; None scores single columns.
    h : float
        Kernel sd on the rank scale.
    chunk_rows : int, optional
        Rows per bincount pass; default as many as keep a pass's flat cell indices
        (``chunk_rows x n_tests`` int32, and as much again while they are built) within
        :data:`COUNT_PASS_BYTES`, and at most 4096.
    """

    def __init__(self, codes, n_bins, pairs=None, *, h, chunk_rows=None):
        # Test-major layout (p, n): a bincount then writes each test's few cells in turn,
        # which is ~6x faster than row-major scattering over all tests' cells.
        self.codes_T = np.ascontiguousarray(np.asarray(codes, dtype=np.int32).T)
        self.m = int(n_bins)
        self.pairs = None if pairs is None else np.asarray(pairs, dtype=np.intp)
        self.n_tests = self.codes_T.shape[0] if self.pairs is None else self.pairs.shape[0]
        self.cells = self.m if pairs is None else self.m * self.m
        self.K = smoothing_matrix(self.m, h)
        if chunk_rows is None:
            # A campaign's ~90 inputs make ~4,000 pairs: 4096 rows a pass held 120 MB of
            # indices at once; counts are integers, so the pass size changes no result.
            chunk_rows = min(4096, max(64, COUNT_PASS_BYTES // (4 * self.n_tests)))
        self.chunk_rows = int(chunk_rows)
        self._offsets = (np.arange(self.n_tests, dtype=np.int32) * self.cells)[:, None]
        self.n = self.codes_T.shape[1]
        self.pooled = self.counts(np.arange(self.n))

    def _flat(self, rows: np.ndarray) -> np.ndarray:
        c = self.codes_T[:, rows]
        if self.pairs is None:
            return c + self._offsets
        flat = c[self.pairs[:, 0]] * np.int32(self.m)
        flat += c[self.pairs[:, 1]]
        flat += self._offsets
        return flat

    def counts(self, rows: np.ndarray) -> np.ndarray:
        """Cell counts of ``rows``, shape (n_tests, m) or (n_tests, m, m)."""
        size = self.n_tests * self.cells
        rows = np.sort(rows)  # sorted rows gather from codes_T with fewer cache misses
        total = None
        for s in range(0, max(rows.size, 1), self.chunk_rows):
            part = np.bincount(self._flat(rows[s : s + self.chunk_rows]).ravel(), minlength=size)
            total = part if total is None else total + part
        shape = (self.n_tests, self.m) if self.pairs is None else (self.n_tests, self.m, self.m)
        assert total is not None  # at least one chunk of rows
        return total.reshape(shape)

    def smooth(self, C: np.ndarray) -> np.ndarray:
        """Kernel-smoothed counts (mass preserving)."""
        if self.pairs is None:
            return C @ self.K.T
        return self.K @ C @ self.K.T

    def tv(self, rows: np.ndarray, pooled: np.ndarray | None = None, n: int | None = None):
        """TV distance between the rows' density and the rest's, per test, shape (n_tests,)."""
        pooled = self.pooled if pooled is None else pooled
        n = self.n if n is None else n
        k = rows.size
        Cm = self.counts(rows).astype(float)
        # smooth(Cm)/k - smooth(pooled - Cm)/(n - k) in one smoothing (it is linear).
        D = self.smooth(Cm * (1.0 / k + 1.0 / (n - k)) - pooled / (n - k))
        return 0.5 * np.abs(D).reshape(self.n_tests, -1).sum(axis=1)


@dataclass
class PermutationResult:
    """Observed TV, its permutation null and the corrected p-values, per test."""

    tv: np.ndarray
    null_mean: np.ndarray
    null_sd: np.ndarray
    p_raw: np.ndarray
    p_maxt: np.ndarray
    null_tv: np.ndarray  # (B, n_tests)
    z: np.ndarray  # (n_tests,) standardised observed statistic
    null_max_z: np.ndarray  # (B,) largest standardised null statistic of each permutation

    @property
    def score(self) -> np.ndarray:
        return self.tv - self.null_mean


def permutation_test(
    engine: BinnedTV,
    minority: np.ndarray,
    strata: Strata | JointStrata,
    n_permutations: int,
    rng: np.random.Generator,
) -> PermutationResult:
    """Observed TV of the smaller class against the rest, with a stratified permutation null."""
    rows = np.flatnonzero(minority)
    tv = engine.tv(rows)
    null = np.empty((n_permutations, engine.n_tests))
    for b in range(n_permutations):
        null[b] = engine.tv(strata.draw(rng))
    mean = null.mean(axis=0)
    sd = null.std(axis=0, ddof=1) if n_permutations > 1 else np.ones_like(mean)
    sd = np.where(sd > 0, sd, np.inf)  # a constant statistic can never be significant
    z_obs, max_null = standardise(tv, null)
    # Small tolerance: equal statistics (e.g. duplicated columns) count as ">=".
    p_raw = (1.0 + (null >= tv - 1e-12).sum(axis=0)) / (n_permutations + 1.0)
    p_maxt = maxt_p(z_obs, max_null)
    return PermutationResult(
        tv=tv,
        null_mean=mean,
        null_sd=sd,
        p_raw=p_raw,
        p_maxt=p_maxt,
        null_tv=null,
        z=z_obs,
        null_max_z=max_null,
    )


def standardise(obs: np.ndarray, null: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standardised observed statistics and the per-draw maximum of the standardised null.

    The mean and sd of each test are taken over the ``B + 1`` values *including the observed
    one*, so that under the null the observed vector and the ``B`` permuted ones stay
    exchangeable and the max-T p-value is exact.  Standardising by the ``B`` null values alone
    (the observed value out of sample) made the test anti-conservative: the tests whose null sd
    happens to be underestimated dominate the observed maximum but not the null maxima
    (``benchmarks/null_calibration.py`` measures the false-flag rate; ``docs/drivers.md``).

    Returns
    -------
    z_obs : ndarray (n_tests,)
    max_null : ndarray (B,)
        ``max_k z_kb`` (``-inf`` with no tests).
    """
    allv = np.vstack([obs[None], null])
    mean = allv.mean(axis=0)
    sd = allv.std(axis=0, ddof=1) if allv.shape[0] > 1 else np.ones_like(mean)
    sd = np.where(sd > 0, sd, np.inf)  # a constant statistic can never be significant
    z_obs = (obs - mean) / sd
    if obs.size == 0:
        return z_obs, np.full(null.shape[0], -np.inf)
    return z_obs, ((null - mean) / sd).max(axis=1)


def maxt_p(z_obs: np.ndarray, max_null: np.ndarray) -> np.ndarray:
    """Westfall-Young max-T adjusted p-values: ``(1 + #{b : max_null_b >= z_j}) / (B + 1)``."""
    B = max_null.size
    srt = np.sort(max_null)
    # count of max_null >= z - tol (ties count as exceeding: conservative)
    ge = B - np.searchsorted(srt, z_obs - 1e-12, side="left")
    return (1.0 + ge) / (B + 1.0)
