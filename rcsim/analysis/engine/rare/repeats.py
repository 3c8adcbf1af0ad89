"""Independent repeats of subset simulation: an estimate whose spread is measured, with the
model's figure as a floor.

Why
---
One subset simulation reports a coefficient of variation built from a model of its own
variance (:mod:`.intervals`).  Au & Beck's usual formula (levels uncorrelated) was measured to
give intervals that cover less than their nominal 95 % (85-95 of 100, ``docs/rare_events.md``);
their fully correlated bound covers (99-100 of 100) but overstates the real spread 1.5-3x, so a
reader is shown a CoV of 0.52-0.56 at ``P ~ 1e-5`` on the real simulator where the estimates
actually spread by 0.16.  ``K`` independent estimations of ``N`` runs per level cost what one of
``K N`` does (the cost of a level is the same), and their sample spread *is* the estimator's:
the reported estimate is their mean, its CoV ``s / (sqrt(K) mean)`` (at least the model's,
below), and its interval comes from the ``K`` estimates.

The interval
------------
Subset-simulation estimates are right-skewed (a product of level fractions), so the interval
is Cox's for the mean of a log-normal sample (Land, 1972; Zhou & Gao, 1997), with Student's
``t`` on ``K - 1`` degrees of freedom for the few repeats:

    y_k = ln P_k,   ybar, s_y^2 their mean and variance,
    ln(mean) ~ ybar + s_y^2 / 2  +-  t_{K-1} sqrt(s_y^2 / K + s_y^4 / (2 (K - 1))).

The floor.  Four estimates can agree by chance: the CoV measured from them has three degrees
of freedom, and on the real simulator at ``P ~ 7e-4`` with ``N = 250`` it came out as low as
0.08 where the estimates spread by 0.46 (three of eight intervals missed the plain Monte Carlo
reference).  So the reported CoV is the larger of the measured one and Au & Beck's for the
mean, ``sqrt(sum_k c_k^2) / K`` (``c_k`` each repeat's usual, uncorrelated figure,
:func:`model_cov2`), and Cox's ``s_y^2`` is at least ``ln(1 + mean_k c_k^2)``, the same model's
variance of one ``ln P_k``; the reason says when the model's figure was used.

Measured (``benchmarks/rare_event.py --repeats 4 --n-per-level 500 --repeat 100``, seeds
0-99, ``docs/rare_events.md``): on the nine analytic cells (linear in 10 and 86 dimensions at
1e-3, 1e-5, 1e-6, two failure regions, the curved boundary) 98-100 of 100 intervals held the
truth, the reported CoV was 0.18-0.29 against a real spread of 0.19-0.39 (without the floor:
88-98 of 100 with the reported CoV 0.69-0.87x the real spread over 400 repetitions).  What the
interval absorbs and the CoV alone does not: subset simulation at ``N = 500`` is biased high by
up to 10 % (mean / truth 1.00-1.13), which averaging repeats does not remove.

Statuses of the combination
---------------------------
* every repeat ``monte_carlo`` (level 0 already saw ``p0 N`` failures: not rare): the ``K``
  level-0 samples are one plain Monte Carlo of ``K N`` independent runs, with its exact
  interval;
* every repeat has an estimate above 0: the mean with Cox's interval, ``converged`` when every
  repeat converged or counted at level 0, ``budget`` when the budget ended any of them early;
* some repeats saw no failure (``not_resolved``) and others did: ``budget``, their estimate
  taken as 0 in the mean, a ``t`` interval on the raw estimates clipped at 0 (a logarithm of
  0 does not exist);
* no repeat saw a failure: ``not_resolved`` with the largest of the ``K`` one-sided bounds
  (each is a valid bound on its own; the largest is too, and conservative).

Seeds and evaluation ids
------------------------
Repeat 0 is the plain estimation on the root seed (``K = 1`` is :func:`.subset_simulation`
itself, bit for bit); repeat ``k >= 1`` draws from the root's child ``(REPEAT_KEY + k,)``, a key
no level uses.  Repeat ``k``'s evaluation ids are its own plus ``k * ID_STRIDE``, so that a
campaign gives every run of every repeat its own identity.

References
----------
Land, C. E. (1972), "An evaluation of approximate confidence interval estimation methods for
lognormal means", Technometrics 14(1), 145-158.
Zhou, X.-H. and Gao, S. (1997), "Confidence intervals for the log-normal mean", Statistics in
Medicine 16(7), 783-790.
"""

from __future__ import annotations

import math
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import stats

from rcsim.analysis.engine.rare.intervals import CONFIDENCE, clopper_pearson
from rcsim.analysis.engine.rare.result import RareEventResult
from rcsim.analysis.engine.rare.subset import (
    LimitState,
    Progress,
    SubsetConfig,
    subset_simulation,
)

#: Repeat ``k >= 1`` draws from the root's child ``(REPEAT_KEY + k,)`` (levels use ``(j,)``,
#: ``j`` below ``max_levels``).
REPEAT_KEY = 2**31
#: Repeat ``k``'s evaluation ids are offset by ``k * ID_STRIDE`` (an estimation evaluates far
#: fewer than 2^27 = 134 million points).
ID_STRIDE = 2**27


def repeat_seed(seed: int | np.random.SeedSequence, k: int) -> np.random.SeedSequence:
    """The root seed of repeat ``k`` (module docstring): the root itself for ``k = 0``."""
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(int(seed))
    if k == 0:
        return root
    return np.random.SeedSequence(root.entropy, spawn_key=tuple(root.spawn_key) + (REPEAT_KEY + k,))


def split_budget(max_evaluations: int | None, repeats: int) -> int | None:
    """Each repeat's share of a total budget of evaluations (None: no budget)."""
    return None if max_evaluations is None else max_evaluations // repeats


def offset_result(result: RareEventResult, k: int) -> RareEventResult:
    """``result`` of repeat ``k`` with its evaluation ids made global (``+ k * ID_STRIDE``)."""
    if k == 0:
        return result
    cf = result.closest_failure
    return replace(
        result,
        failures_id=np.asarray(result.failures_id, np.int64) + k * ID_STRIDE,
        closest_failure=None if cf is None else replace(cf, eval_id=cf.eval_id + k * ID_STRIDE),
    )


def model_cov2(result: RareEventResult) -> float:
    """One repeat's squared CoV by Au & Beck's usual formula (levels uncorrelated; the binomial
    one of plain Monte Carlo at level 0): the model the floor of :func:`combine_repeats` uses."""
    cov = result.cov_uncorrelated if result.cov_uncorrelated is not None else result.cov
    return float(cov) ** 2 if cov is not None and math.isfinite(cov) else 0.0


def _cox_interval(p: np.ndarray, confidence: float, s2_floor: float = 0.0) -> tuple[float, float]:
    """Cox's interval for the mean of a log-normal sample ``p`` (module docstring), the
    variance of ``ln p`` taken as at least ``s2_floor``."""
    k = p.size
    y = np.log(p)
    s2 = max(float(y.var(ddof=1)), s2_floor)
    centre = float(y.mean()) + s2 / 2.0
    half = float(stats.t.ppf(0.5 + confidence / 2.0, k - 1)) * math.sqrt(
        s2 / k + s2 * s2 / (2.0 * (k - 1))
    )
    return math.exp(centre - half), min(1.0, math.exp(centre + half))


def _t_interval(p: np.ndarray, confidence: float) -> tuple[float, float]:
    k = p.size
    half = float(stats.t.ppf(0.5 + confidence / 2.0, k - 1)) * float(p.std(ddof=1)) / math.sqrt(k)
    m = float(p.mean())
    return max(0.0, m - half), min(1.0, m + half)


def combine_repeats(
    results: list[RareEventResult], confidence: float = CONFIDENCE
) -> RareEventResult:
    """One result from ``K >= 2`` independent estimations (module docstring, "Statuses").

    Parameters
    ----------
    results : list of RareEventResult
        Repeat ``k``'s result at index ``k``, its ids already global (:func:`offset_result`).
    confidence : float

    Returns
    -------
    RareEventResult
        ``method`` names the repeats; ``repeats`` holds the parts; ``levels`` is empty (each
        part has its own); failures and the closest one are pooled over the parts.
    """
    k = len(results)
    if k < 2:
        raise ValueError(f"combining repeats needs at least 2 of them, got {k}")
    statuses = [r.status for r in results]
    n_eval = sum(r.n_evaluations for r in results)
    closest = [r.closest_failure for r in results if r.closest_failure is not None]
    fields: dict = dict(
        method=f"subset simulation, {k} independent repeats",
        confidence=confidence,
        n_evaluations=n_eval,
        levels=[],
        closest_failure=min(closest, key=lambda f: f.norm) if closest else None,
        failures_u=np.concatenate([r.failures_u for r in results]),
        failures_margin=np.concatenate([r.failures_margin for r in results]),
        failures_id=np.concatenate([np.asarray(r.failures_id, np.int64) for r in results]),
        n_nonfinite=sum(r.n_nonfinite for r in results),
        repeats=tuple(results),
    )
    if all(s == "not_resolved" for s in statuses):
        # The reason is the largest bound's own (how that bound is made), not repeat 0's.
        worst = max(range(k), key=lambda i: float(results[i].upper_bound or 0.0))
        bound = float(results[worst].upper_bound or 1.0)
        return RareEventResult(
            status="not_resolved",
            probability=None,
            cov=None,
            interval=None,
            upper_bound=bound,
            reason=(
                f"no failure in any of {k} independent repeats ({n_eval:,} evaluations); the "
                f"largest of their {k} one-sided bounds, repeat {worst}'s: " + results[worst].reason
            ),
            **fields,
        )
    if all(s == "monte_carlo" for s in statuses):
        n = sum(r.levels[0].n_samples for r in results)
        fails = sum(r.levels[0].n_failures for r in results)
        pooled = fails / n
        return RareEventResult(
            status="monte_carlo",
            probability=pooled,
            cov=math.sqrt((1.0 - pooled) / (n * pooled)) if 0.0 < pooled else None,
            interval=clopper_pearson(fails, n, confidence),
            upper_bound=None,
            reason=(
                f"{fails} of {n} independent samples failed at level 0 of {k} repeats: not "
                f"rare, plain Monte Carlo with its exact interval"
            ),
            **fields,
        )
    p = np.array([r.probability if r.probability is not None else 0.0 for r in results])
    mean = float(p.mean())
    measured = float(p.std(ddof=1)) / (math.sqrt(k) * mean)
    model2 = np.array([model_cov2(r) for r in results])
    floor = math.sqrt(float(model2.sum())) / k  # the CoV of a mean of k independent estimates
    cov = max(measured, floor)
    spread = f"the {k} estimates {', '.join(f'{x:.3g}' for x in p)}"
    if np.all(p > 0.0):
        early = [i for i, s in enumerate(statuses) if s == "budget"]
        status = "budget" if early else "converged"
        why = (
            f"mean of {k} independent subset simulations ({spread}), Cox's log-normal interval "
            + (
                "on their spread"
                if measured >= floor
                else f"on Au & Beck's CoV of their mean, {floor:.2f}, larger than the spread "
                f"measured over the {k} ({measured:.2f}; {k} values can agree by chance)"
            )
        )
        if early:
            ended = ", ".join(map(str, early))
            why += f"; the budget ended repeats {ended} before the failure level"
        return RareEventResult(
            status=status,
            probability=mean,
            cov=cov,
            interval=_cox_interval(p, confidence, math.log1p(float(model2.mean()))),
            upper_bound=None,
            reason=why,
            **fields,
        )
    none = [i for i, x in enumerate(p) if x == 0.0]
    return RareEventResult(
        status="budget",
        probability=mean,
        cov=cov,
        interval=_t_interval(p, confidence),
        upper_bound=None,
        reason=(
            f"repeats {', '.join(map(str, none))} saw no failure within their budget and count "
            f"0: mean of {spread}, Student's t interval clipped at 0"
        ),
        **fields,
    )


def repeated_subset_simulation(
    g: LimitState,
    dim: int,
    config: SubsetConfig,
    repeats: int,
    *,
    seed: int | np.random.SeedSequence,
    state_dir: str | os.PathLike | None = None,
    progress: Progress | None = None,
    u0: list[np.ndarray] | None = None,
    label: str = "",
) -> RareEventResult:
    """``repeats`` independent subset simulations of ``g``, one after the other, combined.

    Parameters
    ----------
    g, dim, progress, label
        As :func:`.subset_simulation`; ``g`` receives global ids (module docstring).
    config : SubsetConfig
        Of each repeat; its ``max_evaluations``, if set, is the total, split evenly.
    repeats : int
        ``K``; 1 is :func:`.subset_simulation` itself.
    seed : int or numpy.random.SeedSequence
    state_dir : path, optional
        Repeat ``k``'s state file is ``state_dir/state-k.npz`` (resumable per repeat).
    u0 : list of ndarray, optional
        Level 0's points of each repeat.

    Returns
    -------
    RareEventResult
    """
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    if u0 is not None and len(u0) != repeats:
        raise ValueError(
            f"u0 must hold one array of level-0 points per repeat ({repeats}), got {len(u0)}"
        )
    share = split_budget(config.max_evaluations, repeats)
    if share is not None and share < config.n_per_level:
        raise ValueError(
            f"max_evaluations ({config.max_evaluations}) must allow level 0 of each of the "
            f"{repeats} repeats ({repeats} x {config.n_per_level} evaluations)"
        )
    per = replace(config, max_evaluations=share)
    results = []
    for k in range(repeats):

        def g_k(u: np.ndarray, ids: np.ndarray, _k: int = k) -> np.ndarray:
            return g(u, np.asarray(ids, np.int64) + _k * ID_STRIDE)

        path = None if state_dir is None else Path(state_dir) / f"state-{k}.npz"
        res = subset_simulation(
            g_k,
            dim,
            per if repeats > 1 else config,
            seed=repeat_seed(seed, k),
            state_path=path,
            progress=progress,
            u0=None if u0 is None else u0[k],
            label=label,
        )
        results.append(offset_result(res, k))
    return results[0] if repeats == 1 else combine_repeats(results, config.confidence)
