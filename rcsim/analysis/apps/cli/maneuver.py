"""``rcsim maneuver``: fly one attitude maneuver and write its history and plots."""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from rcsim.analysis.apps.cli.vehicle_args import add_vehicle_args, flown_vehicle
from rcsim.lookup.c_library import LIBRARY_PREFIX
from rcsim.models.errors import InputError

COMMAND = "maneuver"  # recorded in the output directory's marker


def register(sub) -> None:
    p = sub.add_parser(
        "maneuver",
        help="fly one rest-to-rest attitude maneuver (history.parquet + plots)",
        description="Fly the nominal vehicle (the paper's, or a vehicle file's with "
        "--vehicle) from rest to a commanded attitude and write "
        "DIR/history.parquet (one row per control cycle of the vehicle's profile: 40 ms for "
        "the paper's), DIR/attitude_error.png, DIR/rates_jets.png and DIR/summary.json (which "
        "names the vehicle and the flight-software profile flown).",
    )
    p.add_argument(
        "--controller",
        default="phase-plane",
        metavar="NAME",
        help="phase-plane, lookup (the paper's pattern recognition), adaptive "
        "(lookup whose table entries learn their firing times in flight), allocator "
        "(jet selection for any layout; objective the profile's allocation: propellant, "
        "propellant+translation or translation-first), a name an installed package registers "
        "(entry points 'rcsim.controllers'), or your own flight software: "
        "plugin:package.module:factory (Python) or library:path/to/libfsw.so (C, the ABI "
        "of rcsim/lookup/c_abi/rcsim_fsw.h; flown in a child process) "
        "(docs/flight_software.md); default phase-plane",
    )
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a plug-in controller's parameter (repeatable; VALUE read as TOML: 0.5, true, "
        '"text", [1, 2]; anything else is a string)',
    )
    p.add_argument(
        "--attitude-deg",
        nargs=3,
        type=float,
        required=True,
        metavar=("R", "P", "Y"),
        help="commanded attitude as roll, pitch, yaw rotation-vector components [deg]",
    )
    p.add_argument("--duration-s", type=float, default=60.0, help="simulated time [s] (default 60)")
    p.add_argument(
        "--table", help="lookup table CSV for --controller lookup or adaptive (default: packaged)"
    )
    add_vehicle_args(
        p,
        vehicle_help="vehicle file to fly instead of the paper's vehicle, any number of jets (a "
        'packaged one by name: "paper", "canted16", "canted12", "service_module"); a layout '
        "other than Table 2's flies with --controller allocator, or --controller lookup "
        "--table T.csv with a table made by `rcsim lookup generate --vehicle FILE --out T.csv`",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="output directory (created; an existing one is refused unless it holds "
        "an earlier `rcsim maneuver`'s outputs and --overwrite is given)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace DIR if it holds an earlier `rcsim maneuver`'s outputs",
    )
    p.add_argument(
        "--yes",
        action="store_true",
        help="start even if the estimate is over 30 minutes (the estimate is printed first)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rcsim.analysis.engine.flight import Scenario, controller_record, fly, write_flight
    from rcsim.analysis.engine.isolated import run_isolated
    from rcsim.analysis.engine.output import check_out_dir
    from rcsim.lookup.registry import check_controller_name, is_plugin, make_controller

    if not all(math.isfinite(a) for a in args.attitude_deg):
        raise InputError(f"--attitude-deg must be finite, got {args.attitude_deg}")
    if np.linalg.norm(args.attitude_deg) >= 180.0:
        raise InputError(f"--attitude-deg: rotation must be under 180 deg, got {args.attitude_deg}")
    try:
        check_controller_name(args.controller)
    except InputError as exc:
        raise InputError(f"--controller: {exc}") from None
    if args.param and not is_plugin(args.controller):
        raise InputError(f"--param is only for a plug-in controller, not {args.controller!r}")
    vehicle = _vehicle(args)  # after the command is known to be a rotation
    cycle = vehicle.control.cycle_s
    if not math.isfinite(args.duration_s) or args.duration_s < cycle:
        raise InputError(
            f"--duration-s must be at least one control cycle ({cycle:g} s), "
            f"got {args.duration_s:g}"
        )
    from rcsim.analysis.apps.estimates import confirm, flying_seconds
    from rcsim.spacecraft.guards import check_history_memory

    # What cannot fit in memory is refused before what merely takes long.
    check_history_memory(
        1, math.ceil(args.duration_s / cycle), args.duration_s, n_jets=vehicle.n_jets
    )
    confirm(
        "the maneuver (one run, no batching)",
        flying_seconds(args.duration_s, runs=1),
        yes=args.yes,
        parameter="duration_s",
        value=args.duration_s,
    )
    out = check_out_dir(  # before the work
        args.out, COMMAND, overwrite=args.overwrite,
        inputs={"--table": args.table, "--vehicle": args.vehicle},
    )  # fmt: skip
    r, p, y = args.attitude_deg
    scenario = Scenario(
        name="maneuver", duration_s=args.duration_s, att_cmd_rad=np.radians(args.attitude_deg)
    )
    params = plugin_params(args.param)
    ctl = make_controller(args.controller, vehicle, table=args.table, plugin_params=params)
    if args.controller.startswith(LIBRARY_PREFIX):  # C code may crash: not in this process
        item = (scenario, args.controller, vehicle, params)
        history = run_isolated(_fly_one, item, who=f"--controller {args.controller}")
    else:
        history = fly(scenario, controller_obj=ctl, vehicle=vehicle)
    title = f"{args.controller} maneuver ({r:g}, {p:g}, {y:g}) deg"
    if args.vehicle is not None:
        title += f" on {vehicle.name}"
    paths = write_flight(
        history,
        out,
        title=title,
        vehicle=vehicle,
        command=COMMAND,
        overwrite=args.overwrite,
        record=controller_record(args.controller, ctl),
    )
    s = json.loads(paths["summary.json"].read_text())  # what the user's file says
    err = ", ".join(f"{v:.4f}" for v in s["final_att_err_deg"])
    print(f"{title}: final attitude error [{err}] deg, {s['firings']} firings")
    if s["propellant_exhausted_s"] is not None:
        print(
            f"{s['reason']}: all {s['propellant_kg']:.4g} kg used; the jets delivered nothing "
            "after it (commands after it are not counted as firings)"
        )
    elif s["sim_failed"]:
        print(f"the simulation failed: {s['reason']}")
    elif s["control_lost"]:
        print(s["reason"])
    print(
        f"outputs in {paths['history.parquet'].parent}/: "
        + ", ".join(p.name for p in paths.values())
    )
    return 0


def _vehicle(args: argparse.Namespace):
    """The vehicle to fly (``--vehicle``, ``--control``), refused (one line) when the
    controller cannot fly it (:func:`rcsim.lookup.registry.vehicle_problem`) or its jets cannot
    turn the vehicle toward the commanded attitude
    (:func:`rcsim.spacecraft.vehicle.authority.unreachable_command`)."""
    from rcsim.lookup.registry import vehicle_problem
    from rcsim.spacecraft.vehicle.authority import unreachable_command

    vehicle = flown_vehicle(args)
    problem = vehicle_problem(args.controller, args.table, vehicle, table_option="--table")
    if problem is not None:
        where = f" --vehicle {args.vehicle}" if args.vehicle is not None else ""
        raise InputError(f"--controller {args.controller}{where}: {problem[1]}")
    why = unreachable_command(vehicle.definition, np.radians(args.attitude_deg))
    if why:
        raise InputError(
            f"--vehicle {args.vehicle} cannot fly --attitude-deg {args.attitude_deg}: {why}"
        )
    return vehicle


def _fly_one(item: tuple):
    """``(scenario, controller, vehicle, params)`` flown: what a child process runs."""
    from rcsim.analysis.engine.flight import fly

    scenario, controller, vehicle, params = item
    return fly(scenario, controller, vehicle=vehicle, controller_params=params)


def fly_plugin_scenario(scenario, controller: str, vehicle, params: dict):
    """A named scenario (``rcsim scenario run``) flown by a plug-in: built and probed here
    (one line if it cannot be), flown here, or in a child process for C flight code."""
    from rcsim.analysis.engine.isolated import run_isolated
    from rcsim.analysis.engine.scenarios import fly_scenario
    from rcsim.lookup.registry import make_controller

    ctl = make_controller(controller, vehicle, plugin_params=params)
    if not controller.startswith(LIBRARY_PREFIX):
        return fly_scenario(scenario, vehicle=vehicle, controller_obj=ctl)
    item = (scenario, controller, vehicle, params)
    return run_isolated(_fly_scenario_one, item, who=f"--controller {controller}")


def _fly_scenario_one(item: tuple):
    """``(scenario, controller, vehicle, params)`` flown: what a child process runs."""
    from rcsim.analysis.engine.scenarios import fly_scenario
    from rcsim.lookup.registry import make_controller

    scenario, controller, vehicle, params = item
    ctl = make_controller(controller, vehicle, plugin_params=params)
    return fly_scenario(scenario, vehicle=vehicle, controller_obj=ctl)


def plugin_params(pairs: list[str]) -> dict:
    """``--param KEY=VALUE`` pairs as a plug-in's parameters: VALUE read as a TOML value
    (numbers, booleans, quoted strings, arrays), else kept as the string given."""
    import tomllib

    params: dict = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--param must be KEY=VALUE, got {pair!r}")
        try:
            params[key.strip()] = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            params[key.strip()] = value
    return params
