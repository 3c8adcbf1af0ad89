"""The paper's named scenarios (Gambone Figs 3-8, 17-28): definitions, flights, metrics, figures.

* :mod:`~rcsim.analysis.scenarios.catalog` -- :class:`PaperScenario` and the named scenarios;
* :mod:`~rcsim.analysis.scenarios.flying` -- fly one with either controller, measure it,
  compare the two controllers;
* :mod:`~rcsim.analysis.scenarios.plots` -- scenario and lookup-table plots;
* :mod:`~rcsim.analysis.scenarios.outputs` -- write one flight's output directory;
* :mod:`~rcsim.analysis.scenarios.figure_set` -- regenerate the docs figure set.

Inside, imports flow catalog <- flying <- (outputs, figure_set) and plots <- (outputs,
figure_set).  Imports ``rcsim.analysis.flight``/``plots``/``output`` and the layers below;
never ``rcsim.analysis.campaign`` or ``rcsim.analysis.cli``.
"""
from rcsim.analysis.scenarios.catalog import (
    PaperScenario, all_scenarios, get_scenario, scenario_names,
)
from rcsim.analysis.scenarios.flying import (
    compare_controllers, comparison_markdown, fly_scenario, scenario_metrics, settled_time,
    summarize,
)
from rcsim.analysis.scenarios.outputs import write_scenario

__all__ = [
    "PaperScenario", "all_scenarios", "get_scenario", "scenario_names", "compare_controllers",
    "comparison_markdown", "fly_scenario", "scenario_metrics", "settled_time", "summarize",
    "write_scenario",
]
