"""k-nearest-neighbour failure-probability maps over a pair of inputs (Gambone Fig. 15).

The two inputs are put on the rank scale (so neither dominates the distance by its units),
``P(fail)`` at a point is the failed share of its ``k`` nearest runs, and ``k`` is chosen by
leave-one-out cross-validation of the Brier score over :attr:`KNNFailureMap.k_grid` (exact
and cheap for kNN: one neighbour query with ``max(k) + 1`` neighbours, each run's own point
dropped, gives every candidate's held-out prediction).
The map is evaluated at the centres of an ``n_grid x n_grid`` grid in the inputs' own units;
cells with no run in them or in any of their 8 neighbours are masked (NaN: no data, no
claim; the neighbours keep a sparse edge from turning into confetti).  Each cell carries an
uncertainty:
the half-width of the 90 % Jeffreys interval of a binomial proportion with ``k`` trials and the
cell's estimate -- it is large where ``k`` is small or ``P`` near 1/2.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage, stats
from sklearn.neighbors import KNeighborsClassifier, NearestNeighbors

from rcsim.analysis.results.drivers.base import check_xy

#: Runs whose neighbours one query asks for (bounds the neighbour table: k + 1 indices and
#: distances a run).
MAP_QUERY_ROWS = 8192


class KNNFailureMap:
    """kNN ``P(fail)`` over two inputs on a grid, with k by cross-validation.

    Parameters
    ----------
    k_grid : tuple of int
        Candidate neighbour counts (those above 80 % of the runs are dropped).
    n_grid : int
        Grid cells per axis.
    random_state : int

    Attributes
    ----------
    feature_names_in_ : list of str (2)
    k_ : int
    cv_brier_ : dict {k: mean Brier score}
    edges_a_, edges_b_ : ndarray (n_grid + 1,)
        Cell edges in input units.
    prob_ : ndarray (n_grid, n_grid)
        ``P(fail)`` at cell centres, ``[i_a, i_b]``; NaN where masked (no run near).
    uncertainty_ : ndarray (n_grid, n_grid)
        90 % interval half-width of ``prob_``; NaN where masked.
    counts_ : ndarray of int (n_grid, n_grid)
        Runs per cell.
    """

    def __init__(self, k_grid=(5, 10, 20, 40, 80, 160), n_grid=30, random_state=0):
        self.k_grid = k_grid
        self.n_grid = n_grid
        self.random_state = random_state

    def fit(self, X, y):
        """Fit on ``X`` (n, 2) and binary ``y`` (True = failed); returns self."""
        X, y, _, names = check_xy(X, y)
        if X.shape[1] != 2:
            raise ValueError(f"a map needs exactly 2 inputs, got {X.shape[1]}")
        n = X.shape[0]
        self._sorted = [np.sort(X[:, j]) for j in range(2)]
        R = np.column_stack([self._to_rank(X[:, j], j) for j in range(2)])
        ks = [k for k in self.k_grid if k <= 0.8 * n] or [max(1, n // 2)]
        kmax = max(ks)
        nn = NearestNeighbors(n_neighbors=kmax + 1).fit(R)
        # Failed runs among each run's first k neighbours, per candidate k.  Queried
        # MAP_QUERY_ROWS runs at a time: the whole neighbour table and its running counts were
        # ~0.5 GB at 10^5 runs.  A tree answers each query on its own, so the blocks change no
        # neighbour; a table small enough for one block is queried whole, as before.
        fails = np.empty((len(ks), n), dtype=np.int64)
        at_k = np.array(ks) - 1
        for start in range(0, n, MAP_QUERY_ROWS):
            rows = np.arange(start, min(start + MAP_QUERY_ROWS, n))
            _, idx = nn.kneighbors(R[rows])
            # Drop each run itself (its own nearest neighbour unless tied at distance 0).
            own = idx == rows[:, None]
            own[:, -1] |= ~own.any(axis=1)
            neigh = idx[~own].reshape(rows.size, kmax)
            fails[:, rows] = np.cumsum(y[neigh], axis=1)[:, at_k].T
        self.cv_brier_ = {k: float(np.mean((fails[i] / k - y) ** 2)) for i, k in enumerate(ks)}
        self.k_ = min(self.cv_brier_, key=lambda k: self.cv_brier_[k])
        model = KNeighborsClassifier(self.k_).fit(R, y)
        g = int(self.n_grid)
        self.edges_a_ = np.linspace(X[:, 0].min(), X[:, 0].max(), g + 1)
        self.edges_b_ = np.linspace(X[:, 1].min(), X[:, 1].max(), g + 1)
        ca = 0.5 * (self.edges_a_[:-1] + self.edges_a_[1:])
        cb = 0.5 * (self.edges_b_[:-1] + self.edges_b_[1:])
        A, B = np.meshgrid(ca, cb, indexing="ij")
        grid = np.column_stack([self._to_rank(A.ravel(), 0), self._to_rank(B.ravel(), 1)])
        prob = model.predict_proba(grid)[:, list(model.classes_).index(True)].reshape(g, g)
        self.counts_, _, _ = np.histogram2d(X[:, 0], X[:, 1], [self.edges_a_, self.edges_b_])
        self.counts_ = self.counts_.astype(int)
        fails = prob * self.k_
        lo = stats.beta.ppf(0.05, fails + 0.5, self.k_ - fails + 0.5)
        hi = stats.beta.ppf(0.95, fails + 0.5, self.k_ - fails + 0.5)
        empty = ~ndimage.binary_dilation(self.counts_ > 0, structure=np.ones((3, 3), bool))
        self.prob_ = np.where(empty, np.nan, prob)
        self.uncertainty_ = np.where(empty, np.nan, 0.5 * (hi - lo))
        self.feature_names_in_ = names
        return self

    def _to_rank(self, x, j):
        s = self._sorted[j]
        # Mid-rank of x among the fitted values (the empirical CDF, linearly interpolated).
        return (0.5 * (np.searchsorted(s, x, "left") + np.searchsorted(s, x, "right"))) / s.size
