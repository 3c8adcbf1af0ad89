"""Pair drivers: every pair of inputs on a 2-D rank-scale density, and what it adds beyond singles.

Two tests per pair:

* **joint** (``p_joint_``): is the pair distributed differently among failed runs at all?  Its
  2-D TV distance minus the permutation-null mean is the pair's ``score`` (as for singles, see
  :mod:`rcsim.analysis.results.drivers.kde`); p-values are max-T adjusted over *all pairs* (a
  separate family from the singles).  Any pair holding one driver passes it, so it says
  nothing about the pair as such.
* **interaction** (``p_value_``, ``significant_``): does the pair add anything beyond the
  separate effects of its two inputs within the same runs of the same case
  (:mod:`rcsim.analysis.results.drivers.interaction`)?  Every pair is tested with an exact
  conditional p-value, Holm-adjusted over all pairs.  A pair is flagged as an interaction only
  when its joint test also holds (``p_joint_ < joint_level``): a pair whose failed runs do not
  differ at all adds nothing to see (three false interactions in 16 full-size null
  tables all had ``p_joint = 1``).  The gate only removes flags, so the interaction family's
  error stays at most ``alpha``; a pair that passes the joint test alone is not flagged (it
  holds a driver, which the single-factor ranking shows).  (Testing only the pairs that pass the
  joint test was tried: the screen then selects pairs for chance joint patterns when a driver
  is weak pooled, and flagged 4 of 20 tables with two drivers in two different cases.)  Two
  inputs that act in different cases are not an interaction.

``gain = score(a, b) - max(score(a), score(b))``: the separation the pair shows beyond its
better single input, a descriptive effect size (not a test).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.analysis.results.drivers.base import as_rng, check_xy, minority_of
from rcsim.analysis.results.drivers.interaction import interaction_test
from rcsim.analysis.results.drivers.kde import (
    N_BINS_2D,
    BinnedTV,
    Strata,
    bandwidth,
    bin_codes,
    permutation_test,
    rank_scale,
)
from rcsim.analysis.results.drivers.single import SingleFactorKDE, _ranks


class PairKDE:
    """Rank-scale 2-D KDE comparison of failed and successful runs for every pair of inputs.

    Parameters
    ----------
    n_bins : int
        Rank-scale bins per axis (default 16).
    n_permutations : int
        Label permutations of the joint test (default 200; the interaction test is exact).
    alpha : float
        Family-wise level of the interaction test (Holm over all pairs).
    joint_level : float or None
        Level of the joint test's gate (default ``alpha``): an interaction needs
        ``p_joint_ < joint_level`` too.
    random_state : int or numpy.random.Generator

    Attributes
    ----------
    feature_names_in_ : list of str
    pairs_ : ndarray of int (P, 2)
        Column indices ``a < b`` of every pair.
    tv_, null_mean_, score_, p_raw_ : ndarray (P,)
        Joint test: TV, its null mean, the score and the unadjusted p-value.
    p_joint_ : ndarray (P,)
        Joint test, max-T adjusted over all pairs.
    p_interaction_ : ndarray (P,)
        Interaction test: exact conditional p-value, Holm-adjusted over all pairs.
    interaction_excess_ : ndarray (P,)
        Signed interaction z: failed runs with both inputs high beyond the no-interaction
        expectation, in null sd, summed over cases.
    p_value_ : ndarray (P,)
        ``p_interaction_``.
    significant_ : ndarray of bool (P,)
        ``p_value_ < alpha`` and ``p_joint_ < joint_level``: a flagged interaction.
    kind_ : ndarray of str (P,)
        "interaction" (``significant_``) or "".
    gain_ : ndarray (P,)
        ``score_`` minus the better single score of the two inputs.
    rank_ : ndarray of int (P,)
        Interactions first, then the other pairs; by joint score within each group.
    score_rank_ : ndarray of int (P,)
        Rank by joint score alone.
    bandwidth_ : float
    single_score_ : ndarray (p,)
        The single scores the gains were taken against.
    """

    def __init__(
        self, n_bins=N_BINS_2D, n_permutations=200, alpha=0.05, random_state=0, joint_level=None
    ):
        self.n_bins = n_bins
        self.n_permutations = n_permutations
        self.alpha = alpha
        self.random_state = random_state
        self.joint_level = joint_level

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
        self.p_joint_, self.p_raw_ = res.p_maxt, res.p_raw
        self.single_score_ = single_score
        self.gain_ = self.score_ - np.maximum(single_score[ia], single_score[ib])
        self._interactions(X, minority, strata)
        return self

    def _interactions(self, X, minority, strata):
        P = len(self.pairs_)
        it = interaction_test(X, minority, strata, self.pairs_)
        self.p_interaction_ = it.p_holm
        self.interaction_excess_ = it.excess
        self.p_value_ = it.p_holm
        gate = self.alpha if self.joint_level is None else self.joint_level
        self.significant_ = (self.p_value_ < self.alpha) & (self.p_joint_ < gate)
        self.kind_ = np.where(self.significant_, "interaction", "")
        self.score_rank_ = _ranks(self.score_)
        group = np.where(self.significant_, 0, 1)
        order = np.lexsort((self.score_rank_, group))
        self.rank_ = np.empty(P, dtype=int)
        self.rank_[order] = np.arange(1, P + 1)

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
                "significant": self.significant_,
                "kind": self.kind_,
                "p_joint": self.p_joint_,
                "p_interaction": self.p_interaction_,
                "interaction_excess": self.interaction_excess_,
                "tv": self.tv_,
                "tv_null_mean": self.null_mean_,
                "p_raw": self.p_raw_,
            }
        )
        return df.sort_values("rank", kind="stable").reset_index(drop=True)
