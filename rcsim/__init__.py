"""rcsim: spacecraft reaction-control simulation for RCS analysts.

The package on top owns the version, ``python -m rcsim`` and the public Python API; the code
lives in the four layers the tree shows, each a top-level package, with one-way imports::

    models  <-  spacecraft  <-  lookup  <-  analysis  <-  rcsim
    (MJCF,      (vehicle,       (control-   (engine: fly and write; results: read and
     tables)     physics)        lers)       judge; apps: loop, CLI, studies)

The public API (``docs/api.md`` has a worked, tested example; ``help(rcsim.<name>)`` gives
each one's docstring).  Names load on first use, so ``import rcsim`` is quick.

Flying
    Scenario, fly, history_frame, write_flight  -- one flight (a batch of one or many runs)
    VehicleParams, make_controller               -- the vehicle's parameters, a controller by name
Campaigns
    parse_dict, load_spec, CampaignSpec, run_campaign -- a Monte Carlo dispersion campaign
    runs_table                                   -- the columns and files of its results
Failure drivers
    load_runs, analyze, DriverSettings, write_analysis -- a campaign, a table file or a DataFrame
Lookup tables
    load_lookup_table, generate_table, run_refinement
The analyst's loop
    LoopSettings, run_loop

Units are SI and radians inside; degrees, deg/s and N appear only in file columns and CLI flags,
with the unit in the name (``rate_deg_s``).
"""

from __future__ import annotations

import importlib

__version__ = "0.2.0"

#: Public name -> (module, attribute); the attribute is the name unless it differs.
_API: dict[str, tuple[str, str]] = {
    "Scenario": ("analysis.engine.flight", "Scenario"),
    "fly": ("analysis.engine.flight", "fly"),
    "history_frame": ("analysis.engine.flight", "history_frame"),
    "write_flight": ("analysis.engine.flight", "write_flight"),
    "VehicleParams": ("spacecraft.vehicle", "VehicleParams"),
    "make_controller": ("lookup.registry", "make_controller"),
    "parse_dict": ("analysis.engine.campaign.spec", "parse_dict"),
    "load_spec": ("analysis.engine.campaign.spec", "load_spec"),
    "CampaignSpec": ("analysis.engine.campaign.spec", "CampaignSpec"),
    "run_campaign": ("analysis.engine.campaign.runner", "run_campaign"),
    "runs_table": ("analysis.engine", "runs_table"),
    "load_runs": ("analysis.results.drivers.inputs", "load_runs"),
    "analyze": ("analysis.results.drivers.pipeline", "analyze"),
    "DriverSettings": ("analysis.results.drivers.pipeline", "Settings"),
    "write_analysis": ("analysis.results.drivers.outputs", "write_analysis"),
    "load_lookup_table": ("models.tables", "load_lookup_table"),
    "generate_table": ("lookup.table_generation", "generate_table"),
    "run_refinement": ("analysis.apps.refinement.outputs", "run_refinement"),
    "LoopSettings": ("analysis.apps.loop.run", "LoopSettings"),
    "run_loop": ("analysis.apps.loop.run", "run_loop"),
}
__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name not in _API:
        raise AttributeError(f"module 'rcsim' has no attribute {name!r}")
    from rcsim._layers import check_layers

    check_layers()  # a shadowing models.py in the working directory: one clear message
    module, attribute = _API[name]
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value  # later lookups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API))
