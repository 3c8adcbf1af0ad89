"""What users run and read: scenarios, campaigns, failure drivers, reports, studies, the CLI.

Owns flying named scenarios and writing their outputs (:mod:`rcsim.analysis.flight`), plots, Monte
Carlo campaigns and their results, and the ``rcsim`` command line (:mod:`rcsim.analysis.cli`).
Imports every layer below it (``models``, ``spacecraft``, ``lookup``); nothing imports it.
"""
