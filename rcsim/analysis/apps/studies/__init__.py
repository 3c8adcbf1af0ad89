"""Published control studies reproduced with rcsim: one module per study, its figures beside it.

Owns, e.g., :mod:`~rcsim.analysis.apps.studies.noisy_sensor` (Pittella & Sands 2023, single-axis
control under noisy sensors) and its Figure 4
(:mod:`~rcsim.analysis.apps.studies.noisy_sensor_plots`). A study writes its outputs through
:mod:`rcsim.analysis.engine.output` (marker naming the command, atomic directory).  Imports
``rcsim.analysis.engine.output``/``plots`` and the layers below.

Must not import: rcsim.analysis.engine.campaign, rcsim.analysis.results, rcsim.analysis.apps.loop,
rcsim.analysis.apps.refinement.

Only imported by: rcsim.analysis.apps.cli.
"""
