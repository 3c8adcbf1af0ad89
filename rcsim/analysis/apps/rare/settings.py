"""How ``rcsim campaign rare`` estimates each case: the method, the runs per level, the budget,
the repeats (``--method``, ``--runs-per-level``, ``--budget``, ``--repeats``).  Recorded in
``rare.json``; a directory resumes only with the settings it began with."""

from __future__ import annotations

from dataclasses import dataclass

from rcsim.analysis.engine.rare import SubsetConfig

#: Independent repeats per case by default: Cox's interval on 4 estimates, with the model's CoV
#: as its floor (rcsim.analysis.engine.rare.repeats; its measured coverage in
#: docs/rare_events.md).
REPEATS = 4
#: The methods the command offers.  Cross-entropy importance sampling (one Gaussian,
#: rcsim.analysis.engine.rare.importance) is left out: on rate-13 (Table 5 x 3, 0.05 deg/s,
#: P ~ 6e-2 by subset simulation and plain counting) it reported 1.1e-19 with a CoV of 0.43 --
#: its weights degenerate in 53 dimensions, the failure docs/rare_events.md measured.
METHODS = ("subset",)


@dataclass(frozen=True)
class RareSettings:
    """How each case is estimated.

    Attributes
    ----------
    method : str
        ``"subset"`` (subset simulation, resumable; :data:`METHODS`).
    n_per_level : int
        Runs per level of each repeat.
    budget : int
        Most runs per case, all repeats and criteria together: level 0 of each repeat is
        flown once for every criterion, the rest split evenly (one criterion: each repeat gets
        ``budget // repeats``).
    repeats : int
        Independent subset simulations per case (1: one, with its conservative CoV).
    """

    method: str = "subset"
    n_per_level: int = 500
    budget: int = 20_000
    repeats: int = REPEATS

    def record(self) -> dict:
        return {
            "method": self.method,
            "n_per_level": self.n_per_level,
            "budget": self.budget,
            "repeats": self.repeats,
        }

    def config(self) -> SubsetConfig:
        """The estimation's :class:`SubsetConfig`: ``n_per_level`` and the whole ``budget`` (runs
        flown, level 0 once), which :func:`rcsim.analysis.engine.rare.series.series_config`
        splits over the repeats and the criteria."""
        return SubsetConfig(n_per_level=self.n_per_level, max_evaluations=self.budget)
