"""A failure with several criteria, estimated as the series system it is.

Why
---
A run fails when *any* of its criteria fails (rate, attitude, a propellant or delta-v budget):
the failure region is the union ``F = F_1 u ... u F_k`` of the criteria's regions
``F_i = {g_i(u) < 0}``.  Subset simulation on the single margin ``min_i g_i`` follows whichever
criterion is closest at nominal; its chains may never reach a criterion that fails further out
but more often, and then report a confident bound or interval far below the truth
(``docs/rare_events.md``, "Several criteria").  Here each criterion is estimated by its own
subset simulations, on its own margin, and the criteria are combined with bounds that hold
whatever their overlap.

Method
------
``g(u, ids)`` returns the margins of every criterion at once, shape (n, k): one flight gives all
of them.  For each criterion ``i``, :func:`.repeats.repeated_subset_simulation` runs on the
margin ``g_i`` at confidence ``1 - alpha / k`` (Bonferroni, below).  Every evaluation is recorded
with all ``k`` margins, so that

* level 0 is flown once: every criterion starts from the same ``K N`` independent points (repeat
  ``k``'s level 0 is the one a plain repeated estimation would draw), and each criterion's chains
  then draw from their own stream (the root's child ``(CRITERION_KEY + i,)``, the root itself
  for the first: one criterion is :func:`.repeats.repeated_subset_simulation` bit for bit);
* a point evaluated for criterion ``A``'s chains tells whether it fails ``B``: these records
  give the joint estimate and the exploration check below.

Combination (series-system bounds, Ditlevsen's first-order ones): ``max_i P_i <= P(F) <= sum_i
P_i``.  With each criterion's two-sided interval ``(lo_i, hi_i)`` at ``1 - alpha / k`` (or its
one-sided bound ``hi_i`` when it saw no failure, ``lo_i = 0``), the reported interval is

    ( max_i lo_i ,  min(1, sum_i hi_i) ).

It holds ``P(F)`` whenever every criterion's interval holds its ``P_i`` (``P(F) >= P_i >= lo_i``
and ``P(F) <= sum P_i <= sum hi_i``); each of the ``2 k`` one-sided misses has probability at
most ``alpha / (2 k)``, so the interval covers with probability at least ``1 - alpha``
whatever the dependence between the criteria's estimates (Bonferroni).  Measured coverage is in
``docs/rare_events.md``.

The joint estimate (from the same samples).  ``1_F = sum_i 1_{F_i} / m(u)`` with ``m(u)`` the
number of criteria failing at ``u``, so ``P(F) = sum_i P_i E[1 / m | F_i]``.  Every failure
sample of criterion ``i``'s chains is a sample of the input law conditioned on ``F_i``; its
other margins are recorded, so ``E[1 / m | F_i]`` is the mean of ``1 / m`` over them.  The point
estimate is ``sum_i P_i w_i`` over the criteria with an estimate (those with a bound only add
nothing to it, and their bound to the upper end), clipped into the interval; its CoV is not
modelled -- the interval is the statement.

Exploration.  A criterion's region counts as explored when its own chains were run on its own
margin; the check that can fail: if its own chains saw no failure of it while points evaluated
for other criteria did fail it, its chains did not find its region, and no bound or interval is
given (status ``not_explored``; the text names the criterion and what would resolve it).

Evaluation ids
--------------
Evaluation ``e`` of repeat ``r`` of criterion ``i`` is flown as id ``r 2^27 + e`` when ``e < N``
(level 0, shared) and ``r 2^27 + i 2^23 + e`` otherwise (:func:`flight_ids`): a campaign gives
each id its own run identity, and a criterion's estimation evaluates far fewer than 2^23 points.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from rcsim.analysis.engine.rare.intervals import CONFIDENCE
from rcsim.analysis.engine.rare.repeats import (
    ID_STRIDE,
    combine_repeats,
    offset_result,
    repeat_seed,
)
from rcsim.analysis.engine.rare.result import RareEventResult
from rcsim.analysis.engine.rare.state import level_generator
from rcsim.analysis.engine.rare.subset import SubsetConfig, subset_simulation

#: ``g(u, ids) -> margins``: points (n, d) and evaluation ids (n,) in, margins (n, k) out, one
#: column per criterion (below 0, or not finite: failed).
MultiLimitState = Callable[[np.ndarray, np.ndarray], np.ndarray]
#: Criterion ``i``'s chain evaluations are offset by ``i * CRITERION_STRIDE`` inside a repeat.
CRITERION_STRIDE = 2**23
#: At most this many criteria (their id ranges must fit in a repeat's ``ID_STRIDE``).
MAX_CRITERIA = ID_STRIDE // CRITERION_STRIDE
#: Criterion ``i``'s chains draw from the root's child ``(CRITERION_KEY + i,)``.
CRITERION_KEY = 2**30

SERIES_STATUSES = ("converged", "budget", "partial", "not_resolved", "not_explored")


def flight_ids(ids: np.ndarray, criterion: int, n0: int) -> np.ndarray:
    """The flown ids of criterion ``criterion``'s (global, repeat-offset) evaluation ids
    ``ids``: level 0 (``ids % 2^27 < n0``) shared, later ones offset (module docstring)."""
    ids = np.asarray(ids, np.int64)
    return np.where(ids % ID_STRIDE < n0, ids, ids + criterion * CRITERION_STRIDE)


def criterion_seed(seed: int | np.random.SeedSequence, i: int) -> np.random.SeedSequence:
    """The root of criterion ``i``'s chains (module docstring): the root itself for ``i = 0``,
    so that one criterion is :func:`.repeats.repeated_subset_simulation` bit for bit."""
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(int(seed))
    if i == 0:
        return root
    return np.random.SeedSequence(
        root.entropy, spawn_key=tuple(root.spawn_key) + (CRITERION_KEY + i,)
    )


def level_zero_points(
    seed: int | np.random.SeedSequence, dim: int, n: int, repeats: int
) -> list[np.ndarray]:
    """Repeat ``k``'s level-0 points, ``k < repeats``: those a plain repeated estimation on
    ``seed`` draws (level 0's stream of :func:`.repeats.repeat_seed`)."""
    return [
        level_generator(repeat_seed(seed, k), 0).standard_normal((n, dim)) for k in range(repeats)
    ]


def series_budget(max_evaluations: int | None, n0: int, repeats: int, k: int) -> int | None:
    """Each criterion-repeat's ``max_evaluations`` (its level 0 counted, as the estimator
    counts it) when ``max_evaluations`` flights are shared by ``k`` criteria and ``repeats``
    repeats: level 0 is flown once (``repeats n0``), the rest split evenly."""
    if max_evaluations is None:
        return None
    if max_evaluations < repeats * n0:
        raise ValueError(
            f"max_evaluations ({max_evaluations}) must allow level 0 of each of the {repeats} "
            f"repeats ({repeats} x {n0} evaluations)"
        )
    return n0 + (max_evaluations - repeats * n0) // (repeats * k)


class Record:
    """Every flight's margins of every criterion, by flown id (module docstring)."""

    def __init__(self, k: int):
        self.k = k
        self.margins: dict[int, np.ndarray] = {}

    def add(self, ids: np.ndarray, margins: np.ndarray) -> None:
        for i, row in zip(np.asarray(ids, np.int64).tolist(), margins):
            self.margins[int(i)] = row

    def lookup(self, ids: np.ndarray) -> np.ndarray:
        """(n, k) the recorded margins of flown ids ``ids``."""
        if len(ids) == 0:
            return np.empty((0, self.k))
        return np.vstack([self.margins[int(i)] for i in np.asarray(ids, np.int64)])

    def _all(self) -> np.ndarray:
        return np.vstack(list(self.margins.values())) if self.margins else np.empty((0, self.k))

    def n_failed(self) -> int:
        """Flights that failed any criterion."""
        return int(np.sum(np.any(~(self._all() >= 0.0), axis=1)))

    def n_nonfinite(self) -> int:
        """Flights with a margin that is not finite (a run not flown: every criterion fails)."""
        return int(np.sum(np.any(~np.isfinite(self._all()), axis=1)))

    def failing(self) -> np.ndarray:
        """(k,) how many recorded flights fail each criterion."""
        if not self.margins:
            return np.zeros(self.k, int)
        m = np.vstack(list(self.margins.values()))
        return np.sum(~(m >= 0.0), axis=0)


def recording(g: MultiLimitState, k: int, record: Record) -> MultiLimitState:
    """``g`` that flies only ids not yet recorded, and records what it flies (shape-checked)."""

    def g_rec(u: np.ndarray, ids: np.ndarray) -> np.ndarray:
        ids = np.asarray(ids, np.int64)
        new = np.array([int(i) not in record.margins for i in ids], bool)
        if new.any():
            m = np.asarray(g(u[new], ids[new]), float)
            if m.shape != (int(new.sum()), k):
                raise ValueError(
                    f"the limit state returned margins of shape {m.shape} for "
                    f"{int(new.sum())} points and {k} criteria"
                )
            record.add(ids[new], m)
        return record.lookup(ids)

    return g_rec


def criterion_limit_state(g_rec: MultiLimitState, i: int, n0: int):
    """Criterion ``i``'s scalar margin, its ids mapped to flown ones (:func:`flight_ids`)."""

    def g_i(u: np.ndarray, ids: np.ndarray) -> np.ndarray:
        return g_rec(u, flight_ids(ids, i, n0))[:, i]

    return g_i


@dataclass(frozen=True)
class SeriesResult:
    """A failure with several criteria (module docstring).

    Attributes
    ----------
    names : tuple of str
        The criteria, in the margin's column order.
    criteria : tuple of RareEventResult
        Each criterion's own estimation, at ``criterion_confidence``.
    status : str
        ``converged`` (every criterion estimated, converged or counted at level 0), ``budget``
        (every criterion estimated, some only up to the budget), ``partial`` (some criteria saw
        no failure: their bounds enter the upper end), ``not_resolved`` (no criterion saw a
        failure: an upper bound), ``not_explored`` (a criterion's region was not explored: no
        bound, no interval; ``unexplored`` names it).
    probability : float or None
        The joint estimate ``sum_i P_i E[1/m | F_i]`` (module docstring); None without one.
    interval : (float, float) or None
        ``(max_i lo_i, min(1, sum_i hi_i))`` at ``confidence``.
    upper_bound : float or None
        ``min(1, sum_i bound_i)`` when ``not_resolved``.
    confidence, criterion_confidence : float
        Of the combination, and of each criterion's interval (``1 - (1 - confidence) / k``).
    n_evaluations : int
        Distinct points evaluated (flights), level 0 counted once.
    weights : tuple of float or None
        ``E[1/m | F_i]`` per criterion (None: no failure sample of it).
    unexplored : tuple of str
        Criteria whose regions were not explored.
    found_elsewhere : tuple of int
        Per criterion, the recorded flights that failed it.
    reason : str
        How the result was reached, and for ``not_explored`` what would resolve it.
    n_failures, n_nonfinite : int
        Flights that failed any criterion; flights with a margin not finite.
    """

    names: tuple[str, ...]
    criteria: tuple[RareEventResult, ...]
    status: str
    probability: float | None
    interval: tuple[float, float] | None
    upper_bound: float | None
    confidence: float
    criterion_confidence: float
    n_evaluations: int
    weights: tuple[float | None, ...]
    unexplored: tuple[str, ...] = ()
    found_elsewhere: tuple[int, ...] = ()
    reason: str = ""
    n_failures: int = 0
    n_nonfinite: int = 0
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.status not in SERIES_STATUSES:
            raise ValueError(f"status must be one of {SERIES_STATUSES}, got {self.status!r}")

    def criterion_text(self, i: int) -> str:
        """Criterion ``i``'s own figures in one phrase."""
        r = self.criteria[i]
        pct = f"{self.criterion_confidence:.1%}"
        if r.status == "not_resolved":
            return f"{self.names[i]}: no failure seen, P < {r.upper_bound:.3g} ({pct} one-sided)"
        assert r.probability is not None and r.interval is not None
        lo, hi = r.interval
        return f"{self.names[i]}: P = {r.probability:.3g} ({pct} interval {lo:.3g} - {hi:.3g})"

    def summary(self) -> str:
        """One line for a terminal or a log, every figure from the fields above."""
        pct = f"{self.confidence:.0%}"
        if self.status == "not_explored":
            return f"P(fail) not estimated in {self.n_evaluations:,} evaluations: {self.reason}"
        parts = "; ".join(self.criterion_text(i) for i in range(len(self.names)))
        if self.status == "not_resolved":
            return (
                f"P(fail) not resolved in {self.n_evaluations:,} evaluations: P < "
                f"{self.upper_bound:.3g} ({pct} one-sided, the sum of the criteria's bounds; "
                f"{parts})"
            )
        assert self.interval is not None
        lo, hi = self.interval
        head = (
            f"P(fail) = {self.probability:.3g} ({pct} interval {lo:.3g} - {hi:.3g}, series "
            f"bounds over {len(self.names)} criteria) in {self.n_evaluations:,} evaluations"
        )
        if self.status == "budget":
            head += " [the budget ended some criteria before their failure level]"
        elif self.status == "partial":
            head += " [some criteria saw no failure: their bounds enter the upper end]"
        return f"{head}; {parts}"


def _resolve_hint(config: SubsetConfig, max_evaluations: int | None) -> str:
    more = f"more runs per level than {config.n_per_level:,}"
    budget = "" if max_evaluations is None else f" or a budget above {max_evaluations:,}"
    return f"{more}{budget}, so that its own chains reach its failure region"


def _ends(r: RareEventResult) -> tuple[float, float]:
    """A criterion's (lower, upper) ends: its interval, or (0, its bound) without one."""
    if r.interval is not None:
        return float(r.interval[0]), float(r.interval[1])
    return 0.0, float(r.upper_bound if r.upper_bound is not None else 1.0)


def combine_series(
    names: Sequence[str],
    criteria: Sequence[RareEventResult],
    failing_margins: Sequence[np.ndarray],
    found_elsewhere: np.ndarray,
    n_evaluations: int,
    confidence: float = CONFIDENCE,
    resolve: str = "more runs per level or a larger budget",
    n_failures: int = 0,
    n_nonfinite: int = 0,
) -> SeriesResult:
    """Combine the criteria's estimations (module docstring, "Combination").

    Parameters
    ----------
    names : sequence of str
    criteria : sequence of RareEventResult
        Criterion ``i``'s estimation on its own margin, at ``1 - (1 - confidence) / k``.
    failing_margins : sequence of ndarray
        Per criterion, (n_i, k) every criterion's margins at its own failure samples.
    found_elsewhere : ndarray, (k,)
        Per criterion, the flights evaluated (for any criterion) that failed it.
    n_evaluations : int
        Distinct flights.
    confidence : float
    resolve : str
        What would resolve an unexplored criterion (the caller's words: its flags).
    n_failures, n_nonfinite : int
        Flights that failed any criterion, and with a margin not finite.

    Returns
    -------
    SeriesResult
    """
    k = len(names)
    c_i = 1.0 - (1.0 - confidence) / k
    weights: list[float | None] = []
    for i in range(k):
        m = np.asarray(failing_margins[i], float).reshape(-1, k)
        if m.shape[0] == 0:
            weights.append(None)
            continue
        multiplicity = np.maximum(np.sum(~(m >= 0.0), axis=1), 1)
        weights.append(float(np.mean(1.0 / multiplicity)))
    found = tuple(int(x) for x in np.asarray(found_elsewhere).reshape(k))
    common: dict[str, Any] = dict(
        names=tuple(names),
        criteria=tuple(criteria),
        confidence=confidence,
        criterion_confidence=c_i,
        n_evaluations=int(n_evaluations),
        weights=tuple(weights),
        found_elsewhere=found,
        n_failures=int(n_failures),
        n_nonfinite=int(n_nonfinite),
    )
    missed = [i for i, r in enumerate(criteria) if r.status == "not_resolved" and found[i] > 0]
    if missed:
        which = ", ".join(
            f"'{names[i]}' (its own chains saw no failure of it; {found[i]:,} of the points "
            f"flown for the other criteria failed it)"
            for i in missed
        )
        return SeriesResult(
            status="not_explored",
            probability=None,
            interval=None,
            upper_bound=None,
            unexplored=tuple(names[i] for i in missed),
            reason=(
                f"the region of criterion {which} was not explored, so no bound or interval on "
                f"P(fail) can be stated; to resolve it: {resolve}"
            ),
            **common,
        )
    estimated = [i for i, r in enumerate(criteria) if r.status != "not_resolved"]
    if not estimated:
        bound = min(1.0, sum(float(r.upper_bound or 1.0) for r in criteria))
        return SeriesResult(
            status="not_resolved",
            probability=None,
            interval=None,
            upper_bound=bound,
            reason=(
                f"no criterion saw a failure on its own chains; the sum of their {k} one-sided "
                f"bounds at {c_i:.1%} each (Bonferroni: {confidence:.0%} jointly)"
            ),
            **common,
        )
    ends = [_ends(r) for r in criteria]
    lo = max(ends[i][0] for i in estimated)
    hi = min(1.0, sum(end[1] for end in ends))
    point = sum(float(criteria[i].probability or 0.0) * (weights[i] or 1.0) for i in estimated)
    point = min(max(point, lo), hi)
    if len(estimated) < k:
        status = "partial"
    elif any(r.status == "budget" for r in criteria):
        status = "budget"
    else:
        status = "converged"
    bounded = [names[i] for i in range(k) if i not in estimated]
    why = (
        f"series-system bounds: the largest lower end and the sum of the upper ends of the "
        f"{k} criteria's {c_i:.1%} intervals (Bonferroni: {confidence:.0%} jointly); the "
        f"estimate weighs each criterion's P by the mean of 1 / (criteria failed) over its "
        f"failure samples"
    )
    if bounded:
        why += f"; {', '.join(bounded)} saw no failure and enter by their one-sided bounds"
    return SeriesResult(
        status=status,
        probability=point,
        interval=(lo, hi),
        upper_bound=None,
        reason=why,
        **common,
    )


@dataclass(frozen=True)
class SeriesRepeat:
    """One repeat of every criterion (:func:`series_repeat`).

    Attributes
    ----------
    parts : tuple of RareEventResult
        Criterion ``i``'s estimation of this repeat, its ids global (repeat offset).
    failing : tuple of ndarray
        Per criterion, (n_i, k) every criterion's margins at its failure samples.
    found : ndarray, (k,)
        Flights of this repeat that failed each criterion.
    flights : int
        Distinct flights of this repeat.
    n_failures, n_nonfinite : int
        Of them, those that failed any criterion, and those with a margin not finite.
    """

    parts: tuple[RareEventResult, ...]
    failing: tuple[np.ndarray, ...]
    found: np.ndarray
    flights: int
    n_failures: int = 0
    n_nonfinite: int = 0


def series_config(config: SubsetConfig, repeats: int, k: int) -> SubsetConfig:
    """Each criterion-repeat's config: confidence ``1 - (1 - c) / k``, budget
    :func:`series_budget` (``config.max_evaluations`` the total of flights)."""
    return replace(
        config,
        confidence=1.0 - (1.0 - config.confidence) / k,
        max_evaluations=series_budget(config.max_evaluations, config.n_per_level, repeats, k),
    )


def _named(progress: Callable[[str, object], None], name: str) -> Callable[[object], None]:
    def call(record: object) -> None:
        progress(name, record)

    return call


def series_repeat(
    g: MultiLimitState,
    dim: int,
    per: SubsetConfig,
    names: Sequence[str],
    r: int,
    *,
    seed: int | np.random.SeedSequence,
    u0: np.ndarray,
    state_paths: Sequence | None = None,
    progress: Callable[[str, object], None] | None = None,
    label: str = "",
    record: Record | None = None,
) -> SeriesRepeat:
    """Repeat ``r`` of every criterion: criterion ``i`` by subset simulation on its own margin
    from the shared level 0 ``u0``, its chains on :func:`criterion_seed`'s repeat ``r``.

    Parameters
    ----------
    g : callable
        ``g(u, ids) -> (n, k)``; receives flown ids (:func:`flight_ids`, repeat offset
        included), each once.
    dim : int
    per : SubsetConfig
        Of each criterion (:func:`series_config`).
    names : sequence of str
    r : int
    seed : int or numpy.random.SeedSequence
        The estimation's root.
    u0 : ndarray, (n_per_level, dim)
        This repeat's level 0.
    state_paths : sequence of path, optional
        Criterion ``i``'s state file (resumable).
    progress : callable, optional
        ``progress(name, level record)`` after each level of each criterion.
    label : str
        Of the state files: suffixed by the criterion's name when there are several (one
        criterion keeps it as given, so a single-margin estimation's state file resumes).
    record : Record, optional
        The flights already made (a resumed estimation's, read back from its files): not
        flown again, and their margins known to the joint estimate.

    Returns
    -------
    SeriesRepeat
    """
    k = len(names)
    n0 = per.n_per_level
    record = Record(k) if record is None else record
    g_rec = recording(g, k, record)
    parts, failing = [], []
    for i, name in enumerate(names):
        g_i = criterion_limit_state(g_rec, i, n0)

        def g_ir(u: np.ndarray, ids: np.ndarray, _g=g_i) -> np.ndarray:
            return _g(u, np.asarray(ids, np.int64) + r * ID_STRIDE)

        res = subset_simulation(
            g_ir,
            dim,
            per,
            seed=repeat_seed(criterion_seed(seed, i), r),
            state_path=None if state_paths is None else state_paths[i],
            progress=None if progress is None else _named(progress, name),
            u0=u0,
            label=label if k == 1 else f"{label} criterion {name}",
        )
        res = offset_result(res, r)
        parts.append(res)
        failing.append(record.lookup(flight_ids(res.failures_id, i, n0)))
    return SeriesRepeat(
        tuple(parts),
        tuple(failing),
        record.failing(),
        len(record.margins),
        record.n_failed(),
        record.n_nonfinite(),
    )


def combine_series_repeats(
    names: Sequence[str],
    repeats: Sequence[SeriesRepeat],
    confidence: float = CONFIDENCE,
    resolve: str = "more runs per level or a larger budget",
) -> SeriesResult:
    """Each criterion's repeats combined (:func:`.repeats.combine_repeats`), then the criteria
    (:func:`combine_series`)."""
    k = len(names)
    c_i = 1.0 - (1.0 - confidence) / k
    criteria = []
    for i in range(k):
        parts = [rep.parts[i] for rep in repeats]
        criteria.append(parts[0] if len(parts) == 1 else combine_repeats(parts, c_i))
    failing = [np.vstack([rep.failing[i] for rep in repeats]) for i in range(k)]
    return combine_series(
        names,
        criteria,
        failing,
        np.sum([rep.found for rep in repeats], axis=0),
        sum(rep.flights for rep in repeats),
        confidence,
        resolve,
        sum(rep.n_failures for rep in repeats),
        sum(rep.n_nonfinite for rep in repeats),
    )


def series_subset_simulation(
    g: MultiLimitState,
    dim: int,
    config: SubsetConfig,
    repeats: int,
    *,
    seed: int | np.random.SeedSequence,
    names: Sequence[str],
    label: str = "",
) -> SeriesResult:
    """``P(min_i g_i(u) < 0)`` as a series system of the criteria ``g_i`` (module docstring).

    Parameters
    ----------
    g : callable
        ``g(u, ids) -> (n, k)`` margins, one column per criterion (``names``).
    dim : int
    config : SubsetConfig
        Its ``max_evaluations``, if set, is the total of distinct evaluations (level 0 counted
        once), split by :func:`series_budget`; its ``confidence`` is the combination's (each
        criterion runs at ``1 - (1 - confidence) / k``).
    repeats : int
        ``K`` independent subset simulations per criterion.
    seed : int or numpy.random.SeedSequence
    names : sequence of str
        The criteria (``k`` of them, at most :data:`MAX_CRITERIA`).
    label : str
        As :func:`.subset.subset_simulation`.

    Returns
    -------
    SeriesResult
    """
    k = len(names)
    if not 1 <= k <= MAX_CRITERIA:
        raise ValueError(f"names must name 1 to {MAX_CRITERIA} criteria, got {k}")
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    per = series_config(config, repeats, k)
    u0 = level_zero_points(seed, dim, config.n_per_level, repeats)
    outcomes = [
        series_repeat(g, dim, per, names, r, seed=seed, u0=u0[r], label=label)
        for r in range(repeats)
    ]
    return combine_series_repeats(
        names, outcomes, config.confidence, _resolve_hint(config, config.max_evaluations)
    )


def union_probability(p: Sequence[float]) -> float:
    """``1 - prod_i (1 - p_i)``: the union of independent events (the tests' analytic truth for
    half-spaces in independent coordinates), computed without cancellation."""
    return -math.expm1(sum(math.log1p(-float(x)) for x in p))
