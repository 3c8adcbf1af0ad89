"""A campaign spec's vehicle: the ``vehicle`` key and the ``[control]`` overrides resolved once
into the :class:`~rcsim.spacecraft.vehicle.Vehicle` it flies, and the checks that need it
(the controller and its table can fly it, every case is within its jets' reach).  Used by
:mod:`~rcsim.analysis.engine.campaign.spec`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rcsim.analysis.engine.campaign.reader import Reader
from rcsim.analysis.engine.flight import Scenario
from rcsim.models.errors import InputError
from rcsim.spacecraft.control_profile import flatten_control
from rcsim.spacecraft.vehicle import Vehicle


def check_jet_map(vehicle: Vehicle, controller: str, table: str | None, source: str) -> None:
    """Refuse a controller that cannot fly the vehicle
    (:func:`rcsim.lookup.registry.vehicle_problem`: the phase-plane controller on a vehicle
    whose jets do not each turn one axis, the packaged lookup tables on a vehicle whose jets
    torque otherwise than Table 2's, any jet table on a vehicle without 16 jets), naming the
    key."""
    from rcsim.lookup.registry import vehicle_problem

    problem = vehicle_problem(controller, table, vehicle)
    if problem is not None:
        what, text = problem
        raise InputError(f"{source}: controller.{what}: {text}")


def check_channel_table(controller: str, table: str, vehicle: Vehicle, source: str) -> None:
    """A channel table flies only with the lookup controller, and only the vehicle its recipe
    was solved for (:func:`rcsim.lookup.jet_sets.check_table_vehicle`)."""
    from rcsim.lookup.jet_sets import check_table_vehicle
    from rcsim.models.tables import is_channel_table, load_lookup_table

    if not is_channel_table(table):
        return
    tab = load_lookup_table(table)
    try:
        if controller != "lookup":
            raise InputError(
                f"{table}: a channel table flies with the lookup controller, not {controller!r}"
            )
        check_table_vehicle(tab, vehicle)
    except InputError as exc:
        raise InputError(f"{source}: controller.table: {exc}") from None


def check_reachable(vehicle: Vehicle, cases: list[Scenario], source: str) -> None:
    """Refuse a case whose rate change or attitude step the vehicle's jets cannot give,
    naming the case and the axis direction."""
    from rcsim.spacecraft.vehicle.authority import unreachable_command

    definition = vehicle.definition
    for case in cases:
        for what, need in (
            ("rate change", case.rate_cmd_rad_s - case.omega0_rad_s),
            ("attitude step", case.att_cmd_rad),
        ):
            why = unreachable_command(definition, need)
            if why:
                raise InputError(
                    f"{source}: vehicle: {definition.source} cannot fly case {case.name!r}: "
                    f"{why} (its {what} is {np.degrees(need).round(4).tolist()} deg"
                    f"{'/s' if what == 'rate change' else ''})"
                )


def spec_vehicle(top: Reader, base_dir: Path, source: str) -> tuple[Vehicle, dict, bool]:
    """``vehicle`` (a packaged vehicle's name or a vehicle file, relative to the spec; absent:
    the paper's) and ``[control]`` (overrides of its profile), resolved once into the
    :class:`~rcsim.spacecraft.vehicle.Vehicle` the campaign flies.

    Returns the vehicle, what ``resolved`` records of it -- the file and its sha256 (a resume
    or replay refuses a changed file) when the spec names one, its nominal valve timing when
    the file gives some (``vehicle_timing``, about which ``[dispersions.timing]``
    disperses), ``control`` when the spec gives it; nothing for a spec with neither, which
    resolves as before -- and whether the spec named a vehicle.
    """
    from rcsim.spacecraft.vehicle import PACKAGED_VEHICLES, resolve_vehicle

    control = top.raw("control") if top.has("control") else None
    if control is not None and not isinstance(control, dict):
        raise top.error("control", "must be a table of profile keys (see `rcsim campaign example`)")
    overrides = flatten_control(control or {})
    where = f"{source} [control]"
    resolved: dict = {} if control is None else {"control": control}
    if not top.has("vehicle"):
        return Vehicle.load(None, control=overrides, control_from=where), resolved, False
    stored = top.raw("vehicle_sha256") if top.has("vehicle_sha256") else None
    stored_timing = top.raw("vehicle_timing") if top.has("vehicle_timing") else None
    value = top.raw("vehicle")
    if not isinstance(value, str) or not value:
        names = ", ".join(f'"{n}"' for n in PACKAGED_VEHICLES)
        raise top.error("vehicle", f"must be a packaged vehicle ({names}) or a file path", value)
    local = base_dir / value
    if value in PACKAGED_VEHICLES and local.exists():
        raise top.error(
            "vehicle",
            f"ambiguous: both the packaged vehicle {value!r} and the file {local}; "
            f'write "./{value}"',
            value,
        )
    if value in PACKAGED_VEHICLES:
        path = str(resolve_vehicle(value))
    else:
        file = Path(value).expanduser()
        file = file if file.is_absolute() else base_dir / file
        if not file.is_file():
            raise top.error("vehicle", "file not found", str(file))
        path = str(file.resolve())
    # InputError naming the vehicle file, the key and the value (or the [control] override).
    vehicle = Vehicle.load(
        value if value in PACKAGED_VEHICLES else path, control=overrides, control_from=where
    )
    if stored is not None and stored != vehicle.sha256:
        raise top.error("vehicle", "file changed since the campaign ran (sha256 differs)", value)
    resolved.update(vehicle=vehicle.ref, vehicle_sha256=vehicle.sha256)
    definition = vehicle.definition
    timing = definition.delay_record() if definition.delay_keys else None
    if stored_timing is not None and stored_timing != timing:
        raise top.error(
            "vehicle_timing",
            f"is not the valve timing of {definition.source} "
            f"({'it gives none' if timing is None else timing})",
            stored_timing,
        )
    if timing is not None:
        resolved["vehicle_timing"] = timing
    return vehicle, resolved, True
