"""A second opinion from another method family: random-forest permutation importance.

The KDE ranking looks at one input (or pair) at a time; a random forest looks at all inputs at
once and can pick up what a marginal view misses (or show that a KDE driver is only a proxy
for a correlated one).  Importance is the drop in held-out ROC AUC when one input is shuffled
(as scikit-learn's ``permutation_importance``, the shuffled copies predicted in a few blocks),
mean and sd over ``n_repeats`` shuffles.  Rows beyond ``max_rows`` are subsampled (stratified
by outcome) to bound the cost.

The forest's ranking is shown beside the KDE's for comparison, never as a flag: no rule on it
is a calibrated test (the earlier rule, "mean - 2 sd > 0", with no correction, marked 3-8 inputs of
every one of 16 full-size null tables as "forest only").
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.ensemble import RandomForestClassifier
from sklearn.metrics import roc_auc_score
from sklearn.model_selection import train_test_split

from rcsim.analysis.results.drivers.base import check_xy
from rcsim.analysis.results.drivers.single import _ranks

#: Largest block of shuffled held-out copies predicted in one call [bytes of float32 inputs].
PREDICT_BLOCK_BYTES = 16 * 2**20


class ForestImportance:
    """Random-forest permutation importance of every input for the failure outcome.

    Parameters
    ----------
    n_estimators : int
    n_repeats : int
        Shuffles per input.
    max_rows : int
        At most this many runs are used (stratified subsample).
    test_size : float
        Held-out share the importance is measured on.
    max_depth : int
        Tree depth limit (bounds the cost of the many held-out predictions).
    random_state : int
    n_jobs : int

    Attributes
    ----------
    feature_names_in_ : list of str
    importance_mean_, importance_sd_ : ndarray (p,)
        Held-out AUC drop.
    rank_ : ndarray of int (p,)
    test_auc_ : float
    """

    def __init__(
        self,
        n_estimators=60,
        n_repeats=3,
        max_rows=4000,
        test_size=0.3,
        max_depth=12,
        random_state=0,
        n_jobs=1,
    ):
        self.n_estimators = n_estimators
        self.n_repeats = n_repeats
        self.max_rows = max_rows
        self.test_size = test_size
        self.random_state = random_state
        self.n_jobs = n_jobs
        self.max_depth = max_depth

    def fit(self, X, y):
        X, y, _, names = check_xy(X, y)
        idx = np.arange(y.size)
        if y.size > self.max_rows:
            idx, _ = train_test_split(
                idx, train_size=int(self.max_rows), stratify=y, random_state=self.random_state
            )
        n_minor = min(int(y[idx].sum()), int((~y[idx]).sum()))
        strat = y[idx] if n_minor >= 2 else None
        tr, te = train_test_split(
            idx, test_size=self.test_size, stratify=strat, random_state=self.random_state
        )
        forest = RandomForestClassifier(
            n_estimators=self.n_estimators,
            min_samples_leaf=3,
            max_depth=self.max_depth,
            class_weight="balanced_subsample",
            random_state=self.random_state,
            n_jobs=self.n_jobs,
        ).fit(X[tr], y[tr])
        self.feature_names_in_ = names
        if y[te].all() or not y[te].any():  # AUC undefined: too few failures to hold out
            self.importance_mean_ = np.full(len(names), np.nan)
            self.importance_sd_ = np.full(len(names), np.nan)
            self.test_auc_ = float("nan")
        else:
            self.test_auc_ = float(roc_auc_score(y[te], forest.predict_proba(X[te])[:, 1]))
            drops = self._auc_drops(forest, X[te], y[te])
            self.importance_mean_, self.importance_sd_ = drops.mean(axis=1), drops.std(axis=1)
        self.rank_ = _ranks(np.nan_to_num(self.importance_mean_, nan=-np.inf))
        return self

    def _auc_drops(self, forest, X, y):
        """AUC drop per input and repeat, shape (p, n_repeats).

        The same quantity as scikit-learn's ``permutation_importance`` with ``roc_auc``, but
        the shuffled copies of the held-out set are predicted a block of inputs at a time, each
        block of at most :data:`PREDICT_BLOCK_BYTES` (one call per copy costs ~10 ms of
        overhead each, 260 calls for 86 inputs; all copies in one call held ~350 MB at once on
        a 26,000-run campaign's 90 inputs).  A forest predicts each row on its own, so the
        blocks change no probability; the shuffles are drawn in the same order (input, then
        repeat) whatever the block size.
        """
        rng = np.random.default_rng(self.random_state)
        n, p = X.shape
        R = int(self.n_repeats)
        # The forest predicts in float32 (scikit-learn's tree dtype): convert once, not per
        # block, with the same rounding scikit-learn's own conversion would do.
        X32 = np.ascontiguousarray(X, dtype=np.float32)
        per_input = R * n * p * X32.itemsize
        block = max(1, min(p, PREDICT_BLOCK_BYTES // max(per_input, 1)))
        prob = np.empty((p, R, n))
        for j0 in range(0, p, block):
            js = range(j0, min(j0 + block, p))
            big = np.repeat(X32[None], len(js) * R, axis=0)  # (inputs x R, n, p)
            for b, j in enumerate(js):
                for r in range(R):
                    big[b * R + r, :, j] = X32[rng.permutation(n), j]
            prob[j0 : js.stop] = forest.predict_proba(big.reshape(-1, p))[:, 1].reshape(
                len(js), R, n
            )
        auc = np.array([[roc_auc_score(y, prob[j, r]) for r in range(R)] for j in range(p)])
        return self.test_auc_ - auc


def compare(kde_table: pd.DataFrame, forest: ForestImportance) -> pd.DataFrame:
    """The forest's ranking beside a KDE ``drivers`` table (no flag: module docstring).

    Returns
    -------
    DataFrame
        ``kde_table`` plus ``forest_importance, forest_importance_sd, forest_rank``.
    """
    f = pd.DataFrame(
        {
            "factor": forest.feature_names_in_,
            "forest_importance": forest.importance_mean_,
            "forest_importance_sd": forest.importance_sd_,
            "forest_rank": forest.rank_,
        }
    )
    return kde_table.merge(f, on="factor", how="left")
