"""The analysis that reads results: campaign runs in, findings out.  It never flies.

* :mod:`~analysis.results.drivers` -- failure drivers (a TRAM-like analysis) and their report
  sections;
* :mod:`~analysis.results.scoring` -- how refinement candidates are scored from their runs;
* :mod:`~analysis.results.proportions` -- failure probabilities with intervals, runs to a
  bound, the paired (McNemar) test;
* :mod:`~analysis.results.report` -- the generic HTML report kit (self-contained pages).

Reads the engine's result files through :mod:`analysis.engine.runs_table`.

Must not import: analysis.apps, analysis.engine.campaign.runner, analysis.engine.flight.
"""
