"""Controllers by name, as the CLI and campaign specs name them.

:data:`ALL_CONTROLLERS` is the one list of controller names the CLI's ``--controller`` choices
and campaign specs (``controller.name``) accept.  :data:`CONTROLLERS`, the paper's two, is what
the scenario comparison flies (``rcsim scenario compare``: the paper's lookup controller against
the phase-plane baseline); the adaptive lookup controller is a variant of the lookup controller
whose purpose (learning under dispersions, sensor noise and jet faults) the named nominal
scenarios do not exercise, so it is compared in campaigns (``docs/faults.md``) instead.
"""

from __future__ import annotations

import os

import mujoco

from rcsim.spacecraft.simulation import Controller

#: The paper's two controllers: what the scenario comparison flies (module docstring).
CONTROLLERS = ("phase-plane", "lookup")
#: Built by :func:`make_controller` too, offered by the CLI and campaign specs, not flown by the
#: scenario comparison: the adaptive lookup controller (:mod:`rcsim.lookup.adaptive`) and the
#: allocator controller (:mod:`rcsim.lookup.allocator_controller`: minimum-propellant jet selection
#: for any jet layout).
MORE_CONTROLLERS = ("adaptive", "allocator")
#: Every controller :func:`make_controller` builds, by name: the CLI's and the specs' choices.
ALL_CONTROLLERS = CONTROLLERS + MORE_CONTROLLERS
#: Controllers that fly a lookup table (``table`` and ``lookup_options`` apply).
TABLE_CONTROLLERS = ("lookup", "adaptive")


def vehicle_problem(
    name: str, table, vehicle, *, table_option: str = "controller.table ="
) -> tuple[str, str] | None:
    """Why controller ``name`` (with lookup ``table``, None: the packaged one) cannot fly the
    vehicle file ``vehicle`` (a :class:`rcsim.spacecraft.vehicle_file.VehicleDef`), or None.

    The allocator flies any layout.  The phase-plane controller and the packaged lookup tables
    (the default and the paper's Tables 6 and 7) assume the paper's jet map (Table 2: which
    jet turns which axis which way); any jet table fires the paper's 16 jets.  A channel table
    (:mod:`rcsim.lookup.channels`) fires the jets of the vehicle its recipe was solved for, whatever
    their count (:func:`rcsim.lookup.jet_sets.check_table_vehicle` checks which).  Returns
    ``(what, problem)``: ``what`` is ``"name"`` or ``"table"`` (the choice at fault),
    ``problem`` one sentence naming the first jet that differs or the jet counts, ending with
    the way out: the allocator, or a table generated for the vehicle (``rcsim lookup generate
    --vehicle``), given as ``table_option`` (how the caller sets the table: ``--table`` on the
    command line, ``controller.table =`` in a campaign spec).
    """
    from rcsim.models.tables import N_JETS, PAPER_LOOKUP_TABLES, is_channel_table, load_jet_map
    from rcsim.spacecraft.vehicle_file.authority import jet_map_mismatch

    if name == "allocator":
        return None
    channels = (
        table is not None and str(table) not in PAPER_LOOKUP_TABLES and is_channel_table(table)
    )
    if channels:  # its recipe is per jet of the vehicle it was solved for (checked with it)
        return None
    if table is not None and name in TABLE_CONTROLLERS and vehicle.n_jets != N_JETS:
        return (
            "table",
            f"a lookup table fires the paper's {N_JETS} jets; {vehicle.source} has "
            f"{vehicle.n_jets} (got {str(table)!r}); use the allocator controller",
        )
    packaged = table is None or str(table) in PAPER_LOOKUP_TABLES  # made for Table 2's jets
    if name != "phase-plane" and not packaged:
        return None  # a user's table made for their vehicle (rcsim lookup generate --vehicle)
    differs = jet_map_mismatch(vehicle, load_jet_map())
    if differs:
        what = ""
        if name != "phase-plane":
            what = " with the packaged table" if table is None else f" with the paper's {table}"
        # A vehicle whose jets differ from Table 2's gets a channel table, which only the
        # lookup controller flies (`rcsim lookup generate --vehicle`: is_coupled).
        generate = f"`rcsim lookup generate --vehicle {vehicle.source} --out T.csv`"
        own = (
            f"or generate this vehicle's own table ({generate}) and fly it with "
            f"{table_option} T.csv"
            if name == "lookup"
            else f"or the lookup controller with this vehicle's own table ({generate})"
        )
        return (
            "name",
            f"{name!r}{what} assumes the paper's jet map (Table 2), but in {vehicle.source} "
            f"{differs}; use the allocator controller, {own}",
        )
    return None


def make_controller(
    name: str,
    *,
    table: str | os.PathLike | None = None,
    model: mujoco.MjModel | None = None,
    lookup_options: dict | None = None,
    phase_plane_options: dict | None = None,
    adapt_options: dict | None = None,
    vehicle=None,
    jets_off=(),
) -> Controller:
    """Build a controller.

    Parameters
    ----------
    name : {"phase-plane", "lookup", "adaptive", "allocator"}
    table : path, optional
        Lookup table CSV (rcsim or paper layout) for ``"lookup"`` and ``"adaptive"``, or
        whatever else
        :func:`rcsim.models.tables.load_lookup_table` accepts; default the packaged table
        ``rcsim/lookup/data/generated_table.csv``.
    model : mujoco.MjModel, optional
        Vehicle whose *nominal* properties the phase-plane design uses.
    lookup_options, phase_plane_options : dict, optional
        Overrides of :class:`rcsim.lookup.pattern_recognition.LookupParams` /
        :class:`rcsim.lookup.phase_plane.PhasePlaneParams` fields for that controller.
    adapt_options : dict, optional
        :class:`rcsim.lookup.adaptive.AdaptParams` fields for ``"adaptive"``.
    vehicle : rcsim.spacecraft.vehicle_file.VehicleDef, optional
        The vehicle file flown; the allocator takes its Isp and minimum on-time from it
        (default: the packaged vehicle's 280 s and none); a channel table must have been
        solved for it (:func:`rcsim.lookup.jet_sets.check_table_vehicle`).
    jets_off : sequence of int
        Jets (1-based) the allocator may not use.

    Raises
    ------
    InputError
        Unknown ``name``; ``table`` given for a controller other than ``"lookup"``; a table
        that does not load (a missing file is named by its path).
    """
    from rcsim.models.errors import InputError
    from rcsim.models.tables import load_jet_map

    if table is not None and name in ALL_CONTROLLERS and name not in TABLE_CONTROLLERS:
        raise InputError(
            f"is only for the lookup controller, not {name!r} (got {str(table)!r})",
            parameter="table",
            value=table,
        )
    if name == "phase-plane":
        from rcsim.lookup.phase_plane import PhasePlaneController, PhasePlaneParams

        return PhasePlaneController(
            PhasePlaneParams.for_vehicle(load_jet_map(), model=model, **(phase_plane_options or {}))
        )
    if name == "lookup":
        from rcsim.lookup.jet_sets import check_table_vehicle
        from rcsim.lookup.pattern_recognition import LookupController

        ctl = LookupController.from_files(table, **(lookup_options or {}))
        # A channel table flies only the vehicle file its recipe was solved for.
        check_table_vehicle(ctl.table, None if vehicle is None else vehicle.source)
        return ctl
    if name == "adaptive":
        from rcsim.lookup.adaptive import AdaptiveLookupController, AdaptParams

        ctl = AdaptiveLookupController.from_files(table, **(lookup_options or {}))
        ctl.adapt = AdaptParams(**(adapt_options or {}))  # type: ignore[attr-defined]
        return ctl
    if name == "allocator":
        from rcsim.lookup.allocator_controller import allocator_controller
        from rcsim.spacecraft.vehicle import load_model

        return allocator_controller(
            load_model() if model is None else model,
            isp_s=280.0 if vehicle is None else vehicle.isp_s,
            min_on_s=0.0 if vehicle is None else vehicle.min_on_s,
            jets_off=jets_off,
        )
    raise InputError(f"unknown controller {name!r}; choose one of {', '.join(ALL_CONTROLLERS)}")
