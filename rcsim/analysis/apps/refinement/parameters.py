"""What a refinement flies and the parameters it takes: its rate-case campaign, its vehicle,
its seeds, the checks of its parameters.

``rcsim lookup refine``, :func:`~rcsim.analysis.apps.refinement.outputs.run_refinement` and
``rcsim loop`` build their campaigns here (the loop uses the "before" campaign's runs as the
search's baseline: the same runs only if both come from here).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rcsim.analysis.apps.refinement.search import SEARCH_RUNS_PER_CASE
from rcsim.analysis.engine.campaign.spec import CampaignSpec, parse_dict
from rcsim.models.errors import InputError
from rcsim.models.tables import LookupTable
from rcsim.spacecraft.dispersions import MAX_SEED
from rcsim.spacecraft.vehicle import DEFAULT_VEHICLE, Vehicle


def rate_cases_campaign(
    *,
    runs_per_case: int,
    seed: int,
    duration_s: float = 20.0,
    table: str = "default",
    histories: str = "none",
    plots: bool = False,
    vehicle: Vehicle | str | None = None,
    controller: str = "lookup",
    name_vehicle: bool = False,
    controller_params: dict | None = None,
) -> dict:
    """The campaign a refinement flies, as a spec dict: all 26 Table 3 cases from rest, the
    vehicle's dispersions (Table 5 for the paper's), the campaign's default failure threshold.

    The one definition: ``rcsim loop`` writes it as the TOML of its campaigns, and uses the
    "before" campaign's runs as the search's baseline -- the same runs only if both come
    from here.  ``vehicle``: named in the spec (:func:`vehicle_keys`) unless it is the paper's
    as it is packaged and ``name_vehicle`` is false (the user did not name it).
    ``controller``: another than the lookup controller only to check a vehicle before its
    table exists (the loop's ``generate``), or a plug-in that flies the table
    (:mod:`rcsim.lookup.table_plugins`) with ``controller_params`` (its table file among them).
    """
    from rcsim.lookup.registry import is_plugin

    section: dict = {"name": controller}
    if controller == "lookup":
        section = {"name": "lookup", "table": table}
    elif is_plugin(controller):
        section = plugin_section(controller, controller_params)
    spec: dict = {
        "seed": seed,
        "runs_per_case": runs_per_case,
        "scenario": {
            "kind": "rate-cases",
            "cases": "all",
            "mode": "command",
            "duration_s": float(duration_s),
        },
        "controller": section,
        "dispersions": {"table": "default", "scale": 1.0},
        "output": {"histories": histories, "plots": plots},
    }
    spec.update(vehicle_keys(vehicle, named=name_vehicle))
    return spec


def plugin_section(controller: str, params: dict | None) -> dict:
    """A spec's ``[controller]`` for plug-in ``controller`` (``plugin:...``, ``library:...`` or
    a registered name) with its ``[controller.params]``."""
    from rcsim.lookup.c_library import LIBRARY_PREFIX
    from rcsim.lookup.plugins import PLUGIN_PREFIX

    if controller.startswith(PLUGIN_PREFIX):
        section: dict = {"plugin": controller[len(PLUGIN_PREFIX) :]}
    elif controller.startswith(LIBRARY_PREFIX):
        section = {"library": controller[len(LIBRARY_PREFIX) :]}
    else:
        section = {"name": controller}
    if params:
        section["params"] = dict(params)
    return section


def vehicle_keys(vehicle: Vehicle | str | None, *, named: bool = False) -> dict:
    """What a spec says of ``vehicle`` (a :class:`Vehicle`, a packaged name or a file):
    ``vehicle`` (its packaged name or file) unless it is the default and the user did not
    name it (``named``; a spec without the key flies the paper's vehicle, and resolves as it
    always did), and ``control`` when its profile was overridden."""
    if vehicle is None:
        return {}
    vehicle = Vehicle.load(vehicle)
    out: dict = {}
    if named or vehicle.ref != DEFAULT_VEHICLE:
        out["vehicle"] = vehicle.ref
    if vehicle.overrides:
        out["control"] = dict(vehicle.overrides)
    return out


def refinement_spec(
    *,
    runs_per_case: int,
    seed: int,
    duration_s: float = 20.0,
    source: str = "lookup refine",
    vehicle: Vehicle | str | None = None,
    table: str = "default",
    controller: str = "lookup",
) -> CampaignSpec:
    """:func:`rate_cases_campaign` validated (a :class:`CampaignSpec`).

    ``table``: the table file the campaign names (the refinement flies its candidates
    itself); a channel table's file, so that it is checked against ``vehicle``."""
    return parse_dict(
        rate_cases_campaign(
            runs_per_case=runs_per_case,
            seed=seed,
            duration_s=duration_s,
            vehicle=vehicle,
            table=table,
            controller=controller,
        ),
        source=source,
        base_dir=None,
    )


def refinement_vehicle(table: LookupTable, vehicle=None) -> tuple[Vehicle, str]:
    """What a refinement of ``table`` flies: ``(vehicle, table file)``.

    ``vehicle`` given (a :class:`Vehicle`, a packaged name, a file): that one (a channel
    table must have been solved for it, which the campaign spec checks); else a jet table
    flies the paper's vehicle and a channel table the vehicle file its recipe was solved for.
    A jet table names no file ("default": the campaign flies the candidates, not the file); a
    channel table is named by its own file (the one it was loaded from: its recipe is beside
    it).
    """
    if table.recipe is None:
        return Vehicle.load(vehicle), "default"
    source = Path(table.source)
    if not source.is_file():
        raise InputError(
            f"{table.source or '<lookup table>'}: a channel table is refined from its file "
            "(its recipe beside it); save it with LookupTable.to_csv and load it",
            parameter="table",
            value=table.source,
        )
    own = Vehicle.load(table.recipe.vehicle if vehicle is None else vehicle)
    return own, str(source.absolute())


#: Most runs per case a refinement accepts: 26 cases x 100,000 runs is 65 days of a 2-core
#: machine's flying; a larger number is a typo, refused before any work.
MAX_RUNS_PER_CASE = 100_000


def load_refinable_table(table) -> LookupTable:
    """The table to refine (a CSV path or ``table6`` / ``table7``).

    Refinement flies the 16-jet vehicle; a table generated for failed jets (its companion file
    records them, :mod:`rcsim.lookup.jet_sets`) is refused with that reason rather than with
    the jet-map mismatch the plain loader would report.
    """
    from rcsim.lookup.jet_sets import jets_off_of
    from rcsim.models.tables import PAPER_LOOKUP_TABLES, load_lookup_table

    if str(table) not in PAPER_LOOKUP_TABLES and Path(table).is_file():
        off = jets_off_of(table)
        if off:
            raise InputError(
                f"{table}: a table for jets {','.join(map(str, off))} off; "
                "refinement flies the full 16-jet vehicle (fly this table with "
                "`rcsim campaign run` and its spec's controller.table)",
                parameter="table",
                value=str(table),
            )
    return load_lookup_table(table)


def held_out_seed(seed: int) -> int:
    """The default held-out seed of a search on ``seed``: ``seed + 1``.

    Any other seed is as unseen (each seed's streams are independent); one rule keeps
    ``rcsim lookup refine`` and ``rcsim loop`` on the same default.
    """
    return seed + 1


def confirmation_seed(seed: int, fresh_seed: int) -> int:
    """The default confirmation seed (the refinement's second gate): one past the larger of
    the search and held-out seeds, so that it is neither (seeds 1 and 2: 3)."""
    return max(seed, fresh_seed) + 1


def check_parameters(
    *,
    runs_per_case,
    seed,
    fresh_seed,
    duration_s,
    max_iterations,
    search_runs_per_case=SEARCH_RUNS_PER_CASE,
    confirm_seed=None,
    vehicle=None,
    max_propellant_rise_pct=10.0,
) -> None:
    """Raise :class:`InputError` naming the first out-of-range refinement parameter
    (``duration_s`` within what one campaign chunk of ``vehicle``, default the paper's,
    holds)."""

    def bad(name, value, problem):
        return InputError(f"{problem}, got {value!r}", parameter=name, value=value)

    for name, value, lo, hi in (
        ("runs_per_case", runs_per_case, 1, MAX_RUNS_PER_CASE),
        ("seed", seed, 0, MAX_SEED),
        ("fresh_seed", fresh_seed, 0, MAX_SEED),
        ("max_iterations", max_iterations, 1, 1000),
        ("search_runs_per_case", search_runs_per_case, 1, MAX_RUNS_PER_CASE),
        *((("confirm_seed", confirm_seed, 0, MAX_SEED),) if confirm_seed is not None else ()),
    ):
        if (
            not isinstance(value, (int, np.integer))
            or isinstance(value, bool)
            or value < lo
            or (hi is not None and value > hi)
        ):
            raise bad(name, value, f"must be an integer in {lo}..{hi if hi else 'inf'}")
    if fresh_seed == seed:
        raise bad(
            "fresh_seed", fresh_seed, "must differ from the search seed (it is the held-out check)"
        )
    if confirm_seed is not None and confirm_seed in (seed, fresh_seed):
        raise bad(
            "confirm_seed",
            confirm_seed,
            "must differ from the search and held-out seeds (it is the second gate)",
        )
    if (
        isinstance(max_propellant_rise_pct, bool)
        or not isinstance(max_propellant_rise_pct, (int, float))
        or not (np.isfinite(max_propellant_rise_pct) and 0 <= max_propellant_rise_pct <= 1000)
    ):
        raise bad(
            "max_propellant_rise_pct",
            max_propellant_rise_pct,
            "must be a percentage in 0..1000 (a case's mean propellant rise judged on "
            "failures alone)",
        )
    from rcsim.analysis.engine.campaign.limits import max_duration_s

    vehicle = Vehicle.load(vehicle)
    longest = max_duration_s(
        n_jets=vehicle.definition.n_jets,
        cycle_s=vehicle.control.cycle_s,
        n_modes=vehicle.model.njnt - 1,
    )
    # At least a second: the longest table firing (0.52 s), the 0.16 s hold and a correction.
    if not (
        isinstance(duration_s, (int, float))
        and np.isfinite(duration_s)
        and 1.0 <= duration_s <= longest
    ):
        raise bad(
            "duration_s",
            duration_s,
            f"must be a time in 1..{longest:.0f} s (a firing, "
            "its hold and a correction; at most what one campaign chunk holds)",
        )
