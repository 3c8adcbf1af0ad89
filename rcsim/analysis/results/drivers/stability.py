"""Stability of the rankings: would another campaign of the same size say the same?

The campaign is split at random into two halves ``n_splits`` times (within strata, so every
rate case keeps half its runs); both halves of a split are scored, giving ``2 n_splits``
half-campaigns.  A half's score is its TV minus the full campaign's permutation-null mean scaled
by ``sqrt(2)`` (the null bias of a TV grows about as ``1 / sqrt(n)``, and a half has half the
runs), and its ranking is compared with the full campaign's.

``stability`` of a factor (or pair) of full rank ``r`` is the share of halves that rank it
``r``-th or better -- for the top factor, the share of halves in which it is still first.
Complementary halves reuse the full campaign's counts (half B = all minus half A), so a split
costs one pass over half of the runs.
"""

from __future__ import annotations

import numpy as np

from rcsim.analysis.results.drivers.base import as_rng, check_xy, minority_of
from rcsim.analysis.results.drivers.single import _ranks


class HalfSampleStability:
    """Rank stability of fitted single and pair rankings under half-sampling.

    Parameters
    ----------
    n_splits : int
        Random splits; each gives two halves (default 5, i.e. 10 halves).
    random_state : int or numpy.random.Generator

    Attributes
    ----------
    single_stability_ : ndarray (p,)
        Share of halves ranking each input at least as high as the full campaign.
    single_half_rank_ : ndarray (2 n_splits, p)
    pair_stability_ : ndarray (P,) or None
    pair_half_rank_ : ndarray (2 n_splits, P) or None
    """

    def __init__(self, n_splits=5, random_state=0):
        self.n_splits = n_splits
        self.random_state = random_state

    def fit(self, X, y, singles, pairs=None, strata=None):
        """Score the halves.

        Parameters
        ----------
        X, y, strata : as given to the fitted estimators (their binned counts are reused)
        singles : fitted SingleFactorKDE
        pairs : fitted PairKDE, optional

        Returns
        -------
        self
        """
        X, y, strata, _ = check_xy(X, y, strata)
        if int(self.n_splits) < 1:
            raise ValueError(f"n_splits must be >= 1, got {self.n_splits}")
        rng = as_rng(self.random_state)
        minority = minority_of(y)
        if minority.sum() < 2 or (~minority).sum() < 2:
            raise ValueError("stability needs at least 2 runs of each class")
        # The fitted estimators' own binned counts: the same runs, already binned.
        engines = [(singles.engine_, singles)]
        if pairs is not None:
            engines.append((pairs.engine_, pairs))
        for engine, est in engines:
            if engine.n != y.size:
                raise ValueError(
                    f"{type(est).__name__} was fitted on {engine.n} runs, not these {y.size}"
                )
        halves = [self._split(strata, rng) for _ in range(int(self.n_splits))]
        out = []
        for engine, est in engines:
            ranks = []
            for rows_a in halves:
                pooled_a = engine.counts(rows_a)
                in_a = np.zeros(y.size, bool)
                in_a[rows_a] = True
                for pooled_h, mask in ((pooled_a, in_a), (engine.pooled - pooled_a, ~in_a)):
                    rows_min = np.flatnonzero(minority & mask)
                    n_h = int(mask.sum())
                    if rows_min.size == 0 or rows_min.size == n_h:
                        ranks.append(np.full(engine.n_tests, engine.n_tests))
                        continue
                    tv = engine.tv(rows_min, pooled=pooled_h, n=n_h)
                    ranks.append(_ranks(tv - np.sqrt(2.0) * est.null_mean_))
            half_ranks = np.array(ranks)
            # Halves are ranked by score: compare with the full campaign's rank by score.
            full_rank = getattr(est, "score_rank_", est.rank_)
            out.append((half_ranks, (half_ranks <= full_rank[None]).mean(axis=0)))
        self.single_half_rank_, self.single_stability_ = out[0]
        self.pair_half_rank_: np.ndarray | None = None
        self.pair_stability_: np.ndarray | None = None
        if pairs is not None:
            self.pair_half_rank_, self.pair_stability_ = out[1]
        return self

    @staticmethod
    def _split(strata, rng):
        """Rows of a random half: within each stratum, a random half of its rows."""
        keys = rng.random(strata.size)
        order = np.lexsort((keys, strata))
        _, start, size = np.unique(strata[order], return_index=True, return_counts=True)
        pos = np.arange(order.size) - np.repeat(start, size)
        return np.sort(order[pos < np.repeat(size // 2, size)])
