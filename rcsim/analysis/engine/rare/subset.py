"""Subset simulation with batched Markov chains: ``P(g(u) < 0)`` for ``u ~ N(0, I_d)``.

Algorithm (Au & Beck, 2001)
---------------------------
Level 0 draws ``N`` independent points and evaluates the margin ``g`` on all of them at once.
Each level then sets the next threshold ``b`` at the ``p0`` quantile of its margins (midway
between the ``n_c``-th and ``n_c + 1``-th smallest, ``n_c = p0 N``), so that the region
``{g <= b}`` holds a fraction ``p0`` of the level, and grows ``n_c`` Markov chains of
``n_s = 1 / p0`` states from the ``n_c`` samples inside it.  The chains stay in the region and
sample it with the input law conditioned on it; the next level's ``N`` points are their states.
When at least ``n_c`` points of a level fail (``g < 0``), the estimate is
``P = p0^m * n_fail / N`` (``m`` thresholds set), with the coefficient of variation and the
log-normal interval of :mod:`.intervals`.

Markov chains (Papaioannou et al., 2015)
----------------------------------------
Conditional sampling in standard-normal space: a state ``u`` proposes
``v = rho * u + sqrt(1 - rho^2) * xi`` (``xi ~ N(0, I)``, componentwise ``rho_i``), which leaves
``N(0, I)`` invariant, so the move is accepted exactly when ``v`` stays in the region
(``g(v) <= b``); otherwise the chain repeats its state.  ``sigma_i = sqrt(1 - rho_i^2)`` is
``min(1, lambda * s_i)``, ``s_i`` the spread of the level's seeds in coordinate ``i``, and
``lambda`` is adapted after every step towards an acceptance of 0.44 (their "aCS":
``ln lambda += (a - 0.44) / sqrt(t)`` at the level's ``t``-th step).  All ``n_c`` chains move
together: one step is one call of ``g`` on ``n_c`` points -- one batch, e.g. one campaign chunk.

Choices
-------
* Failure is ``g < 0``; a margin that is not finite (NaN, inf: a run that diverged or could not
  be flown) counts as a failure with margin ``-inf``, and the result says how many there were.
* Ties at a threshold: the region is ``{g <= b}`` with ``b`` the tied value, its probability the
  counted fraction, and ``n_c`` seeds are drawn at random among its points (each is a sample of
  the region, so any of them is a valid seed).  A level whose every point lies in the region
  (a flat margin) cannot progress: the estimation stops there, as when the budget ends.
* Level ``j`` draws from its own stream (:func:`.state.level_generator`); a state file after
  each level makes a killed estimation resume where it stopped, with the same answer.
* Evaluation ids number the points in the order they are evaluated (level 0: ``0 .. N - 1``);
  ``g`` receives them with the points, so that a campaign can give each point its own run
  identity and noise streams (``docs/rare_events.md``).

References
----------
Au, S.-K. and Beck, J. L. (2001), Probabilistic Engineering Mechanics 16(4), 263-277.
Papaioannou, I., Betz, W., Zwirglmaier, K. and Straub, D. (2015), "MCMC algorithms for subset
simulation", Probabilistic Engineering Mechanics 41, 89-103.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from rcsim.analysis.engine.rare.intervals import (
    CONFIDENCE,
    chain_gamma,
    clopper_pearson,
    combined_cov,
    level_cov2,
    lognormal_interval,
    lognormal_upper,
    zero_failure_bound,
)
from rcsim.analysis.engine.rare.result import FailurePoint, RareEventResult
from rcsim.analysis.engine.rare.state import LevelRecord, SubsetState, level_generator

#: ``g(u, ids) -> margins``: points (n, d) and their evaluation ids (n,) int64 in, margins
#: (n,) out (below 0: failed).
LimitState = Callable[[np.ndarray, np.ndarray], np.ndarray]
#: Called after each finished level with its record.
Progress = Callable[[LevelRecord], None]


@dataclass(frozen=True)
class SubsetConfig:
    """Settings of a subset simulation.

    Attributes
    ----------
    n_per_level : int
        ``N``, samples per level.
    p0 : float
        Conditional probability of each intermediate level; ``p0 N`` and ``1 / p0`` must be
        whole numbers (chains and their length).
    max_levels : int
        Most levels, level 0 included.
    max_evaluations : int or None
        Most evaluations of ``g``; a level is only started if it fits.
    target_acceptance, initial_scale : float
        The chains' acceptance target and the first ``lambda`` (Papaioannou et al.: 0.44, 0.6).
    confidence : float
        Of the interval (two-sided) and of the bound (one-sided).
    """

    n_per_level: int = 1000
    p0: float = 0.1
    max_levels: int = 20
    max_evaluations: int | None = None
    target_acceptance: float = 0.44
    initial_scale: float = 0.6
    confidence: float = CONFIDENCE

    def __post_init__(self):
        if not 0.0 < self.p0 < 1.0:
            raise ValueError(f"p0 must be in (0, 1), got {self.p0!r}")
        n_c = self.n_per_level * self.p0
        if (
            self.n_per_level < 2
            or abs(n_c - round(n_c)) > 1e-9
            or round(n_c) < 1
            or self.n_per_level % round(n_c)
        ):
            raise ValueError(
                f"n_per_level * p0 must be a whole number of chains dividing n_per_level, got "
                f"n_per_level={self.n_per_level}, p0={self.p0}"
            )
        if self.max_levels < 1:
            raise ValueError(f"max_levels must be >= 1, got {self.max_levels}")
        if self.max_evaluations is not None and self.max_evaluations < self.n_per_level:
            raise ValueError(
                f"max_evaluations ({self.max_evaluations}) must allow level 0 "
                f"({self.n_per_level} evaluations)"
            )
        if not 0.0 < self.confidence < 1.0 or not 0.0 < self.target_acceptance < 1.0:
            raise ValueError("confidence and target_acceptance must be in (0, 1)")
        if not self.initial_scale > 0.0:
            raise ValueError(f"initial_scale must be > 0, got {self.initial_scale}")

    @property
    def n_chains(self) -> int:
        return int(round(self.n_per_level * self.p0))

    @property
    def chain_length(self) -> int:
        return self.n_per_level // self.n_chains


def _root(seed: int | np.random.SeedSequence) -> np.random.SeedSequence:
    return seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(int(seed))


def _evaluate(g: LimitState, u: np.ndarray, ids: np.ndarray, state: SubsetState) -> np.ndarray:
    """Margins of points ``u`` (non-finite -> -inf, counted), failures kept in ``state``."""
    margins = np.asarray(g(u, ids), dtype=float).reshape(-1)
    if margins.shape != (u.shape[0],):
        raise ValueError(f"the limit state returned {margins.size} margins for {u.shape[0]} points")
    bad = ~np.isfinite(margins)
    if bad.any():
        margins = np.where(bad, -np.inf, margins)
        state.n_nonfinite += int(bad.sum())
    state.n_evaluations += u.shape[0]
    state.add_failures(u, margins, ids)
    return margins


def _close_level(state: SubsetState, config: SubsetConfig, acceptance: float | None) -> LevelRecord:
    """The record of the level whose samples ``state`` holds: its threshold and fraction."""
    n, n_c = config.n_per_level, config.n_chains
    level = len(state.levels)
    n_s = 1 if level == 0 else config.chain_length
    g = state.margins
    n_fail = int(np.sum(g < 0.0))
    if n_fail >= n_c:
        threshold, inside, final = 0.0, g < 0.0, True
    else:
        ordered = np.sort(g)
        lo, hi = ordered[n_c - 1], ordered[n_c]
        threshold = lo if lo == hi else 0.5 * (lo + hi)
        inside, final = g <= threshold, False
    p = float(inside.mean())
    gamma = chain_gamma(inside.reshape(n_s, -1))
    return LevelRecord(
        level=level,
        threshold=float(threshold),
        probability=p,
        gamma=gamma,
        cov2=level_cov2(p, n, gamma),
        n_samples=n,
        n_failures=n_fail,
        acceptance=acceptance,
        scale=state.scale,
        n_evaluations=state.n_evaluations,
        final=final,
    )


def _next_level(
    g: LimitState, state: SubsetState, config: SubsetConfig, rng: np.random.Generator
) -> float:
    """Grow the chains of the next level from the last level's region; returns the mean
    acceptance.  ``state`` then holds the new level's samples."""
    n_c, n_s = config.n_chains, config.chain_length
    threshold = state.levels[-1].threshold
    inside = np.flatnonzero(state.margins <= threshold)
    if inside.size > n_c:  # ties at the threshold (module docstring, "Choices")
        inside = np.sort(rng.choice(inside, size=n_c, replace=False))
    current, current_g = state.u[inside].copy(), state.margins[inside].copy()
    spread = current.std(axis=0, ddof=1) if n_c > 1 else np.ones(current.shape[1])
    # A coordinate all seeds share (copies of one state) would never move: give it the
    # prior's spread instead.
    spread = np.where(spread > 0.0, spread, 1.0)
    d = current.shape[1]
    u_all = np.empty((n_s, n_c, d))
    g_all = np.empty((n_s, n_c))
    ids_all = np.empty((n_s, n_c), dtype=np.int64)
    u_all[0], g_all[0], ids_all[0] = current, current_g, state.ids[inside]
    scale, accepted = state.scale, 0.0
    for step in range(1, n_s):
        sigma = np.minimum(1.0, scale * spread)
        rho = np.sqrt(1.0 - sigma * sigma)
        proposal = rho * current + sigma * rng.standard_normal((n_c, d))
        ids = np.arange(state.n_evaluations, state.n_evaluations + n_c, dtype=np.int64)
        proposal_g = _evaluate(g, proposal, ids, state)
        move = proposal_g <= threshold
        current = np.where(move[:, None], proposal, current)
        current_g = np.where(move, proposal_g, current_g)
        ids_all[step] = np.where(move, ids, ids_all[step - 1])
        u_all[step], g_all[step] = current, current_g
        rate = float(move.mean())
        accepted += rate
        scale = math.exp(math.log(scale) + (rate - config.target_acceptance) / math.sqrt(step))
    state.u = u_all.reshape(n_s * n_c, d)
    state.margins = g_all.reshape(-1)
    state.ids = ids_all.reshape(-1)
    state.scale = scale
    return accepted / max(n_s - 1, 1)


def subset_simulation(
    g: LimitState,
    dim: int,
    config: SubsetConfig = SubsetConfig(),
    *,
    seed: int | np.random.SeedSequence,
    state_path: str | os.PathLike | None = None,
    progress: Progress | None = None,
    u0: np.ndarray | None = None,
    label: str = "",
) -> RareEventResult:
    """Estimate ``P(g(u) < 0)``, ``u ~ N(0, I_dim)``, by subset simulation (module docstring).

    Parameters
    ----------
    g : callable
        ``g(u, ids) -> margins``: ``u`` (n, dim) points, ``ids`` (n,) int64 their evaluation
        ids; returns (n,) margins, below 0 where the point fails.
    dim : int
    config : SubsetConfig
    seed : int or numpy.random.SeedSequence
        The root of every random draw (level ``j`` draws from its child ``(j,)``).
    state_path : path, optional
        State file (``.npz``): written after each level; if it exists, the estimation resumes
        from it (refused if it belongs to other settings).
    progress : callable, optional
        Called with each finished level's :class:`~.state.LevelRecord`.
    u0 : ndarray, (n_per_level, dim), optional
        Level 0's points, if the caller already has independent standard-normal draws (a
        campaign's seeded runs); by default drawn from level 0's stream.  Part of the state's
        fingerprint (its SHA-256): resuming needs the same points.
    label : str
        Names the limit state in the state file's fingerprint (a state of another is refused).

    Returns
    -------
    RareEventResult
    """
    root = _root(seed)
    problem = {
        "method": "subset simulation",
        "dim": int(dim),
        "config": asdict(config),
        "seed_entropy": str(root.entropy),
        "seed_spawn_key": list(root.spawn_key),
        "label": label,
        "u0": None if u0 is None else hashlib.sha256(np.asarray(u0, float).tobytes()).hexdigest(),
    }
    path = None if state_path is None else Path(state_path)
    if path is not None and path.exists():
        state = SubsetState.load(path, problem)
    else:
        state = _level_zero(g, dim, config, root, u0, problem)
        state.levels.append(_close_level(state, config, None))
        _checkpoint(state, path, progress)
    while True:
        last = state.levels[-1]
        if last.final:
            return _final_result(state, config)
        stalled = last.probability >= 1.0
        affordable = config.max_evaluations is None or (
            state.n_evaluations + config.n_per_level - config.n_chains <= config.max_evaluations
        )
        if stalled or not affordable or len(state.levels) >= config.max_levels:
            return _budget_result(state, config, stalled)
        acceptance = _next_level(g, state, config, level_generator(root, len(state.levels)))
        state.levels.append(_close_level(state, config, acceptance))
        _checkpoint(state, path, progress)


def _level_zero(
    g: LimitState,
    dim: int,
    config: SubsetConfig,
    root: np.random.SeedSequence,
    u0: np.ndarray | None,
    problem: dict,
) -> SubsetState:
    n = config.n_per_level
    if u0 is None:
        u = level_generator(root, 0).standard_normal((n, dim))
    else:
        u = np.asarray(u0, dtype=float)
        if u.shape != (n, dim):
            raise ValueError(f"u0 must have shape ({n}, {dim}), got {u.shape}")
    state = SubsetState(
        problem=problem,
        levels=[],
        u=u,
        margins=np.empty(0),
        ids=np.arange(n, dtype=np.int64),
        scale=config.initial_scale,
        n_evaluations=0,
    )
    state.margins = _evaluate(g, u, state.ids, state)
    return state


def _checkpoint(state: SubsetState, path: Path | None, progress: Progress | None) -> None:
    if path is not None:
        state.save(path)
    if progress is not None:
        progress(state.levels[-1])


def _closest(state: SubsetState) -> FailurePoint | None:
    if state.fail_ids.size == 0:
        return None
    norms = np.linalg.norm(state.fail_u, axis=1)
    k = int(np.argmin(norms))
    return FailurePoint(
        u=state.fail_u[k].copy(),
        norm=float(norms[k]),
        margin=float(state.fail_margins[k]),
        eval_id=int(state.fail_ids[k]),
    )


def _result(state: SubsetState, config: SubsetConfig, **fields) -> RareEventResult:
    return RareEventResult(
        method="subset simulation",
        confidence=config.confidence,
        n_evaluations=state.n_evaluations,
        levels=list(state.levels),
        closest_failure=_closest(state),
        failures_u=state.fail_u.reshape(-1, state.u.shape[1]),
        failures_margin=state.fail_margins,
        failures_id=state.fail_ids,
        n_nonfinite=state.n_nonfinite,
        **fields,
    )


def _final_result(state: SubsetState, config: SubsetConfig) -> RareEventResult:
    levels = state.levels
    last = levels[-1]
    if len(levels) == 1:
        # The failure region is not rare: level 0 is plain Monte Carlo, exact interval.
        k, n = last.n_failures, last.n_samples
        return _result(
            state,
            config,
            status="monte_carlo",
            probability=k / n,
            cov=math.sqrt(last.cov2),
            interval=clopper_pearson(k, n, config.confidence),
            upper_bound=None,
            reason=(
                f"{k} of {n} independent samples failed at level 0 (at least p0 N = "
                f"{config.n_chains}): plain Monte Carlo with its exact interval"
            ),
        )
    p = float(np.prod([r.probability for r in levels]))
    cov = combined_cov((r.cov2 for r in levels), correlated=True)
    return _result(
        state,
        config,
        status="converged",
        probability=p,
        cov=cov,
        interval=lognormal_interval(p, cov, config.confidence),
        upper_bound=None,
        cov_uncorrelated=combined_cov(r.cov2 for r in levels),
        reason=(
            f"{len(levels) - 1} intermediate levels, {last.n_failures} failure samples at the last"
        ),
    )


def _budget_result(state: SubsetState, config: SubsetConfig, stalled: bool) -> RareEventResult:
    """The budget (or a flat margin) ended the estimation before the failure level."""
    levels = state.levels
    last = levels[-1]
    why = (
        f"the margin stopped decreasing at level {last.level} (every sample at or below "
        f"{last.threshold:.6g})"
        if stalled
        else f"the budget ended after level {last.level} ({state.n_evaluations:,} evaluations)"
    )
    n = config.n_per_level
    n_s = 1 if last.level == 0 else config.chain_length
    reached = float(np.prod([r.probability for r in levels[:-1]]))  # P(region of last level)
    cov2_reached = [r.cov2 for r in levels[:-1]]
    if last.n_failures > 0:
        fail = state.margins < 0.0
        p_last = last.n_failures / n
        cov2_last = level_cov2(p_last, n, chain_gamma(fail.reshape(n_s, -1)))
        p = reached * p_last
        cov = combined_cov([*cov2_reached, cov2_last], correlated=True)
        return _result(
            state,
            config,
            status="budget",
            probability=p,
            cov=cov,
            interval=lognormal_interval(p, cov, config.confidence),
            upper_bound=None,
            cov_uncorrelated=combined_cov([*cov2_reached, cov2_last]),
            reason=(
                f"{why}: the estimate rests on {last.n_failures} failure samples of its last level"
            ),
        )
    alpha = 1.0 - config.confidence
    if last.level == 0:
        bound = zero_failure_bound(n, config.confidence)
        how = f"0 failures in {n} independent samples: exact one-sided bound 1 - alpha^(1/N)"
    else:
        # Bonferroni: the region's probability at its one-sided 1 - alpha/2 (log-normal) times
        # the exact zero-failure bound at 1 - alpha/2 on the last level's samples, counted as
        # N / (1 + gamma) independent ones (gamma: that level's chain correlation).
        n_eff = n / (1.0 + max(last.gamma, 0.0))
        cov_reached = combined_cov(cov2_reached, correlated=True)
        region = lognormal_upper(reached, cov_reached, 1.0 - alpha / 2.0)
        bound = region * zero_failure_bound(n_eff, 1.0 - alpha / 2.0)
        how = (
            f"P(region of level {last.level}) = {reached:.3g}, its one-sided "
            f"{1 - alpha / 2:.1%} bound {region:.3g}, times the zero-failure bound of "
            f"{n} correlated samples counted as {n_eff:.0f} independent ones"
        )
    return _result(
        state,
        config,
        status="not_resolved",
        probability=None,
        cov=None,
        interval=None,
        upper_bound=bound,
        reason=(
            f"{why} with no failure seen; {how}; a bound only if the chains followed every "
            f"failure region of the margin (the smallest of several criteria is not one "
            f"region: estimate each criterion on its own, rcsim.analysis.engine.rare.series)"
        ),
    )
