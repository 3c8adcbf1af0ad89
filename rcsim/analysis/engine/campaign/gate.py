"""The failure gate: does a finished campaign's failure percentage stay within a limit?

A team puts "the refined table still holds" in its CI by running a campaign with a limit
``max_failed_pct`` (spec key ``failure.max_failed_pct``, or the ``rcsim campaign run`` option
that overrides it): the campaign is written in full either way, and the gate's verdict is
the command's exit status.  The gate judges results; it changes nothing that is flown, so it
is not part of the spec's digest (a campaign may be resumed under another limit).

A campaign *exceeds* the limit when ``100 * failed / runs > max_failed_pct``: a limit of 0
tolerates no failure, 100 tolerates every run failing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rcsim.models.errors import InputError

#: The limit's range, in percent of the campaign's runs.
MIN_PCT, MAX_PCT = 0.0, 100.0
_RANGE = f"a percentage from {MIN_PCT:g} to {MAX_PCT:g}"


def max_failed_pct_problem(value) -> str | None:
    """Why ``value`` is not a valid limit (None: it is one).

    Parameters
    ----------
    value : object
        As read from a spec or given by a caller: must be an int or float (not a bool) in
        [0, 100], percent of the campaign's runs.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"must be {_RANGE} (a number)"
    if math.isnan(value) or not MIN_PCT <= value <= MAX_PCT:
        return f"must be {_RANGE}"
    return None


def check_max_failed_pct(value) -> float:
    """``value`` as a float, or :class:`InputError` about parameter ``max_failed_pct``."""
    problem = max_failed_pct_problem(value)
    if problem is not None:
        raise InputError(f"{problem}, got {value!r}", parameter="max_failed_pct", value=value)
    return float(value)


@dataclass(frozen=True)
class GateResult:
    """The gate's verdict on a campaign's counts.

    Attributes
    ----------
    runs, failed : int
        Runs of the campaign, and how many failed (``failed`` column of runs.parquet).
    max_failed_pct : float
        The limit, percent.
    """

    runs: int
    failed: int
    max_failed_pct: float

    @property
    def failed_pct(self) -> float:
        """Failed runs, percent of all runs (0 for an empty campaign)."""
        return 100.0 * self.failed / self.runs if self.runs else 0.0

    @property
    def passed(self) -> bool:
        # Compared without dividing, so 5 failures in 100 runs is exactly at a 5 % limit.
        return 100 * self.failed <= self.max_failed_pct * self.runs

    def text(self) -> str:
        """One line: the failure percentage against the limit and the verdict."""
        relation = "<=" if self.passed else ">"
        return (
            f"gate {'passed' if self.passed else 'failed'}: {self.failed_pct:.6g} % of "
            f"runs failed ({self.failed} of {self.runs}) {relation} max_failed_pct "
            f"{self.max_failed_pct:g} %"
        )

    def to_json(self) -> dict:
        return {
            "max_failed_pct": self.max_failed_pct,
            "runs": self.runs,
            "failed": self.failed,
            "failed_pct": self.failed_pct,
            "passed": self.passed,
        }


def judge(counts: dict, max_failed_pct: float) -> GateResult:
    """The gate on a campaign's ``counts`` (``manifest.json``'s ``runs`` and ``failed``)."""
    return GateResult(
        runs=int(counts.get("runs", 0)),
        failed=int(counts.get("failed", 0)),
        max_failed_pct=check_max_failed_pct(max_failed_pct),
    )
