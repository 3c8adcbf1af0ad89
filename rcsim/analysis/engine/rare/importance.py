"""Cross-entropy importance sampling with a shifted standard normal: the alternative to subset
simulation that ``benchmarks/rare_event.py`` measures against it.

Algorithm (Rubinstein & Kroese, 2004; in standard-normal space, e.g. Papaioannou et al., 2019)
------------------------------------------------------------------------------------------
The sampling density is ``N(mu, I)``.  Each step draws ``n`` points from it (one batch), sets
the level ``b`` at the ``rho`` quantile of their margins (not below 0), and moves ``mu`` to the
weighted mean of the points with ``g <= b``, weights ``w = phi(u) / phi(u - mu) =
exp(-mu.u + |mu|^2 / 2)`` -- the cross-entropy optimum within the family.  When ``b`` reaches
0, a final batch of ``n_final`` points estimates ``P = mean(w 1[g < 0])``; its CoV is the
sample standard deviation of ``w 1[g < 0]`` over ``sqrt(n_final) P``, and the interval is the
log-normal one of :mod:`.intervals`.

Its weakness is the family: one shifted Gaussian goes to one design point.  A limit state
with two failure regions (:func:`.limit_states.series`) is then estimated at one region's
probability, with a small CoV and an interval that misses the truth -- the measurement that
makes subset simulation the campaign's default (``docs/rare_events.md``).  Non-finite margins
count as failures with margin ``-inf``, as in :mod:`.subset`.  It is not resumable: it is a
comparison, not a campaign method.

References
----------
Rubinstein, R. Y. and Kroese, D. P. (2004), The Cross-Entropy Method, Springer.
Papaioannou, I., Geyer, S. and Straub, D. (2019), "Improved cross entropy-based importance
sampling with a flexible mixture model", Reliability Engineering & System Safety 191.
"""

from __future__ import annotations

import math

import numpy as np

from rcsim.analysis.engine.rare.intervals import CONFIDENCE, lognormal_interval
from rcsim.analysis.engine.rare.result import FailurePoint, RareEventResult
from rcsim.analysis.engine.rare.state import level_generator
from rcsim.analysis.engine.rare.subset import LimitState


def cross_entropy_is(
    g: LimitState,
    dim: int,
    *,
    seed: int | np.random.SeedSequence,
    n_per_step: int = 1000,
    n_final: int = 2000,
    rho: float = 0.1,
    max_steps: int = 20,
    confidence: float = CONFIDENCE,
) -> RareEventResult:
    """Estimate ``P(g(u) < 0)``, ``u ~ N(0, I_dim)``, by cross-entropy importance sampling
    (module docstring); step ``t`` draws from child ``(t,)`` of ``seed``.

    Returns
    -------
    RareEventResult
        ``status`` ``converged``, or ``not_resolved`` (bound 1: nothing is claimed) when the
        level never reached 0 within ``max_steps``.
    """
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(int(seed))
    mu = np.zeros(dim)
    evaluations = 0
    fails: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    nonfinite = 0

    def evaluate(u: np.ndarray) -> np.ndarray:
        nonlocal evaluations, nonfinite
        ids = np.arange(evaluations, evaluations + u.shape[0], dtype=np.int64)
        margins = np.asarray(g(u, ids), dtype=float).reshape(-1)
        bad = ~np.isfinite(margins)
        nonfinite += int(bad.sum())
        margins = np.where(bad, -np.inf, margins)
        evaluations += u.shape[0]
        hit = margins < 0.0
        fails.append((u[hit], margins[hit], ids[hit]))
        return margins

    def log_weights(u: np.ndarray) -> np.ndarray:
        return -(u @ mu) + 0.5 * float(mu @ mu)

    reached = False
    for step in range(max_steps):
        u = mu + level_generator(root, step).standard_normal((n_per_step, dim))
        margins = evaluate(u)
        level = max(0.0, float(np.quantile(margins, rho)))
        elite = margins <= level
        w = np.exp(log_weights(u[elite]))
        mu = (w[:, None] * u[elite]).sum(axis=0) / w.sum()
        if level == 0.0:
            reached = True
            break

    def result(status: str, p: float | None, cov: float | None, reason: str) -> RareEventResult:
        fu = np.concatenate([f[0] for f in fails]).reshape(-1, dim)
        fm = np.concatenate([f[1] for f in fails])
        fi = np.concatenate([f[2] for f in fails]).astype(np.int64)
        return RareEventResult(
            method="cross-entropy importance sampling",
            status=status,
            probability=p,
            cov=cov,
            interval=None if p is None or cov is None else lognormal_interval(p, cov, confidence),
            upper_bound=1.0 if p is None else None,
            confidence=confidence,
            n_evaluations=evaluations,
            levels=[],
            closest_failure=_closest(fu, fm, fi),
            failures_u=fu,
            failures_margin=fm,
            failures_id=fi,
            n_nonfinite=nonfinite,
            reason=reason,
            extra={"mu": mu.copy()},
        )

    if not reached:
        return result(
            "not_resolved",
            None,
            None,
            f"the cross-entropy level did not reach 0 in {max_steps} steps",
        )
    u = mu + level_generator(root, max_steps).standard_normal((n_final, dim))
    margins = evaluate(u)
    terms = np.where(margins < 0.0, np.exp(log_weights(u)), 0.0)
    p = float(terms.mean())
    if p == 0.0:
        return result("not_resolved", None, None, "no failure among the final batch")
    cov = float(terms.std(ddof=1) / (math.sqrt(n_final) * p))
    return result(
        "converged", p, cov, f"sampling density N(mu, I), |mu| = {float(np.linalg.norm(mu)):.3f}"
    )


def _closest(u: np.ndarray, margins: np.ndarray, ids: np.ndarray) -> FailurePoint | None:
    if ids.size == 0:
        return None
    norms = np.linalg.norm(u, axis=1)
    k = int(np.argmin(norms))
    return FailurePoint(u[k].copy(), float(norms[k]), float(margins[k]), int(ids[k]))
