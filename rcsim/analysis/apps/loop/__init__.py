"""The analyst's whole loop on defaults (``rcsim loop``, ``make run``).

* :mod:`~rcsim.analysis.apps.loop.run` -- campaign with the table, failure drivers, refinement,
  the refined table's campaign on a fresh seed; resumable stage by stage;
* :mod:`~rcsim.analysis.apps.loop.report` -- the one ``report.html`` of the loop;
* :mod:`~rcsim.analysis.apps.loop.files` -- the table refined as the campaigns name it (a generated
  one in the loop directory).

Composes ``rcsim.analysis.engine.campaign``, ``drivers``, ``refinement`` and ``report``.

Only imported by: rcsim.analysis.apps.cli, rcsim.
"""
