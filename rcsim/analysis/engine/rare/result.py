"""What a rare-event estimation reports: the estimate and its interval, or the bound the budget
allows; the evaluations spent; the failure points found and the likeliest of them.

Statuses
--------
``converged``
    The estimator reached the failure region with enough samples: ``probability``, ``cov``
    and ``interval`` (log-normal on Au & Beck's CoV, :mod:`.intervals`).
``monte_carlo``
    At least ``p0 N`` of the ``N`` independent samples of level 0 already failed: the failure
    region is not rare, and the estimate is plain Monte Carlo with its exact (Clopper-Pearson)
    interval.  A case that always fails lands here with ``probability = 1``.
``budget``
    The budget ended (or the margin stopped decreasing: every sample of a level at or below
    its threshold) at a level that saw some failures but fewer than ``p0 N``: the estimate
    rests on those few (its CoV says how little), flagged so a reader does not take it for a
    converged one.
``not_resolved``
    The budget ended (or the margin stopped decreasing) before any failure was seen: no
    estimate; ``upper_bound`` is a one-sided bound at ``confidence`` (``reason`` says how it
    is made).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rcsim.analysis.engine.rare.intervals import plain_mc_runs
from rcsim.analysis.engine.rare.state import LevelRecord

STATUSES = ("converged", "monte_carlo", "budget", "not_resolved")


@dataclass(frozen=True)
class FailurePoint:
    """One failure sample in standard-normal space.

    Attributes
    ----------
    u : ndarray, (d,)
        Its coordinates [sigmas].
    norm : float
        ``|u|`` [sigmas]: the smaller, the likelier the point under the input distribution.
    margin : float
        Its margin (below 0; ``-inf``: not finite).
    eval_id : int
        Its evaluation id.
    """

    u: np.ndarray
    norm: float
    margin: float
    eval_id: int

    def largest(self, names=None, count: int = 5) -> list[tuple[str, float]]:
        """The ``count`` coordinates of largest magnitude, ``(name, sigmas)``, largest first
        (names default to ``u0, u1, ...``)."""
        names = list(names) if names is not None else [f"u{i}" for i in range(self.u.size)]
        order = np.argsort(-np.abs(self.u), kind="stable")[:count]
        return [(names[i], float(self.u[i])) for i in order]


@dataclass(frozen=True)
class RareEventResult:
    """The outcome of :func:`~rcsim.analysis.engine.rare.subset.subset_simulation` (or another
    estimator of this package).

    Attributes
    ----------
    method : str
        ``"subset simulation"`` (or the estimator's name).
    status : str
        One of :data:`STATUSES` (module docstring).
    probability : float or None
        The estimate of ``P(g(u) < 0)``; None when ``not_resolved``.
    cov : float or None
        Its coefficient of variation: for one subset simulation Au & Beck's bound with the
        levels fully correlated, ``sum_j delta_j`` (:mod:`.intervals`: the formula whose
        intervals were measured to cover; ``docs/rare_events.md``); for independent repeats
        the measured one, ``s / (sqrt(K) mean)`` (:mod:`.repeats`); plain Monte Carlo's
        binomial one at level 0.
    interval : (float, float) or None
        Two-sided interval at ``confidence``.
    upper_bound : float or None
        One-sided bound at ``confidence`` when ``not_resolved``.
    confidence : float
    n_evaluations : int
        Limit-state evaluations spent (the runs).
    levels : list of LevelRecord
    closest_failure : FailurePoint or None
        The failure sample with the smallest ``|u|``.
    failures_u, failures_margin, failures_id : ndarray
        Every failure sample evaluated, once each: (k, d), (k,), (k,).
    n_nonfinite : int
        Evaluations whose margin was not finite (counted failed, margin ``-inf``).
    reason : str
        One sentence on how the result was reached (the bound's make-up when
        ``not_resolved``).
    cov_uncorrelated : float or None
        Au & Beck's usual CoV with the levels taken as uncorrelated, ``sqrt(sum_j delta_j^2)``,
        for reference: its intervals were measured to cover less than their nominal level.
    extra : dict
        Estimator-specific figures.
    repeats : tuple of RareEventResult
        The independent estimations this result combines (:mod:`.repeats`); empty for one.
    """

    method: str
    status: str
    probability: float | None
    cov: float | None
    interval: tuple[float, float] | None
    upper_bound: float | None
    confidence: float
    n_evaluations: int
    levels: list[LevelRecord]
    closest_failure: FailurePoint | None
    failures_u: np.ndarray
    failures_margin: np.ndarray
    failures_id: np.ndarray
    n_nonfinite: int = 0
    reason: str = ""
    cov_uncorrelated: float | None = None
    extra: dict = field(default_factory=dict)
    repeats: tuple[RareEventResult, ...] = ()

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, got {self.status!r}")

    @property
    def n_failures(self) -> int:
        return int(self.failures_id.size)

    def plain_mc_equivalent(self) -> float | None:
        """Runs plain Monte Carlo would need for this estimate's CoV, ``(1 - P)/(P CoV^2)``;
        None without an estimate (or with a zero one)."""
        if not self.probability or not self.cov:
            return None
        return plain_mc_runs(self.probability, self.cov)

    def summary(self) -> str:
        """One line for a terminal or a log, every figure from the fields above."""
        pct = f"{self.confidence:.0%}"
        if self.status == "not_resolved":
            head = (
                f"P(fail) not resolved in {self.n_evaluations:,} evaluations: "
                f"P < {self.upper_bound:.3g} ({pct} one-sided)"
            )
        else:
            assert self.probability is not None and self.interval is not None
            lo, hi = self.interval
            cov = "" if self.cov is None or not math.isfinite(self.cov) else f", CoV {self.cov:.2f}"
            head = (
                f"P(fail) = {self.probability:.3g} ({pct} interval {lo:.3g} - {hi:.3g}{cov}) "
                f"by {self.method} in {self.n_evaluations:,} evaluations"
            )
            if self.status == "budget":
                head += " [stopped before the failure level: few failure samples]"
        if self.closest_failure is not None:
            head += f"; closest failure at {self.closest_failure.norm:.2f} sigma"
        return head
