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
from typing import TYPE_CHECKING

import numpy as np

from rcsim.spacecraft.simulation import Controller

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle

#: The paper's two controllers: what the scenario comparison flies (module docstring).
CONTROLLERS = ("phase-plane", "lookup")
#: Built by :func:`make_controller` too, offered by the CLI and campaign specs, not flown by the
#: scenario comparison: the adaptive lookup controller (:mod:`rcsim.lookup.adaptive`) and the
#: allocator controller (:mod:`rcsim.lookup.allocator_controller`: jet selection
#: for any jet layout).
MORE_CONTROLLERS = ("adaptive", "allocator")
#: Every controller :func:`make_controller` builds, by name: the CLI's and the specs' choices.
ALL_CONTROLLERS = CONTROLLERS + MORE_CONTROLLERS
#: Controllers that fly a lookup table (``table`` and ``lookup_options`` apply).
TABLE_CONTROLLERS = ("lookup", "adaptive")


def vehicle_problem(
    name: str, table, vehicle: Vehicle, *, table_option: str = "controller.table ="
) -> tuple[str, str] | None:
    """Why controller ``name`` (with lookup ``table``, None: the packaged one) cannot fly
    ``vehicle``, or None.

    The allocator flies any layout.  The phase-plane controller fires, per axis, the jets
    whose torque turns that axis (the vehicle's own Table 2, from its geometry), so it needs
    jets that each turn one axis, every axis both ways.  The packaged lookup tables (the
    default and the paper's Tables 6 and 7) assume the paper's jet map (Table 2: which jet
    turns which axis which way); any jet table fires the paper's 16 jets.  A channel table
    (:mod:`rcsim.lookup.channels`) fires the jets of the vehicle its recipe was solved for,
    whatever their count (:func:`rcsim.lookup.jet_sets.check_table_vehicle` checks which).
    Returns ``(what, problem)``: ``what`` is ``"name"`` or ``"table"`` (the choice at fault),
    ``problem`` one sentence naming the first jet that differs or the jet counts, ending with
    the way out: the allocator, or a table generated for the vehicle (``rcsim lookup generate
    --vehicle``), given as ``table_option`` (how the caller sets the table: ``--table`` on the
    command line, ``controller.table =`` in a campaign spec).
    """
    from rcsim.models.tables import N_JETS, PAPER_LOOKUP_TABLES, is_channel_table, load_jet_map
    from rcsim.spacecraft.vehicle.authority import jet_map_mismatch

    if name == "allocator":
        return None
    if is_plugin(name):  # the user's flight software judges its own vehicle (its factory)
        return None
    generate = f"`rcsim lookup generate --vehicle {vehicle.label} --out T.csv`"
    if name == "phase-plane":
        problem = _coupled(vehicle)
        if problem is None:
            return None
        return (
            "name",
            f"'phase-plane' fires, per axis, the jets that turn only that axis (Table 2's rule, "
            f"read from the geometry), but of the {vehicle.n_jets} jets of {vehicle.label} "
            f"{problem}; use the allocator controller, or the lookup controller with this "
            f"vehicle's own table ({generate})",
        )
    channels = (
        table is not None and str(table) not in PAPER_LOOKUP_TABLES and is_channel_table(table)
    )
    if channels:  # its recipe is per jet of the vehicle it was solved for (checked with it)
        return None
    if table is not None and name in TABLE_CONTROLLERS and vehicle.n_jets != N_JETS:
        return (
            "table",
            f"a lookup table fires the paper's {N_JETS} jets; {vehicle.label} has "
            f"{vehicle.n_jets} (got {str(table)!r}); use the allocator controller",
        )
    packaged = table is None or str(table) in PAPER_LOOKUP_TABLES  # made for Table 2's jets
    if not packaged:
        return None  # a user's table made for their vehicle (rcsim lookup generate --vehicle)
    differs = jet_map_mismatch(vehicle.definition, load_jet_map())
    if differs:
        what = " with the packaged table" if table is None else f" with the paper's {table}"
        # A vehicle whose jets differ from Table 2's gets a channel table, which only the
        # lookup controller flies (`rcsim lookup generate --vehicle`: is_coupled).
        own = (
            f"or generate this vehicle's own table ({generate}) and fly it with "
            f"{table_option} T.csv"
            if name == "lookup"
            else f"or the lookup controller with this vehicle's own table ({generate})"
        )
        return (
            "name",
            f"{name!r}{what} assumes the paper's jet map (Table 2), but in {vehicle.label} "
            f"{differs}; use the allocator controller, {own}",
        )
    return None


def _coupled(vehicle: Vehicle) -> str | None:
    """Why the vehicle's jets are not one axis each, both ways on every axis, or None."""
    from rcsim.spacecraft.vehicle.model import AXES

    signs = vehicle.axis_signs
    for j, row in enumerate(signs):
        if np.count_nonzero(row) > 1:
            return (
                f"{vehicle.jet_names[j]} turns {' and '.join(a for a, s in zip(AXES, row) if s)} "
                f"together (torque signs {row.tolist()})"
            )
    for a, axis in enumerate(AXES):
        for sign, way in ((1, "+"), (-1, "-")):
            if not np.any(signs[:, a] == sign):
                return f"no jet turns {way}{axis}"
    return None


def make_controller(
    name: str,
    vehicle: Vehicle,
    *,
    table: str | os.PathLike | None = None,
    lookup_options: dict | None = None,
    phase_plane_options: dict | None = None,
    adapt_options: dict | None = None,
    jets_off=(),
    plugin_params: dict | None = None,
) -> Controller:
    """Build a controller for ``vehicle``, tuned by its flight-software profile.

    Parameters
    ----------
    name : str
        ``"phase-plane"``, ``"lookup"``, ``"adaptive"``, ``"allocator"``, or a plug-in:
        ``"plugin:package.module:factory"`` or a name an installed package registers
        (:mod:`rcsim.lookup.plugins`).
    vehicle : rcsim.spacecraft.vehicle.Vehicle
        The vehicle flown: its profile (cycle, maneuver rate and limit, deadbands) tunes every
        controller; the phase plane's design uses its nominal mass properties and jet
        geometry, the allocator its jet model, Isp and minimum on-time; a channel table must
        have been solved for it (:func:`rcsim.lookup.jet_sets.check_table_vehicle`).
    table : path, optional
        Lookup table CSV (rcsim or paper layout) for ``"lookup"`` and ``"adaptive"``, or
        whatever else :func:`rcsim.models.tables.load_lookup_table` accepts; default the
        packaged table ``rcsim/lookup/data/generated_table.csv``.
    lookup_options, phase_plane_options : dict, optional
        Overrides of :class:`rcsim.lookup.pattern_recognition.LookupParams` /
        :class:`rcsim.lookup.phase_plane.PhasePlaneParams` fields for that controller (a
        scenario's study of one value; the profile is the place for a vehicle's tuning).
    adapt_options : dict, optional
        :class:`rcsim.lookup.adaptive.AdaptParams` fields for ``"adaptive"``.
    jets_off : sequence of int
        Jets (1-based) the allocator may not use.
    plugin_params : dict, optional
        A plug-in's parameters (its factory's second argument); only for a plug-in.

    Raises
    ------
    InputError
        Unknown ``name``; ``table`` given for a controller other than ``"lookup"``; a table
        that does not load (a missing file is named by its path); a channel table solved for
        another vehicle.
    """
    from rcsim.lookup.plugins import build
    from rcsim.models.errors import InputError

    if is_plugin(name):
        if table is not None:
            raise InputError(
                f"is only for the lookup controller, not the plug-in {name!r} (its own "
                f"parameters set its table; got {str(table)!r})",
                parameter="table",
                value=table,
            )
        return build(name, vehicle, plugin_params)
    if plugin_params:
        raise InputError(
            f"parameters are only for a plug-in controller, not {name!r}",
            parameter="params",
            value=plugin_params,
        )
    if table is not None and name in ALL_CONTROLLERS and name not in TABLE_CONTROLLERS:
        raise InputError(
            f"is only for the lookup controller, not {name!r} (got {str(table)!r})",
            parameter="table",
            value=table,
        )
    control = vehicle.control
    if name == "phase-plane":
        from rcsim.lookup.phase_plane import PhasePlaneController, PhasePlaneParams

        return PhasePlaneController(
            PhasePlaneParams.for_vehicle(vehicle, **(phase_plane_options or {}))
        )
    if name == "lookup":
        from rcsim.lookup.jet_sets import check_table_vehicle
        from rcsim.lookup.pattern_recognition import LookupController

        ctl = LookupController.from_files(table, control, **(lookup_options or {}))
        # A channel table flies only the vehicle file its recipe was solved for.
        check_table_vehicle(ctl.table, vehicle)
        return ctl
    if name == "adaptive":
        from rcsim.lookup.adaptive import AdaptiveLookupController, AdaptParams

        ctl = AdaptiveLookupController.from_files(table, control, **(lookup_options or {}))
        ctl.adapt = AdaptParams(**(adapt_options or {}))  # type: ignore[attr-defined]
        return ctl
    if name == "allocator":
        from rcsim.lookup.allocator_controller import allocator_controller

        return allocator_controller(vehicle, jets_off=jets_off)
    raise InputError(
        f"unknown controller {name!r}; choose one of {', '.join(controller_names())} or a "
        "plug-in, plugin:package.module:factory or library:path/to/libfsw.so"
    )


def is_plugin(name: str) -> bool:
    """Whether controller ``name`` names a plug-in (:mod:`rcsim.lookup.plugins`: by import
    path, or a name an installed package registers; a built-in's name never does)."""
    from rcsim.lookup.c_library import LIBRARY_PREFIX
    from rcsim.lookup.plugins import PLUGIN_PREFIX, registered

    if name in ALL_CONTROLLERS:
        return False
    return name.startswith((PLUGIN_PREFIX, LIBRARY_PREFIX)) or name in registered()


def controller_names() -> tuple[str, ...]:
    """The built-in controllers, then the names installed packages register
    (:data:`rcsim.lookup.plugins.ENTRY_POINT_GROUP`; a built-in's name is never shadowed)."""
    from rcsim.lookup.plugins import registered

    return ALL_CONTROLLERS + tuple(n for n in sorted(registered()) if n not in ALL_CONTROLLERS)


def check_controller_name(name: str) -> str:
    """``name`` if it names a controller :func:`make_controller` can build, else InputError
    (an argparse ``type=``: the message is the one line the user sees)."""
    from rcsim.models.errors import InputError

    if name in controller_names() or is_plugin(name):
        return name
    raise InputError(
        f"unknown controller {name!r}; choose one of {', '.join(controller_names())} or a "
        "plug-in, plugin:package.module:factory or library:path/to/libfsw.so"
    )
