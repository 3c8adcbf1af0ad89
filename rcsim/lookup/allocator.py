"""Jet selection: a small LP per run, solved for a whole batch at once, and a mixed-integer
solve where a jet's minimum on-time binds.

Problem, per run (homogeneous in the command ``b``, the rate change wanted [rad/s])::

    min   sum_j mdot_j t_j  +  w_v |dv|_1  +  w_r |r|_1
    s.t.  D t + r = b          rate change per second of firing (3 rows)
          G t - dv = 0         CG velocity change per second of firing (3 rows, optional)
          t_j = 0  or  t_j >= t_min_j     total on-time of each available jet [s]

What it minimises is the profile's ``allocation`` (:func:`allocation_prices`): ``propellant``
(``w_v`` a tie-break only), ``propellant+translation`` (``w_v = m / (Isp g0)``) or
``translation-first`` (1000 times that).

Minimum on-time.  The LP relaxation (``t >= 0``) is solved first, batched as below.  When its
optimum has no total in ``(0, t_min)`` it is also the mixed-integer optimum (the relaxation's
optimum is feasible).  For a run whose LP optimum has a short total, a depth-first branch and
bound on the short jets (each either off, or held at its minimum: ``t = t_min + t'``, the held
minimum moved to the right-hand side, so every node is the same LP with another right-hand
side and the cached bases below serve it) finds a plan within ``MILP_GAP`` (0.5 %) of the
optimum: a node is pruned when its LP bound cannot beat the best plan by more than the gap.
Should ``MAX_NODES`` not suffice, HiGHS' MILP (:func:`scipy.optimize.milp`, one binary per jet,
``t_min_j z_j <= t_j <= M_j z_j`` with ``M_j`` a feasible plan's cost over ``mdot_j``, so no
optimum is cut off) is solved to the same gap.  Each distinct command is solved once (a
dictionary keyed on the command's and the jet set's bytes).  No share is dropped or deferred
after solving.

Batched solution
----------------
``b`` enters only the right-hand side and no variable has an upper bound, so an optimal basis
``B`` stays optimal for every ``b`` with ``A_B^-1 [b; 0] >= 0`` (every right-hand side, force
rows included: the branch and bound's nodes): its dual feasibility does not depend on it.
The optimum is piecewise linear over finitely many cones.  The allocator keeps
the optimal bases it has met (index set, ``A_B^-1``, and which
columns have a negative reduced cost); a batch is solved by evaluating every cached basis for
every run at once (one ``einsum``, ``(n_runs, K, m)``) and keeping, per run, the cheapest
primal-feasible basis whose columns the run may use and none of whose negative-reduced-cost
columns it may use.  Runs no cached basis covers are solved by HiGHS
(:func:`scipy.optimize.linprog`) one at a time and their basis joins the cache; one miss's
basis usually covers other misses, and in a campaign the misses stop within the first cycles.
Failed jets (per-run availability) use the same cache.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linprog, milp

from rcsim.models.errors import InputError

#: ``translation-first`` prices translation this many times ``m / (Isp g0)``.
TRANSLATION_FIRST_FACTOR = 1e3
#: ``propellant`` breaks ties between plans of equal propellant toward less translation, at
#: this fraction of ``m / (Isp g0)`` (a plan costs at most this relative extra propellant).
TIE_BREAK_FACTOR = 1e-6
#: Relative optimality gap of a plan whose minimum on-time binds: a plan is accepted when its
#: cost is within this of the LP relaxation's (a lower bound), else HiGHS' MILP is solved to it.
MILP_GAP = 0.005
#: Nodes the branch and bound may visit before HiGHS' MILP takes over.
MAX_NODES = 10
#: Distinct MILP answers kept per allocator (oldest dropped first).
MILP_CACHE_SIZE = 100_000


def allocation_prices(mode: str, mass_kg: float, isp_s: float, g0_m_s2: float) -> float:
    """The translation price ``w_v`` [kg per m/s of ``|dv|_1``] of allocation ``mode``
    (:data:`rcsim.spacecraft.control_profile.ALLOCATION_MODES`) for a vehicle of ``mass_kg``
    and specific impulse ``isp_s`` [s]: ``m / (Isp g0)`` is the propellant that nulls 1 m/s."""
    null_kg = mass_kg / (isp_s * g0_m_s2)
    factors = {
        "propellant": TIE_BREAK_FACTOR,
        "propellant+translation": 1.0,
        "translation-first": TRANSLATION_FIRST_FACTOR,
    }
    if mode not in factors:
        raise InputError(f"allocation must be one of {', '.join(factors)}, got {mode!r}")
    return factors[mode] * null_kg


class Allocator:
    """Batched allocator (module docstring).

    Parameters
    ----------
    D : ndarray, (3, n_jets)
        Body-rate change per second of each jet's firing [rad/s per s] (the controller's model).
    mdot_kg_s : ndarray, (n_jets,)
        Propellant flow of each jet [kg/s].
    G : ndarray, (3, n_jets), optional
        CG velocity change per second of firing [m/s per s]; None: translation not priced.
    w_v : float
        Price of translation [kg per m/s of |dv|_1].
    w_r : float
        Price of the residual, relative to the dearest jet's cost of the same rate change.
    t_min_s : ndarray, (n_jets,), optional
        Shortest total on-time of a jet that fires [s] (its minimum delivered pulse); default
        none (the LP alone).
    """

    def __init__(self, D, mdot_kg_s, G=None, w_v: float = 0.0, w_r: float = 1e3, t_min_s=None):
        self.D = np.asarray(D, float)
        self.n = n = self.D.shape[1]
        self.mdot = np.asarray(mdot_kg_s, float).reshape(n)
        if not (np.isfinite(self.D).all() and np.abs(self.D).max() > 0):
            raise InputError("jets give no rate change", parameter="D")
        if not (np.isfinite(self.mdot).all() and (self.mdot > 0).all()):
            raise InputError("must be finite and > 0", parameter="mdot_kg_s")
        # HiGHS' tolerances are absolute (~1e-7): scale rows to unit size, costs to max 1.
        cost_scale = self.mdot.max()
        self.sD = 1.0 / np.abs(self.D).max()
        Ds = self.D * self.sD
        # A jet's full price per second: its propellant and, when priced, its translation; the
        # residual costs w_r times the dearest jet's full price of the same rate change, so no
        # translation price ever makes a reachable rate change cheaper to leave undone.
        jet_price = self.mdot / cost_scale
        if G is not None:
            jet_price = jet_price + w_v * np.abs(np.asarray(G, float)).sum(axis=0) / cost_scale
        # Over the jets that turn the vehicle at all (1e-3 of the strongest): a jet whose force
        # passes near the CG would make the price astronomically large (HiGHS fails on it).
        turn = np.linalg.norm(Ds, axis=0)
        useful = turn >= 1e-3 * turn.max()
        wr = w_r * np.max(jet_price[useful] / turn[useful])
        rows = [np.hstack([Ds, np.eye(3), -np.eye(3)])]
        cost = [self.mdot / cost_scale, np.full(6, wr)]
        if G is not None:
            G = np.asarray(G, float)
            sG = 1.0 / max(np.abs(G).max(), 1e-300)
            rows[0] = np.hstack([rows[0], np.zeros((3, 6))])
            rows.append(np.hstack([G * sG, np.zeros((3, 6)), -np.eye(3), np.eye(3)]))
            cost.append(np.full(6, w_v / sG / cost_scale))
        self.A = np.vstack(rows)
        self.c = np.concatenate(cost)
        self.m, self.ncol = self.A.shape
        self.bases = np.zeros((0, self.m), int)
        self.inv = np.zeros((0, self.m, self.m))  # A_B^-1 (a node of the MILP search shifts
        # the force rows' right-hand side too)
        self.negative = np.zeros((0, self.ncol), bool)  # columns with negative reduced cost
        self.n_lp = 0  # HiGHS solves so far (cache misses)
        self.t_min = np.zeros(n) if t_min_s is None else np.broadcast_to(t_min_s, (n,)) * 1.0
        if not (np.isfinite(self.t_min).all() and (self.t_min >= 0).all()):
            raise InputError("must be finite and >= 0", parameter="t_min_s")
        self._milp_cache: dict[bytes, np.ndarray] = {}
        self.n_milp = 0  # MILP solves so far (distinct commands with a binding minimum)
        self.n_certified = 0  # binding minimum, a rounded plan within MILP_GAP: no MILP
        self.n_nodes = 0  # branch-and-bound nodes so far

    def allocate(self, b, available=None) -> tuple[np.ndarray, np.ndarray]:
        """On-times and residuals for commands ``b``.

        Parameters
        ----------
        b : ndarray, (n_runs, 3)
            Rate change wanted [rad/s].
        available : ndarray of bool, (n_runs, n_jets), optional
            The jets each run may use; default all.

        Returns
        -------
        t : ndarray, (n_runs, n_jets)
            Total on-time of each jet [s], each 0 or at least its ``t_min_s``.
        residual : ndarray, (n_runs, 3)
            Rate change the jets cannot give [rad/s] (zero when ``b`` is reachable).
        """
        b = np.atleast_2d(np.asarray(b, float))
        t, residual = self.allocate_relaxed(b, available)
        if not self.t_min.any():
            return t, residual
        short = (t > 0) & (t < self.t_min * (1 - 1e-9))
        if available is None:
            available = np.ones(t.shape, bool)
        available = np.broadcast_to(np.asarray(available, bool), t.shape)
        for i in np.flatnonzero(short.any(axis=1)):  # runs whose minimum binds, each once
            t[i] = self._solve_milp(b[i], available[i], t[i])
            residual[i] = b[i] - self.D @ t[i]
        return t, residual

    def allocate_relaxed(self, b, available=None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`allocate` without the minimum on-time (the LP relaxation), batched."""
        b = np.atleast_2d(np.asarray(b, float))
        n_runs = b.shape[0]
        if available is None:
            available = np.ones((n_runs, self.n), bool)
        rhs = np.zeros((n_runs, self.m))
        rhs[:, :3] = b * self.sD
        x = self._relaxed(rhs, np.asarray(available, bool))
        t = x[:, : self.n].copy()
        return t, b - t @ self.D.T

    def _relaxed(self, rhs, available) -> np.ndarray:
        """The LP's optimal variables ``(n_runs, ncol)`` for scaled right-hand sides ``rhs``
        ``(n_runs, m)``: cached bases for the whole batch, HiGHS for the misses."""
        n_runs = rhs.shape[0]
        x = np.zeros((n_runs, self.ncol))
        todo = np.flatnonzero(np.any(rhs != 0, axis=1))
        while todo.size:
            chosen, x_basis = self._from_cache(rhs[todo], available[todo])
            hit = chosen >= 0
            rows = todo[hit]
            full = np.zeros((rows.size, self.ncol))
            np.put_along_axis(full, self.bases[chosen[hit]], np.maximum(x_basis[hit], 0.0), axis=1)
            x[rows] = full
            todo = todo[~hit]
            if todo.size == 0:
                break
            i = todo[0]
            cached = self.bases.shape[0]
            solved = self._solve(rhs[i], available[i])
            if self.bases.shape[0] == cached:  # basis not cacheable (degenerate): use the LP's
                x[i] = solved
                todo = todo[1:]
        return x

    def _solve(self, rhs, available) -> np.ndarray:
        """One HiGHS solve; its optimal basis joins the cache when it is dual feasible."""
        self.n_lp += 1
        avail = np.concatenate([available, np.ones(self.ncol - self.n, bool)])
        bounds = [(0, None if avail[j] else 0) for j in range(self.ncol)]
        res = self._linprog(bounds, rhs)
        x, y = res.x, res.eqlin.marginals
        scale = np.maximum(np.abs(self.c), 1e-300)
        reduced = self.c - self.A.T @ y
        support = list(np.flatnonzero(x > 1e-12 * max(1.0, np.abs(x).max())))
        zero = np.flatnonzero(avail & (np.abs(reduced) <= 1e-7 * scale))
        basis = support
        # Complete the support to a basis with zero-reduced-cost columns (A_B nonsingular).
        for j in sorted(set(zero) - set(support), key=lambda j: -np.linalg.norm(self.A[:, j])):
            if len(basis) == self.m:
                break
            if np.linalg.matrix_rank(self.A[:, basis + [j]], tol=1e-10) == len(basis) + 1:
                basis = basis + [j]
        if len(basis) == self.m and np.linalg.matrix_rank(self.A[:, basis], tol=1e-10) == self.m:
            basis = sorted(basis)
            a_b = self.A[:, basis]
            y_b = np.linalg.solve(a_b.T, self.c[basis])
            negative = (self.c - self.A.T @ y_b) < -1e-7 * scale
            known = (self.bases == basis).all(axis=1) & (self.negative == negative).all(axis=1)
            if not (negative & avail).any() and not known.any():
                self.bases = np.vstack([self.bases, basis])
                self.inv = np.concatenate([self.inv, np.linalg.inv(a_b)[None]])
                self.negative = np.vstack([self.negative, negative])
        return x

    def _from_cache(self, rhs, available) -> tuple[np.ndarray, np.ndarray]:
        """Per run the cheapest cached basis that is optimal for it (-1: none), and its x_B."""
        n_runs = rhs.shape[0]
        if self.bases.shape[0] == 0:
            return np.full(n_runs, -1), np.zeros((n_runs, self.m))
        x = np.einsum("kij,nj->nki", self.inv, rhs)  # (n_runs, K, m)
        scale = np.abs(x).max(axis=2, keepdims=True) + 1e-300
        primal = (x >= -1e-9 * scale).all(axis=2)
        avail = np.hstack([available, np.ones((n_runs, self.ncol - self.n), bool)])
        in_basis = avail[:, self.bases].all(axis=2)
        dual = (avail.astype(np.uint8) @ self.negative.T.astype(np.uint8)) == 0
        ok = primal & in_basis & dual
        cost = np.where(ok, np.einsum("nki,ki->nk", np.maximum(x, 0), self.c[self.bases]), np.inf)
        k = np.argmin(cost, axis=1)
        chosen = np.where(ok.any(axis=1), k, -1)
        return chosen, x[np.arange(n_runs), np.maximum(k, 0)]

    def _solve_milp(self, b, available, t_lp) -> np.ndarray:
        """On-times ``(n_jets,)`` [s] of the mixed-integer problem (module docstring) for one
        command; each distinct (command, jet set) solved once."""
        key = b.tobytes() + np.packbits(available).tobytes()
        hit = self._milp_cache.get(key)
        if hit is not None:
            return hit.copy()
        n, ncol = self.n, self.ncol
        rhs = np.zeros(self.m)
        rhs[:3] = b * self.sD
        found = self._branch_and_bound(rhs, available)
        if found is not None:
            return self._remember(key, found)
        # A feasible plan: the LP's short jets held at their minimum, the others re-solved.
        # Its cost bounds the optimum's, so no optimal plan fires a jet longer than that cost
        # over the jet's propellant price: a tight big-M (a loose one lets HiGHS' integrality
        # tolerance, 1e-6, fire short pulses "off").
        held = np.zeros(n, bool)
        feasible = t_lp
        while True:  # hold every short jet at its minimum until none is short (<= n rounds)
            short = (feasible > 0) & (feasible < self.t_min * (1 - 1e-9)) & ~held
            if not short.any():
                break
            held |= short
            feasible = self._held_at_minimum(b, available, held)
        bound = self._cost(feasible, b)
        # A second feasible plan: the short jets dropped, the LP re-solved without them.
        dropped = self._dropped(b, available)
        if self._cost(dropped, b) < bound:
            feasible, bound = dropped, self._cost(dropped, b)
        # The LP relaxation bounds the optimum from below: a feasible plan within MILP_GAP of
        # it is within MILP_GAP of the optimum, and no MILP is needed.
        if bound <= (1 + MILP_GAP) * self._cost(t_lp, b):
            self.n_certified += 1
            return self._remember(key, feasible)
        self.n_milp += 1
        big = bound / self.c[:n]
        cost = np.concatenate([self.c, np.zeros(n)])
        a_link = np.zeros((2 * n, ncol + n))
        a_link[:n, :n] = np.eye(n)
        a_link[:n, ncol:] = -np.diag(big)  # t - M z <= 0
        a_link[n:, :n] = np.eye(n)
        a_link[n:, ncol:] = -np.diag(self.t_min)  # t - t_min z >= 0
        constraints = [
            LinearConstraint(np.hstack([self.A, np.zeros((self.m, n))]), rhs, rhs),
            LinearConstraint(
                a_link,
                np.r_[np.full(n, -np.inf), np.zeros(n)],
                np.r_[np.zeros(n), np.full(n, np.inf)],
            ),
        ]
        upper = np.r_[np.full(ncol, np.inf), available.astype(float)]
        res = milp(
            cost,
            constraints=constraints,
            integrality=np.r_[np.zeros(ncol), np.ones(n)],
            bounds=Bounds(np.zeros(ncol + n), upper),
            options={"mip_rel_gap": MILP_GAP, "presolve": False},
        )
        if res.status != 0 or res.x is None:  # pragma: no cover - z = 0 is always feasible
            raise RuntimeError(f"allocator MILP failed: {res.message}")
        t = res.x[:n].copy()
        # HiGHS' integrality tolerance: a jet it turned off is off, one it fires is at least
        # its minimum (the solve's primal tolerance, ~1e-9 s, rounded away).
        z = res.x[ncol:] > 0.5
        t = np.where(z & available, np.maximum(t, self.t_min), 0.0)
        if self._cost(t, b) > bound:  # pragma: no cover - a solver shortfall: keep the bound's
            t = feasible
        return self._remember(key, t)

    def _branch_and_bound(self, rhs, available) -> np.ndarray | None:
        """On-times ``(n_jets,)`` [s] within ``MILP_GAP`` of the mixed-integer optimum, by
        depth-first branch and bound on the short jets (a short jet is either off or held at
        least at its minimum); every node's LP is the cached-basis LP with the held minimum
        moved to the right-hand side (``t = t_min + t'``, ``t' >= 0``), so a node costs a
        matrix product once its basis is known.  None when ``MAX_NODES`` are not enough."""
        n = self.n
        lower_t = self.t_min * (1 - 1e-9)
        best, best_cost = None, np.inf
        stack = [(np.zeros(n, bool), ~available)]
        for _ in range(MAX_NODES):
            if not stack:
                return best
            self.n_nodes += 1
            held, off = stack.pop()
            base = np.where(held, self.t_min, 0.0)
            x = self._relaxed((rhs - self.A[:, :n] @ base)[None], (~off)[None])[0]
            cost = float(self.c @ x + self.c[:n] @ base)
            if cost * (1 + MILP_GAP) >= best_cost:
                continue  # this branch cannot beat the best by more than the gap
            t = x[:n] + base
            short = (t > 0) & (t < lower_t) & ~held
            if not short.any():
                best, best_cost = t, cost
                continue
            j = int(np.argmax(np.where(short, t / self.t_min, -1.0)))  # nearest its minimum
            one = np.zeros(n, bool)
            one[j] = True
            stack.append((held, off | one))  # off: explored second
            stack.append((held | one, off))  # held at the minimum: a feasible plan soonest
        return best if not stack else None

    def _remember(self, key: bytes, t: np.ndarray) -> np.ndarray:
        if len(self._milp_cache) >= MILP_CACHE_SIZE:
            self._milp_cache.pop(next(iter(self._milp_cache)))
        self._milp_cache[key] = t
        return t.copy()

    def _dropped(self, b, available) -> np.ndarray:
        """On-times ``(n_jets,)`` [s] of the LP without the jets it fires short, repeated
        until none is short (<= n rounds; a feasible plan of the mixed-integer problem)."""
        allowed = available.copy()
        while True:
            t = self.allocate_relaxed(b[None], allowed[None])[0][0]
            short = (t > 0) & (t < self.t_min * (1 - 1e-9))
            if not short.any():
                return t
            allowed &= ~short

    def _linprog(self, bounds, rhs):
        """HiGHS' dual simplex on the allocator's LP; its interior point, then its own choice,
        when the simplex gives up (costs spanning many decades -- a translation price on a
        layout that cannot reach an axis -- can leave its status unknown)."""
        for method in ("highs-ds", "highs-ipm", "highs"):
            res = linprog(self.c, A_eq=self.A, b_eq=rhs, bounds=bounds, method=method)
            if res.status == 0:
                return res
        # pragma: no cover - the elastic residual keeps the LP feasible and bounded
        raise RuntimeError(f"allocator LP failed: {res.message}")

    def _held_at_minimum(self, b, available, held) -> np.ndarray:
        """On-times ``(n_jets,)`` [s] of the LP with the ``held`` jets at least their minimum
        (a feasible plan of the mixed-integer problem)."""
        lower = np.r_[np.where(held & available, self.t_min, 0.0), np.zeros(self.ncol - self.n)]
        upper = [None if j >= self.n or available[j] else 0.0 for j in range(self.ncol)]
        rhs = np.zeros(self.m)
        rhs[:3] = b * self.sD
        res = self._linprog(list(zip(lower, upper)), rhs)
        return np.where(res.x[: self.n] > 0, np.maximum(res.x[: self.n], lower[: self.n]), 0.0)

    def _cost(self, t, b) -> float:
        """The (scaled) objective of on-times ``t`` for command ``b``: propellant, the
        residual and, when priced, the translation left."""
        resid = (b - self.D @ t) * self.sD
        cost = float(self.c[: self.n] @ t + self.c[self.n] * np.abs(resid).sum())
        if self.m > 3:
            dv = self.A[3:, : self.n] @ t
            cost += float(self.c[self.n + 6] * np.abs(dv).sum())
        return cost
