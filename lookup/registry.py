"""Controllers by name, as the CLI and campaign specs name them.

:data:`CONTROLLERS` is the one list of controller names: the CLI's choices, campaign specs and
scenario comparisons take it from here.
"""
from __future__ import annotations

import os

import mujoco

from rcsim.spacecraft.simulation import Controller

#: Every controller :func:`make_controller` builds, by name.
CONTROLLERS = ("phase-plane", "lookup")
#: Built by :func:`make_controller` too, not (yet) offered by the CLI and scenario comparisons:
#: the adaptive lookup controller (:mod:`lookup.adaptive`).
MORE_CONTROLLERS = ("adaptive",)


def make_controller(
    name: str,
    *,
    table: str | os.PathLike | None = None,
    model: mujoco.MjModel | None = None,
    lookup_options: dict | None = None,
    phase_plane_options: dict | None = None,
    adapt_options: dict | None = None,
) -> Controller:
    """Build a controller.

    Parameters
    ----------
    name : {"phase-plane", "lookup", "adaptive"}
    table : path, optional
        Lookup table CSV (rcsim or paper layout) for ``"lookup"`` and ``"adaptive"``, or
        whatever else
        :func:`models.tables.load_lookup_table` accepts; default the packaged table
        ``lookup/data/generated_table.csv``.
    model : mujoco.MjModel, optional
        Vehicle whose *nominal* properties the phase-plane design uses.
    lookup_options, phase_plane_options : dict, optional
        Overrides of :class:`lookup.pattern_recognition.LookupParams` /
        :class:`lookup.phase_plane.PhasePlaneParams` fields for that controller.
    adapt_options : dict, optional
        :class:`lookup.adaptive.AdaptParams` fields for ``"adaptive"``.

    Raises
    ------
    InputError
        Unknown ``name``; ``table`` given for a controller other than ``"lookup"``; a table
        that does not load (a missing file is named by its path).
    """
    from rcsim.models.errors import InputError
    from rcsim.models.tables import load_jet_map

    if name == "phase-plane":
        from rcsim.lookup.phase_plane import PhasePlaneController, PhasePlaneParams

        if table is not None:
            raise InputError(f"is only for the lookup controller, not {name!r} "
                             f"(got {str(table)!r})", parameter="table", value=table)
        return PhasePlaneController(PhasePlaneParams.for_vehicle(
            load_jet_map(), model=model, **(phase_plane_options or {})))
    if name == "lookup":
        from rcsim.lookup.pattern_recognition import LookupController

        return LookupController.from_files(table, **(lookup_options or {}))
    if name == "adaptive":
        from rcsim.lookup.adaptive import AdaptiveLookupController, AdaptParams

        ctl = AdaptiveLookupController.from_files(table, **(lookup_options or {}))
        ctl.adapt = AdaptParams(**(adapt_options or {}))
        return ctl
    raise InputError(f"unknown controller {name!r}; choose one of "
                     f"{', '.join(CONTROLLERS + MORE_CONTROLLERS)}")
