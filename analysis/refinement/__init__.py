"""Automated lookup-table refinement from dispersed runs (Gambone sec. III, Tables 6 -> 7).

* :mod:`~rcsim.analysis.refinement.evaluate` -- fly candidate tables over the same dispersed
  runs (common random numbers), all candidates as one batched campaign;
* :mod:`~rcsim.analysis.refinement.search` -- find, case by case, the firing times that
  minimise failures first and repeated firings second;
* :mod:`~rcsim.analysis.refinement.outputs` -- the held-out check on a fresh seed, the refined
  table, its changelog and before/after plots.

The pure table edits (which cells, by how much) are :mod:`rcsim.lookup.table_edits`.  Imports
``rcsim.analysis.campaign`` (spec, outcomes), ``flight``, ``plots`` and the layers below; never
``rcsim.analysis.cli``.
"""
