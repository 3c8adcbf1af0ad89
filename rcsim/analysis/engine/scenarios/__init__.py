"""The paper's named scenarios (Gambone Figs 3-8, 17-28): definitions, flights, metrics, figures.

* :mod:`~rcsim.analysis.engine.scenarios.catalog` -- :class:`PaperScenario` and the named scenarios;
* :mod:`~rcsim.analysis.engine.scenarios.flying` -- fly one with either controller, measure it,
  compare the two controllers;
* :mod:`~rcsim.analysis.engine.scenarios.plots` -- scenario and lookup-table plots;
* :mod:`~rcsim.analysis.engine.scenarios.outputs` -- write one flight's output directory, the
  controllers' comparison and the figure set as output directories;
* :mod:`~rcsim.analysis.engine.scenarios.figure_set` -- regenerate the docs figure set.

Inside, imports flow catalog <- flying <- figure_set <- outputs and plots <- (figure_set,
outputs).  Imports ``rcsim.analysis.engine.flight``/``plots``/``output`` and the layers below.

Must not import: rcsim.analysis.engine.campaign.
"""

from rcsim.analysis.engine.scenarios.catalog import (
    PaperScenario,
    all_scenarios,
    get_scenario,
    scenario_names,
)
from rcsim.analysis.engine.scenarios.flying import (
    compare_controllers,
    comparison_markdown,
    fly_scenario,
    scenario_metrics,
    settle_tolerances,
    settled_time,
    summarize,
)
from rcsim.analysis.engine.scenarios.outputs import write_scenario

__all__ = [
    "PaperScenario",
    "all_scenarios",
    "get_scenario",
    "scenario_names",
    "compare_controllers",
    "comparison_markdown",
    "fly_scenario",
    "scenario_metrics",
    "settle_tolerances",
    "settled_time",
    "summarize",
    "write_scenario",
]
