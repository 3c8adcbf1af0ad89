"""The simple baseline the KDE analysis is compared with: Welch t-tests, Holm-corrected.

A t-test compares the *means* of an input among failed and successful runs.  It misses a
two-sided driver (hot and cold jets both fail: the failed runs' mean equals the successful
runs') and a pure pair interaction (no single mean moves); ``docs/drivers.md`` shows the
recovery rates beside the KDE's on the planted campaigns of
:mod:`rcsim.analysis.results.drivers.synthetic`.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from rcsim.analysis.results.drivers.base import check_xy
from rcsim.analysis.results.drivers.single import _ranks
from rcsim.analysis.results.proportions import holm_adjusted


class TTestBaseline:
    """Welch t-test of every input, failed vs successful, Holm-adjusted over the inputs.

    Attributes
    ----------
    feature_names_in_ : list of str
    statistic_, p_raw_, p_value_ : ndarray (p,)
        |t|, raw and Holm-adjusted p-values.
    rank_ : ndarray of int (p,)
        1 = largest |t|.
    """

    def fit(self, X, y, strata=None):
        X, y, _, names = check_xy(X, y, strata)
        t, p = stats.ttest_ind(X[y], X[~y], equal_var=False, axis=0)
        t = np.nan_to_num(np.abs(t), nan=0.0)
        p = np.nan_to_num(p, nan=1.0)
        self.feature_names_in_ = names
        self.statistic_, self.p_raw_ = t, p
        self.p_value_ = holm_adjusted(p)
        self.rank_ = _ranks(t)
        return self
