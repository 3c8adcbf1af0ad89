"""rcsim: spacecraft reaction-control simulation for RCS analysts.

The package owns one name; its visible top is the design card's four layers, with one-way
imports (``rcsim.models`` <- ``rcsim.spacecraft`` <- ``rcsim.lookup`` <- ``rcsim.analysis``),
and this module on top owns the version, ``python -m rcsim`` and the public Python API::

    models  <-  spacecraft  <-  lookup  <-  analysis  <-  rcsim (this module)
    (MJCF,      (vehicle,       (control-   (engine: fly and write; results: read and
     tables)     physics)        lers)       judge; apps: loop, CLI, studies)

The public API (``docs/api.md`` has a worked, tested example; ``help(rcsim.<name>)`` gives
each one's docstring).  Names load on first use, so ``import rcsim`` is quick.

The vehicle
    Vehicle, vehicle_report                      -- a vehicle (packaged or a file) resolved once,
                                                    with its flight-software profile; its check
Flying
    Scenario, fly, history_frame, write_flight  -- one flight (a batch of one or many runs)
    RunParameters, make_controller               -- runs' parameters, a controller for a vehicle
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
    "Scenario": ("rcsim.analysis.engine.flight", "Scenario"),
    "fly": ("rcsim.analysis.engine.flight", "fly"),
    "history_frame": ("rcsim.analysis.engine.flight", "history_frame"),
    "write_flight": ("rcsim.analysis.engine.flight", "write_flight"),
    "Vehicle": ("rcsim.spacecraft.vehicle", "Vehicle"),
    "vehicle_report": ("rcsim.spacecraft.vehicle.authority", "vehicle_report"),
    "RunParameters": ("rcsim.spacecraft.vehicle.run_parameters", "RunParameters"),
    "make_controller": ("rcsim.lookup.registry", "make_controller"),
    "parse_dict": ("rcsim.analysis.engine.campaign.spec", "parse_dict"),
    "load_spec": ("rcsim.analysis.engine.campaign.spec", "load_spec"),
    "CampaignSpec": ("rcsim.analysis.engine.campaign.spec", "CampaignSpec"),
    "run_campaign": ("rcsim.analysis.engine.campaign.runner", "run_campaign"),
    "runs_table": ("rcsim.analysis.engine", "runs_table"),
    "load_runs": ("rcsim.analysis.results.drivers.inputs", "load_runs"),
    "analyze": ("rcsim.analysis.results.drivers.pipeline", "analyze"),
    "DriverSettings": ("rcsim.analysis.results.drivers.pipeline", "Settings"),
    "write_analysis": ("rcsim.analysis.results.drivers.outputs", "write_analysis"),
    "load_lookup_table": ("rcsim.models.tables", "load_lookup_table"),
    "generate_table": ("rcsim.analysis.engine.table_files", "generate_table"),
    "run_refinement": ("rcsim.analysis.apps.refinement.outputs", "run_refinement"),
    "LoopSettings": ("rcsim.analysis.apps.loop.run", "LoopSettings"),
    "run_loop": ("rcsim.analysis.apps.loop.run", "run_loop"),
}
__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name not in _API:
        raise AttributeError(f"module 'rcsim' has no attribute {name!r}")
    module, attribute = _API[name]
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value  # later lookups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API))
