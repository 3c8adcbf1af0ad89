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

Solution (:mod:`rcsim.lookup.allocator_simplex`, numpy, every command its own problem).

* **The LP relaxation** (``t >= 0``) of every command is solved by a dense dual simplex, all
  commands of a batch at once, each started from the allocator's own start bases (the optimal
  bases of 200 fixed directions, computed once per allocator from its LP alone: the one whose
  dual bound is highest for the command).  When its optimum has no total in ``(0, t_min)`` it
  is also the mixed-integer optimum, and the command is settled.
* **Branch and bound.**  A command whose LP optimum fires a jet short is searched best first:
  a short jet is either off, or held at its minimum (``t = t_min + t'``, the held minimum
  moved to the right-hand side, so every node is the same LP with another right-hand side and
  column set).  A node is pruned when its LP bound cannot beat the best plan by more than
  ``MILP_GAP`` (0.5 %), so the plan is within ``MILP_GAP`` of the optimum.  A node's LP starts
  from its parent's optimal basis; the nodes of all the batch's searches are solved together.
* **Exact solve (the rule).**  HiGHS' MILP (:func:`scipy.optimize.milp`, one binary per jet,
  ``t_min_j z_j <= t_j <= M_j z_j`` with ``M_j`` a feasible plan's cost over ``mdot_j``, so no
  optimum is cut off, solved to the same gap) runs for a command exactly when its branch and
  bound has not finished within ``MAX_NODES`` LPs.  ``n_milp`` counts these solves.

Each distinct command (its bytes and the jet set's) is solved once per allocator (a dictionary
of plans; a plan is a function of its key alone).  No share is dropped or deferred after
solving.  Nothing else is kept between calls, so a command's plan does not depend on which
other commands share its batch: a campaign's runs fly the same, bit for bit, whichever chunk
holds them.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

from rcsim.lookup.allocator_simplex import (
    branch_and_bound,
    resolve_lps,
    slack_columns,
    solve_lps,
    start_bases,
    warm_start,
)
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
MAX_NODES = 1000
#: Distinct plans of a binding minimum kept per allocator (oldest dropped first).
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
        self.plus, self.minus = slack_columns(self.A, self.n)
        self.start_bases, self.start_duals = start_bases(self.A, self.c, self.plus, self.minus)
        self.t_min = np.zeros(n) if t_min_s is None else np.broadcast_to(t_min_s, (n,)) * 1.0
        if not (np.isfinite(self.t_min).all() and (self.t_min >= 0).all()):
            raise InputError("must be finite and >= 0", parameter="t_min_s")
        self._plans: dict[bytes, np.ndarray] = {}
        self.n_lp = 0  # LP relaxations solved (commands, and the fallback's heuristics)
        self.n_searched = 0  # distinct commands whose minimum binds: branch and bound
        self.n_nodes = 0  # branch-and-bound nodes (LPs) so far
        self.n_milp = 0  # exact solves (HiGHS' MILP): searches not finished in MAX_NODES

    def counts(self) -> dict[str, int]:
        """The solver's work so far: ``lp`` relaxations, ``searched`` commands (branch and
        bound), their ``nodes``, and ``exact`` solves (HiGHS' MILP; the module docstring's
        rule)."""
        return {
            "lp": self.n_lp,
            "searched": self.n_searched,
            "nodes": self.n_nodes,
            "exact": self.n_milp,
        }

    def allocate(self, b, available=None, relaxed=None) -> tuple[np.ndarray, np.ndarray]:
        """On-times and residuals for commands ``b``.

        Parameters
        ----------
        b : ndarray, (n_runs, 3)
            Rate change wanted [rad/s].
        available : ndarray of bool, (n_runs, n_jets), optional
            The jets each run may use; default all.
        relaxed : ndarray, (n_runs, n_jets), optional
            :meth:`allocate_relaxed`'s on-times for the same ``b`` and ``available``, when
            the caller has them (not solved again).

        Returns
        -------
        t : ndarray, (n_runs, n_jets)
            Total on-time of each jet [s], each 0 or at least its ``t_min_s``.
        residual : ndarray, (n_runs, 3)
            Rate change the jets cannot give [rad/s] (zero when ``b`` is reachable).
        """
        b = np.atleast_2d(np.asarray(b, float))
        if relaxed is None:
            t, residual = self.allocate_relaxed(b, available)
        else:
            t = np.array(relaxed, float)
            residual = b - t @ self.D.T
        if not self.t_min.any():
            return t, residual
        if available is None:
            available = np.ones(t.shape, bool)
        available = np.broadcast_to(np.asarray(available, bool), t.shape)
        rows = np.flatnonzero(((t > 0) & (t < self.t_min * (1 - 1e-9))).any(axis=1))
        keys = [b[i].tobytes() + np.packbits(available[i]).tobytes() for i in rows]
        new: dict[bytes, int] = {}  # each distinct command searched once, at its first row
        for key, i in zip(keys, rows):
            if key not in self._plans:
                new.setdefault(key, int(i))
        if new:
            at = np.fromiter(new.values(), int, len(new))
            for key, plan in zip(new, self._search(b[at], available[at])):
                self._remember(key, plan)
        for key, i in zip(keys, rows):
            t[i] = self._plans[key]
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
        x = self._relaxed(rhs, np.broadcast_to(np.asarray(available, bool), (n_runs, self.n)))
        t = x[:, : self.n].copy()
        return t, b - t @ self.D.T

    def _relaxed(self, rhs, available) -> np.ndarray:
        """The LP's optimal variables ``(n_runs, ncol)`` for scaled right-hand sides ``rhs``
        ``(n_runs, m)`` and jets ``available`` ``(n_runs, n)``."""
        x = np.zeros((rhs.shape[0], self.ncol))
        todo = np.flatnonzero(np.any(rhs != 0, axis=1))
        if todo.size:
            allowed = np.ones((todo.size, self.ncol), bool)
            allowed[:, : self.n] = available[todo]
            start = warm_start(self.start_bases, self.start_duals, rhs[todo])
            x[todo] = resolve_lps(self.A, self.c, rhs[todo], allowed, self.plus, self.minus, start)[
                0
            ]
            self.n_lp += todo.size
        return x

    def _search(self, b, available) -> np.ndarray:
        """Plans ``(k, n_jets)`` [s] for commands ``b`` ``(k, 3)`` whose minimum binds: the
        branch and bound, and HiGHS' MILP for a search not finished (module docstring)."""
        rhs = np.zeros((b.shape[0], self.m))
        rhs[:, :3] = b * self.sD
        t, finished, nodes = branch_and_bound(
            self.A, self.c, rhs, available, self.t_min, self.plus, self.minus,
            gap=MILP_GAP, max_nodes=MAX_NODES,
            start=warm_start(self.start_bases, self.start_duals, rhs),
        )  # fmt: skip
        self.n_searched += b.shape[0]
        self.n_nodes += int(nodes.sum())
        for i in np.flatnonzero(~finished):
            t[i] = self._solve_milp(b[i], available[i])
        return t

    def _solve_milp(self, b, available) -> np.ndarray:
        """On-times ``(n_jets,)`` [s] of the mixed-integer problem (module docstring) for one
        command, by HiGHS' MILP."""
        n, ncol = self.n, self.ncol
        self.n_milp += 1
        rhs = np.zeros(self.m)
        rhs[:3] = b * self.sD
        # A feasible plan: the LP's short jets held at their minimum until none is short, or
        # dropped until none is.  Its cost bounds the optimum's, so no optimal plan fires a
        # jet longer than that cost over the jet's propellant price: a tight big-M (a loose
        # one lets HiGHS' integrality tolerance, 1e-6, fire short pulses "off").
        feasible = min(
            (self._held_at_minimum(b, available), self._dropped(b, available)),
            key=lambda plan: self._cost(plan, b),
        )
        bound = self._cost(feasible, b)
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
        return t

    def _remember(self, key: bytes, t: np.ndarray) -> None:
        if len(self._plans) >= MILP_CACHE_SIZE:
            self._plans.pop(next(iter(self._plans)))
        self._plans[key] = t

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

    def _held_at_minimum(self, b, available) -> np.ndarray:
        """On-times ``(n_jets,)`` [s] of the LP with every jet it fires short held at least at
        its minimum, repeated until none is short (<= n rounds; a feasible plan of the
        mixed-integer problem)."""
        held = np.zeros(self.n, bool)
        rhs = np.zeros(self.m)
        rhs[:3] = b * self.sD
        allowed = np.r_[available, np.ones(self.ncol - self.n, bool)][None]
        while True:
            base = np.where(held, self.t_min, 0.0)
            shifted = (rhs - self.A[:, : self.n] @ base)[None]
            x = solve_lps(self.A, self.c, shifted, allowed, self.plus, self.minus)[0][0]
            self.n_lp += 1
            t = x[: self.n] + base
            short = (t > 0) & (t < self.t_min * (1 - 1e-9)) & ~held
            if not short.any():
                return t
            held |= short

    def _cost(self, t, b) -> float:
        """The (scaled) objective of on-times ``t`` for command ``b``: propellant, the
        residual and, when priced, the translation left."""
        resid = (b - self.D @ t) * self.sD
        cost = float(self.c[: self.n] @ t + self.c[self.n] * np.abs(resid).sum())
        if self.m > 3:
            dv = self.A[3:, : self.n] @ t
            cost += float(self.c[self.n + 6] * np.abs(dv).sum())
        return cost
