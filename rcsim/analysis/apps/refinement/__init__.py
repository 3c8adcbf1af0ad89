"""Automated lookup-table refinement from dispersed runs (Gambone sec. III, Tables 6 -> 7).

* :mod:`~rcsim.analysis.apps.refinement.evaluate` -- fly candidate tables over the same dispersed
  runs (common random numbers), all candidates as one batched campaign;
* :mod:`~rcsim.analysis.apps.refinement.search` -- find, case by case, the firing times that
  minimise failures first and repeated firings second;
* :mod:`~rcsim.analysis.apps.refinement.propellant` -- propellant, the second objective: a
  change raising its case's propellant beyond a limit must pay for it with failures;
* :mod:`~rcsim.analysis.apps.refinement.outputs` -- the held-out check on a fresh seed, the refined
  table, its changelog and before/after plots.

The pure table edits (which cells, by how much) are :mod:`rcsim.lookup.table_edits`; how a
candidate's runs are scored is :mod:`rcsim.analysis.results.scoring`.

Must not import: rcsim.analysis.apps.loop, rcsim.analysis.apps.studies.
"""
