"""Published control studies reproduced with rcsim: one module per study, its figures beside it.

Owns, e.g., :mod:`~rcsim.analysis.studies.noisy_sensor` (Pittella & Sands 2023, single-axis
control under noisy sensors) and its Figure 4 (:mod:`~rcsim.analysis.studies.noisy_sensor_plots`).
A study writes its outputs through :mod:`rcsim.analysis.output` (marker naming the command,
atomic directory).  Imports ``rcsim.analysis.output``/``plots`` and the layers below; never
``rcsim.analysis.cli`` (the command line imports the studies, not the other way round).
"""
