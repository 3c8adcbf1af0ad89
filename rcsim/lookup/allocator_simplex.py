"""The allocator's small LP and its branch and bound, solved for many problems at once in numpy.

The allocator's LP (:mod:`rcsim.lookup.allocator`) has a handful of rows (3 rate rows, and 3
translation rows when translation is priced) and a few dozen columns.  HiGHS' fixed cost per
call (building the model, presolve, the Python wrapper) is many times the work of the few
pivots such an LP needs, and a campaign asks for thousands of them.  This module solves them
directly, as a batch of independent problems ("lanes"):

* **Primal simplex from the slack basis.**  The start is one residual (or translation) column
  per row, with the sign of the row's right-hand side: feasible for every right-hand side (the
  residual is elastic), so there is no phase 1, and a column taken away (a jet off) is simply
  never priced.  Dantzig's rule (the most negative reduced cost) enters a column, the ratio
  test's smallest ratio leaves (ties to the lowest column index); after :data:`BLAND_AFTER`
  pivots Bland's rule (the lowest index) enters instead, which cannot cycle.  At the end the
  basic variables are solved afresh from the basis (``A_B x_B = rhs``).
* **Branch and bound** (:func:`branch_and_bound`), best first, every node an LP of the above
  with another right-hand side and column set, the nodes of all problems solved together.

Every lane's arithmetic is elementwise or a sum over a fixed, short axis, so a problem's answer
does not depend on which other problems share its batch (bit for bit): a campaign's runs fly
the same whichever chunk holds them.
"""

from __future__ import annotations

import heapq

import numpy as np

#: Pivots with Dantzig's rule before Bland's rule takes over (no cycling).
BLAND_AFTER = 50
#: Pivots after which the solve gives up (an LP of m rows needs far fewer).
MAX_PIVOTS = 500


def _row_times(v: np.ndarray, M: np.ndarray) -> np.ndarray:
    """``v_l M_l`` per lane, ``v`` (k, m), ``M`` (k, m, j) or (m, j): (k, j).  A sum over a
    short axis in index order, not BLAS or einsum (whose kernels may change with the batch's
    shape), so a lane's bits do not depend on how many lanes there are."""
    return (v[:, :, None] * M).sum(axis=1)


def _times_column(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``M_l v_l`` per lane, ``M`` (k, m, j), ``v`` (k, j): (k, m) (as :func:`_row_times`)."""
    return (M * v[:, None, :]).sum(axis=2)


def slack_columns(A: np.ndarray, first_slack: int) -> tuple[np.ndarray, np.ndarray]:
    """For each row of ``A``, its slack column (index ``>= first_slack``) that is ``+e_i`` and
    the one that is ``-e_i``; two ``(m,)`` int arrays.

    Raises
    ------
    ValueError
        A row without both.
    """
    m = A.shape[0]
    plus = np.full(m, -1)
    minus = np.full(m, -1)
    for j in range(first_slack, A.shape[1]):
        nz = np.flatnonzero(A[:, j])
        if nz.size == 1 and abs(A[nz[0], j]) == 1.0:
            (plus if A[nz[0], j] > 0 else minus)[nz[0]] = j
    if (plus < 0).any() or (minus < 0).any():
        raise ValueError("every row needs a +e_i and a -e_i slack column")
    return plus, minus


def solve_lps(
    A: np.ndarray,
    c: np.ndarray,
    rhs: np.ndarray,
    allowed: np.ndarray,
    plus: np.ndarray,
    minus: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``min c x  s.t.  A x = rhs_l, x >= 0, x_j = 0 where not allowed_l``, for every lane l,
    by the primal simplex from the slack basis.

    Parameters
    ----------
    A : ndarray, (m, ncol)
    c : ndarray, (ncol,)
        Costs, > 0 on the slack columns.
    rhs : ndarray, (L, m)
    allowed : ndarray of bool, (L, ncol)
        Columns each lane may use (the slack columns must be allowed).
    plus, minus : ndarray of int, (m,)
        :func:`slack_columns` of ``A``.

    Returns
    -------
    x : ndarray, (L, ncol)
        An optimal basic solution of each lane, ``>= 0``.
    value : ndarray, (L,)
        ``x @ c``.
    basis : ndarray of int, (L, m)
        The optimal basis of each lane (the start of :func:`resolve_lps`).

    Raises
    ------
    RuntimeError
        A lane without an optimum within :data:`MAX_PIVOTS` pivots.
    """
    rhs = np.asarray(rhs, float)
    n_lanes, m = rhs.shape
    ncol = A.shape[1]
    basis = np.where(rhs >= 0, plus, minus)
    binv = np.where(rhs >= 0, 1.0, -1.0)[:, :, None] * np.eye(m)
    xb = np.abs(rhs)
    # Round-off in a reduced cost grows with the largest price (the residual's).
    tol = 1e-12 * np.abs(c).max()
    active = np.arange(n_lanes)
    for it in range(MAX_PIVOTS):
        if active.size == 0:
            break
        bas = basis[active]
        inv = binv[active]
        k = np.arange(active.size)
        y = _row_times(c[bas], inv)  # c_B A_B^-1, (k, m)
        reduced = c - _row_times(y, A)  # (k, ncol)
        reduced[~allowed[active]] = np.inf
        reduced[k[:, None], bas] = np.inf
        if it < BLAND_AFTER:
            q = np.argmin(reduced, axis=1)
            go = reduced[k, q] < -tol
        else:
            candidate = reduced < -tol
            q = np.argmax(candidate, axis=1)
            go = candidate[k, q]
        if not go.all():
            active, bas, inv, q = active[go], bas[go], inv[go], q[go]
            k = k[: active.size]
        if active.size == 0:
            break
        u = _times_column(inv, A[:, q].T)  # A_B^-1 a_q, (k, m)
        x = xb[active]
        pos = u > 1e-12
        if not pos.any(axis=1).all():  # pragma: no cover - every slack costs > 0: bounded
            raise RuntimeError("allocator LP unbounded")
        ratio = np.where(pos, x / np.where(pos, u, 1.0), np.inf)
        least = ratio.min(axis=1, keepdims=True)
        ties = pos & (ratio <= least + 1e-15 * np.maximum(1.0, least))
        r = np.argmin(np.where(ties, bas, ncol), axis=1)
        piv = u[k, r]
        row = inv[k, r] / piv[:, None]
        xr = x[k, r] / piv
        inv -= u[:, :, None] * row[:, None, :]
        inv[k, r] = row
        x -= u * xr[:, None]
        np.maximum(x, 0.0, out=x)
        x[k, r] = xr
        bas[k, r] = q
        binv[active], xb[active], basis[active] = inv, x, bas
    else:
        raise RuntimeError("allocator LP: no optimum within the pivot limit")
    basis = np.sort(basis, axis=1)
    x, value = _basic_solution(A, c, rhs, basis, allowed)
    return x, value, basis


def _basic_solution(A, c, rhs, basis, allowed) -> tuple[np.ndarray, np.ndarray]:
    """The basic solution ``(L, ncol)`` of each lane's ``basis``, solved afresh from the
    basis (``A_B x_B = rhs``: independent of the pivots' round-off), and its cost ``(L,)``.
    A column not allowed that is still basic (at zero, degenerate) is zero exactly."""
    n_lanes = rhs.shape[0]
    basis = np.sort(basis, axis=1)  # one order per basis: x depends on the set alone
    a_b = np.transpose(A[:, basis], (1, 0, 2))  # (L, m, m)
    out = np.zeros((n_lanes, A.shape[1]))
    solved = np.linalg.solve(a_b, rhs[:, :, None])[:, :, 0]
    out[np.arange(n_lanes)[:, None], basis] = np.maximum(solved, 0.0)
    out[~allowed] = 0.0
    return out, (out * c).sum(axis=1)


#: Dual-simplex pivots from a warm basis before the lane is solved from the slack basis.
MAX_DUAL_PIVOTS = 30


def resolve_lps(
    A: np.ndarray,
    c: np.ndarray,
    rhs: np.ndarray,
    allowed: np.ndarray,
    plus: np.ndarray,
    minus: np.ndarray,
    basis: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`solve_lps` started from ``basis`` ``(L, m)``: an optimal basis of the same LP
    with another right-hand side, or with columns since taken away (a branch-and-bound
    node's parent).  Its reduced costs stay >= 0 on every allowed column, so the dual
    simplex runs: the most infeasible row leaves (a negative basic value, or a basic column
    no longer allowed), the dual ratio test's smallest ratio enters (ties to the lowest
    index).  A lane not optimal within :data:`MAX_DUAL_PIVOTS` pivots is solved by
    :func:`solve_lps` instead.  Same returns."""
    rhs = np.asarray(rhs, float)
    n_lanes = rhs.shape[0]
    basis = basis.copy()
    binv = np.linalg.inv(np.transpose(A[:, basis], (1, 0, 2)))
    xb = _times_column(binv, rhs)
    tol_x = 1e-12 * (1.0 + np.abs(rhs).max(axis=1))
    active = np.arange(n_lanes)
    stuck = np.zeros(n_lanes, bool)
    for _ in range(MAX_DUAL_PIVOTS):
        if active.size == 0:
            break
        bas, inv, x = basis[active], binv[active], xb[active]
        k = np.arange(active.size)
        barred = ~allowed[active[:, None], bas]  # basic but no longer allowed: must leave
        score = np.where(barred, np.abs(x), np.maximum(-x, 0.0))
        r = np.argmax(score, axis=1)
        go = score[k, r] > tol_x[active]
        if not go.all():
            active, bas, inv, x, r = active[go], bas[go], inv[go], x[go], r[go]
            k = k[: active.size]
        if active.size == 0:
            break
        y = _row_times(c[bas], inv)
        reduced = np.maximum(c - _row_times(y, A), 0.0)
        alpha = _row_times(inv[k, r], A)  # the leaving row of A_B^-1 A
        # A negative basic value rises by an entering column with alpha < 0; a barred one
        # falls to zero by one with alpha of its value's sign.
        direction = np.where(barred[k, r], np.sign(x[k, r]), -1.0)
        alpha = alpha * direction[:, None]
        enter = allowed[active] & (alpha > 1e-12)
        enter[k[:, None], bas] = False
        ratio = np.where(enter, reduced / np.where(enter, alpha, 1.0), np.inf)
        q = np.argmin(ratio, axis=1)
        ok = np.isfinite(ratio[k, q])
        u = _times_column(inv, A[:, q].T)
        piv = u[k, r]
        row = inv[k, r] / piv[:, None]
        xr = x[k, r] / piv
        inv -= u[:, :, None] * row[:, None, :]
        inv[k, r] = row
        x -= u * xr[:, None]
        x[k, r] = xr
        bas[k, r] = q
        stuck[active[~ok]] = True  # no entering column: left to the primal simplex
        active = active[ok]
        binv[active], xb[active], basis[active] = inv[ok], x[ok], bas[ok]
    stuck[active] = True  # not optimal within the pivots allowed
    unsettled = np.flatnonzero(stuck)
    basis[unsettled] = np.where(rhs[unsettled] >= 0, plus, minus)  # any nonsingular basis
    basis = np.sort(basis, axis=1)
    x_out, value = _basic_solution(A, c, rhs, basis, allowed)
    if unsettled.size:
        xs, vs, bs = solve_lps(A, c, rhs[unsettled], allowed[unsettled], plus, minus)
        x_out[unsettled], value[unsettled], basis[unsettled] = xs, vs, bs
    return x_out, value, basis


def branch_and_bound(
    A: np.ndarray,
    c: np.ndarray,
    rhs: np.ndarray,
    available: np.ndarray,
    t_min: np.ndarray,
    plus: np.ndarray,
    minus: np.ndarray,
    *,
    gap: float,
    max_nodes: int,
    width: int = 8,
    start: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mixed-integer problems ``min c x, A x = rhs_l, x >= 0``, each of the first ``n``
    columns (the jets) 0 or at least ``t_min``, each to a relative ``gap``.

    Best-first branch and bound on the jets an LP fires short: a short jet is either off (its
    column taken away) or held at its minimum (``t = t_min + t'``, the held minimum moved to
    the right-hand side), so every node is the LP of :func:`solve_lps`.  A node is pruned when
    its LP bound times ``1 + gap`` cannot beat the best plan found, so a finished search's
    plan costs at most ``1 + gap`` times the optimum.  Each round expands the ``width`` best
    open nodes of every unfinished problem, and all their children are solved in one batch.

    Parameters
    ----------
    A, c, plus, minus
        As :func:`solve_lps` (the first ``n`` columns the jets).
    rhs : ndarray, (R, m)
    available : ndarray of bool, (R, n)
        The jets each problem may use.
    t_min : ndarray, (n,)
        Minimum of a jet that fires [the LP's units].
    gap : float
    max_nodes : int
        Nodes (LPs) one problem may use; a problem that needs more is left unfinished.
    width : int
        Nodes each problem expands per round.
    start : ndarray of int, (R, m), optional
        A dual-feasible basis to start each root LP from (:func:`resolve_lps`); default the
        slack basis.

    Returns
    -------
    t : ndarray, (R, n)
        Each finished problem's plan (jet columns; zeros where unfinished).
    finished : ndarray of bool, (R,)
    nodes : ndarray of int, (R,)
        LPs solved per problem.
    """
    n = t_min.size
    n_prob = rhs.shape[0]
    ncol = A.shape[1]
    lower_t = t_min * (1 - 1e-9)
    per_min = np.where(t_min > 0, t_min, 1.0)
    best = np.zeros((n_prob, n))
    best_cost = np.full(n_prob, np.inf)
    nodes = np.zeros(n_prob, int)
    finished = np.ones(n_prob, bool)
    # Per problem, a heap of (bound, sequence, held, off, t, basis): its own sequence numbers, so
    # the order among equal bounds does not depend on the other problems.
    heaps: list[list] = [[] for _ in range(n_prob)]
    seq = np.zeros(n_prob, int)

    def solve(owner, held, off, start):
        base = np.where(held, t_min, 0.0)
        allowed = np.ones((owner.size, ncol), bool)
        allowed[:, :n] = ~off
        shifted = rhs[owner] - base @ A[:, :n].T
        if start is None:
            x, value, basis = solve_lps(A, c, shifted, allowed, plus, minus)
        else:  # warm: from the parent's optimal basis
            x, value, basis = resolve_lps(A, c, shifted, allowed, plus, minus, start)
        nodes[:] += np.bincount(owner, minlength=n_prob)
        return x[:, :n] + base, value + base @ c[:n], basis

    def consider(owner, held, off, t, cost, basis):
        for i in range(owner.size):
            p = owner[i]
            if cost[i] * (1 + gap) >= best_cost[p]:
                continue  # cannot beat the best by more than the gap
            if not ((t[i] > 0) & (t[i] < lower_t) & ~held[i]).any():
                best[p], best_cost[p] = t[i], cost[i]
                continue
            seq[p] += 1
            heapq.heappush(heaps[p], (cost[i], seq[p], held[i], off[i], t[i], basis[i]))

    all_ = np.arange(n_prob)
    none = np.zeros((n_prob, n), bool)
    consider(all_, none, ~available, *solve(all_, none, ~available, start))
    while True:
        owner, held, off, parents = [], [], [], []
        for p in range(n_prob):
            heap = heaps[p]
            if not heap:
                continue
            if nodes[p] >= max_nodes:
                finished[p] = False
                heap.clear()
                continue
            for _ in range(width):
                if not heap:
                    break
                bound, _, h, o, tp, bp = heapq.heappop(heap)
                if bound * (1 + gap) >= best_cost[p]:
                    heap.clear()  # every other open node's bound is at least this one's
                    break
                short = (tp > 0) & (tp < lower_t) & ~h
                j = int(np.argmax(np.where(short, tp / per_min, -1.0)))  # nearest its minimum
                one = np.zeros(n, bool)
                one[j] = True
                owner += [p, p]
                held += [h | one, h]
                off += [o, o | one]
                parents += [bp, bp]
        if not owner:
            break
        o_arr, h_arr, f_arr = np.array(owner), np.array(held), np.array(off)
        consider(o_arr, h_arr, f_arr, *solve(o_arr, h_arr, f_arr, np.array(parents)))
    best[~finished] = 0.0
    return best, finished, nodes


def start_bases(A: np.ndarray, c: np.ndarray, plus, minus, n_directions: int = 200):
    """Optimal bases of the LP with every column allowed, for ``n_directions`` rate-change
    directions spread over the sphere (a Fibonacci lattice; the translation rows' right-hand
    side zero), without repeats, and their duals ``y = c_B A_B^-1``.

    An optimal basis's reduced costs are >= 0 on every column, so it is a dual-feasible start
    for :func:`resolve_lps` whatever the right-hand side and whichever columns are taken away.
    They depend on the LP alone (not on any command flown), computed once per allocator.

    Returns
    -------
    bases : ndarray of int, (K, m)
    duals : ndarray, (K, m)
    """
    m = A.shape[0]
    k = np.arange(n_directions) + 0.5
    z = 1 - 2 * k / n_directions
    phi = np.pi * (1 + 5**0.5) * k
    rho = np.sqrt(1 - z**2)
    rhs = np.zeros((n_directions, m))
    rhs[:, :3] = np.c_[rho * np.cos(phi), rho * np.sin(phi), z]
    allowed = np.ones((n_directions, A.shape[1]), bool)
    bases = np.unique(np.sort(solve_lps(A, c, rhs, allowed, plus, minus)[2], axis=1), axis=0)
    a_b = np.transpose(A[:, bases], (1, 0, 2))
    duals = np.linalg.solve(np.transpose(a_b, (0, 2, 1)), c[bases][:, :, None])[:, :, 0]
    return bases, duals


def warm_start(bases: np.ndarray, duals: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Per lane of ``rhs`` ``(L, m)`` the basis of :func:`start_bases` whose dual bound
    ``y . rhs`` is the highest (the nearest the optimum; ties to the first), ``(L, m)``."""
    bound = (duals[None] * rhs[:, None, :]).sum(axis=2)  # (L, K)
    return bases[np.argmax(bound, axis=1)]
