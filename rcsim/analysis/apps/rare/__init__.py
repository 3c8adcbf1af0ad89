"""Rare-event estimation on a campaign spec: ``P(fail)`` of a case down to probabilities plain
Monte Carlo cannot afford (``docs/rare_events.md``).

* :mod:`~rcsim.analysis.apps.rare.flights` -- the limit state of one case: the runs of points
  ``u`` of the standard-normal space flown as campaign runs, their runs-table rows and margins;
* :mod:`~rcsim.analysis.apps.rare.estimate` -- one estimation per case (``K`` independent
  repeats, combined), resumable level by level, its rows, states and summary in an output
  directory (``rcsim campaign rare``);
* :mod:`~rcsim.analysis.apps.rare.settings` -- how each case is estimated (method, runs per
  level, budget, repeats);
* :mod:`~rcsim.analysis.apps.rare.repeat` -- one repeat: one subset simulation of a case, its
  files in its own folder;
* :mod:`~rcsim.analysis.apps.rare.parallel` -- the repeats side by side on worker processes or
  a Dask cluster;
* :mod:`~rcsim.analysis.apps.rare.words` -- what a reader is told: the estimate, its interval,
  the runs spent and the closest failure in sigmas, in words.

Composes ``rcsim.analysis.engine.rare`` (the generic sampler) with the campaign engine.

Only imported by: rcsim.analysis.apps.cli, rcsim.analysis.apps.loop, rcsim.
"""
