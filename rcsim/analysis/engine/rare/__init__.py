"""Rare-event estimation: ``P(g(u) < 0)`` for ``u ~ N(0, I_d)`` with a margin ``g`` evaluated on
batches of points, down to failure probabilities plain Monte Carlo cannot afford.

* :mod:`~rcsim.analysis.engine.rare.subset` -- subset simulation (Au & Beck, 2001) with batched
  Markov chains (Papaioannou et al., 2015), resumable level by level;
* :mod:`~rcsim.analysis.engine.rare.repeats` -- ``K`` independent subset simulations combined:
  the mean, with a CoV and an interval from their spread, never below the model's (what the
  command reports);
* :mod:`~rcsim.analysis.engine.rare.series` -- a failure with several criteria as a series
  system: each criterion estimated on its own margin, combined with series-system bounds
  (one margin, the smallest of the criteria, can miss a criterion entirely);
* :mod:`~rcsim.analysis.engine.rare.importance` -- cross-entropy importance sampling, the
  comparison ``benchmarks/rare_event.py`` measures (``docs/rare_events.md``);
* :mod:`~rcsim.analysis.engine.rare.intervals` -- the coefficient of variation with the chains'
  correlation, log-normal intervals, exact binomial intervals and zero-failure bounds;
* :mod:`~rcsim.analysis.engine.rare.state` -- the per-level state and its file;
* :mod:`~rcsim.analysis.engine.rare.result` -- what an estimation reports (statuses, the
  closest failure point);
* :mod:`~rcsim.analysis.engine.rare.limit_states` -- analytic limit states with known
  probabilities (the tests' and the benchmark's oracles).

Everything here is generic numpy: it knows nothing of vehicles, flights or campaigns.  A
campaign adapter implements ``g(u, ids)`` by flying the runs of a batch and imports this
package, never the other way round.

Must not import: rcsim.analysis.engine.campaign, rcsim.analysis.engine.flight,
rcsim.analysis.engine.scenarios, rcsim.spacecraft, rcsim.lookup.
"""

from rcsim.analysis.engine.rare.repeats import combine_repeats, repeated_subset_simulation
from rcsim.analysis.engine.rare.result import FailurePoint, RareEventResult
from rcsim.analysis.engine.rare.series import SeriesResult, series_subset_simulation
from rcsim.analysis.engine.rare.subset import SubsetConfig, subset_simulation

__all__ = [
    "FailurePoint",
    "RareEventResult",
    "SeriesResult",
    "SubsetConfig",
    "combine_repeats",
    "repeated_subset_simulation",
    "series_subset_simulation",
    "subset_simulation",
]
