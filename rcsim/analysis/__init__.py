"""What users run and read, in three layers the tree shows (imports flow one way)::

    engine  <-  results  <-  apps

* :mod:`rcsim.analysis.engine` -- the engine that flies and writes: one flight
  (:mod:`~rcsim.analysis.engine.flight`), the paper's scenarios, Monte Carlo campaigns and the
  runs table they write (:mod:`~rcsim.analysis.engine.runs_table`), output directories and plots;
* :mod:`rcsim.analysis.results` -- the analysis that reads results: failure drivers, the scoring of
  refinement candidates, the generic HTML report kit;
* :mod:`rcsim.analysis.apps` -- the applications: the analyst's loop, table refinement, the
  published studies and the ``rcsim`` command line.

Imports every layer below it (``rcsim.models``, ``rcsim.spacecraft``, ``rcsim.lookup``).

Must not import: rcsim.
"""
