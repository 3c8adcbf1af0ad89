"""Published control studies reproduced with rcsim: one module per study, its figures beside it.

Owns, e.g., :mod:`~analysis.apps.studies.noisy_sensor` (Pittella & Sands 2023, single-axis
control under noisy sensors) and its Figure 4 (:mod:`~analysis.apps.studies.noisy_sensor_plots`).
A study writes its outputs through :mod:`analysis.engine.output` (marker naming the
command, atomic directory).  Imports ``analysis.engine.output``/``plots`` and the layers below.

Must not import: analysis.engine.campaign, analysis.results, analysis.apps.loop,
analysis.apps.refinement.
"""
