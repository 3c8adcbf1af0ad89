"""The analysis that reads results: campaign runs in, findings out.  It never flies.

* :mod:`~rcsim.analysis.results.drivers` -- failure drivers (a TRAM-like analysis) and their report
  sections;
* :mod:`~rcsim.analysis.results.scoring` -- how refinement candidates are scored from their runs;
* :mod:`~rcsim.analysis.results.proportions` -- failure probabilities with intervals, runs to a
  bound, the paired (McNemar) test;
* :mod:`~rcsim.analysis.results.report` -- the generic HTML report kit (self-contained pages).

Reads the engine's result files through :mod:`rcsim.analysis.engine.runs_table`.

Must not import: rcsim.analysis.apps, rcsim.analysis.engine.campaign.runner,
rcsim.analysis.engine.flight.
"""
