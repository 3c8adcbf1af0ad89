"""The analyst's whole loop on defaults (``rcsim loop``, ``make run``).

* :mod:`~rcsim.analysis.loop.run` -- campaign with the table, failure drivers, refinement,
  the refined table's campaign on a fresh seed; resumable stage by stage;
* :mod:`~rcsim.analysis.loop.report` -- the one ``report.html`` of the loop.

Composes ``rcsim.analysis.campaign``, ``drivers``, ``refinement`` and ``report``; nothing
below ``rcsim.analysis.cli`` imports it.
"""
