"""The applications: what a user runs, composed from the engine and the results layer.

* :mod:`~rcsim.analysis.apps.loop` -- the analyst's whole loop (``rcsim loop``, ``make run``);
* :mod:`~rcsim.analysis.apps.refinement` -- automated lookup-table refinement;
* :mod:`~rcsim.analysis.apps.studies` -- published control studies (noisy sensors, DAI);
* :mod:`~rcsim.analysis.apps.cli` -- the ``rcsim`` command line (thin: parses, calls the library,
  prints).

Must not import: rcsim.
"""
