"""Pair drivers: every pair of inputs on a 2-D rank-scale density, and its gain over singles.

A pair's score is its 2-D TV distance minus the permutation-null mean (as for singles, see
:mod:`analysis.results.drivers.kde`); p-values are max-T adjusted over *all pairs tested* (a
separate
family from the singles).  ``gain = score(a, b) - max(score(a), score(b))``: the separation the
pair shows beyond its better single input.  Since TV can only shrink when a density is
marginalised, a pair never separates less than its better input in the population; a large
gain marks an interaction (failures need both inputs), a gain near zero a pair that only
carries one driver.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from analysis.results.drivers.base import as_rng, check_xy, minority_of
from analysis.results.drivers.kde import (
    N_BINS_2D,
    BinnedTV,
    Strata,
    bandwidth,
    bin_codes,
    permutation_test,
    rank_scale,
)
from analysis.results.drivers.single import SingleFactorKDE, _ranks


class PairKDE:
    """Rank-scale 2-D KDE comparison of failed and successful runs for every pair of inputs.

    Parameters
    ----------
    n_bins : int
        Rank-scale bins per axis (default 16).
    n_permutations : int
        Label permutations (default 200).
    random_state : int or numpy.random.Generator

    Attributes
    ----------
    feature_names_in_ : list of str
    pairs_ : ndarray of int (P, 2)
        Column indices ``a < b`` of every pair.
    tv_, null_mean_, score_, p_value_, p_raw_ : ndarray (P,)
    gain_ : ndarray (P,)
        ``score_`` minus the better single score of the two inputs.
    rank_ : ndarray of int (P,)
    bandwidth_ : float
    single_score_ : ndarray (p,)
        The single scores the gains were taken against.
    """

    def __init__(self, n_bins=N_BINS_2D, n_permutations=200, random_state=0):
        self.n_bins = n_bins
        self.n_permutations = n_permutations
        self.random_state = random_state

    def fit(self, X, y, strata=None, single_score=None):
        """Score every pair of columns of ``X`` against ``y`` (True = failed).

        Parameters
        ----------
        X : DataFrame or array-like, (n, p), p >= 2
        y : array-like of bool, (n,)
        strata : array-like, (n,), optional
        single_score : ndarray (p,), optional
            Scores of :class:`SingleFactorKDE` on the same data; computed when not given.

        Returns
        -------
        self
        """
        X, y, strata, names = check_xy(X, y, strata)
        p = X.shape[1]
        if p < 2:
            raise ValueError(f"pairs need at least 2 inputs, got {p}")
        if int(self.n_permutations) < 1:
            raise ValueError(f"n_permutations must be >= 1, got {self.n_permutations}")
        rng = as_rng(self.random_state)
        if single_score is None:
            single_score = (
                SingleFactorKDE(n_permutations=self.n_permutations, random_state=rng)
                .fit(X, y, strata)
                .score_
            )
        single_score = np.asarray(single_score, dtype=float)
        if single_score.shape != (p,):
            raise ValueError(f"single_score must have shape ({p},), got {single_score.shape}")
        minority = minority_of(y)
        ia, ib = np.triu_indices(p, 1)
        self.pairs_ = np.column_stack([ia, ib])
        self.bandwidth_ = bandwidth(int(minority.sum()), 2)
        codes = bin_codes(rank_scale(X), self.n_bins)
        self.engine_ = BinnedTV(codes, self.n_bins, self.pairs_, h=self.bandwidth_)
        res = permutation_test(
            self.engine_, minority, Strata.build(strata, minority), int(self.n_permutations), rng
        )
        self.feature_names_in_ = names
        self.n_features_in_ = p
        self.tv_, self.null_mean_, self.score_ = res.tv, res.null_mean, res.score
        self.p_value_, self.p_raw_ = res.p_maxt, res.p_raw
        self.single_score_ = single_score
        self.gain_ = self.score_ - np.maximum(single_score[ia], single_score[ib])
        self.rank_ = _ranks(self.score_)
        return self

    def table(self) -> pd.DataFrame:
        """One row per pair, best first: the columns of ``pairs.csv``."""
        names = np.asarray(self.feature_names_in_, dtype=object)
        df = pd.DataFrame(
            {
                "factor_a": names[self.pairs_[:, 0]],
                "factor_b": names[self.pairs_[:, 1]],
                "score": self.score_,
                "p_value": self.p_value_,
                "gain": self.gain_,
                "rank": self.rank_,
                "tv": self.tv_,
                "tv_null_mean": self.null_mean_,
                "p_raw": self.p_raw_,
            }
        )
        return df.sort_values("rank", kind="stable").reset_index(drop=True)
