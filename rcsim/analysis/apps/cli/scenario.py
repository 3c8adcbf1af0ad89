"""``rcsim scenario``: fly the paper's named scenarios and compare the two controllers.

* ``rcsim scenario list``
* ``rcsim scenario run NAME --controller lookup|phase-plane|adaptive|allocator [--table T.csv]
  [--vehicle FILE] [--control KEY=VALUE] --out DIR``
* ``rcsim scenario compare [--vehicle FILE] --out DIR`` (every scenario, the paper's two
  controllers, lookup and phase-plane: comparison.csv/.md; the adaptive controller is compared
  in campaigns, ``docs/faults.md``)

The scenarios are the paper's; ``--vehicle`` flies them on another vehicle (its own profile,
its own authority: a disturbance beyond its jets' torque is refused).
* ``rcsim scenario figures --out DIR`` (the lookup figure set of docs/figures, lookup_*.png)
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rcsim.analysis.apps.cli.vehicle_args import add_vehicle_args, flown_vehicle
from rcsim.lookup.registry import TABLE_CONTROLLERS
from rcsim.models.errors import InputError


def register(sub) -> None:
    scn = sub.add_parser(
        "scenario",
        help="fly the paper's named scenarios (Gambone Figs 3-8, 17-28)",
        description="Named scenarios reproducing Gambone's figures: single-axis and 5 deg "
        "three-axis maneuvers, large and slow maneuvers, rate damping of the 26 rates, "
        "attitude hold under a disturbance with and without the no-firing region, and a "
        "disturbed three-axis maneuver.",
    )
    cmds = scn.add_subparsers(dest="scenario_command", metavar="ACTION", parser_class=type(scn))
    cmds.required = True

    ls = cmds.add_parser("list", help="list the named scenarios")
    ls.set_defaults(func=run_list)

    run = cmds.add_parser(
        "run",
        help="fly one scenario: history.parquet, metrics.csv, summary.json, plots",
        description="Fly one named scenario and write DIR/history.parquet (one row per run and "
        "control cycle: 40 ms for the paper's profile), DIR/metrics.csv, DIR/summary.json and the "
        "paper-style plots; with --vehicle on that vehicle, with its profile.",
    )
    run.add_argument("name", help="scenario name (see `rcsim scenario list`)")
    run.add_argument(
        "--controller",
        default="lookup",
        metavar="NAME",
        help="lookup (default), phase-plane, adaptive (lookup whose table entries learn their "
        "firing times in flight), allocator, a registered plug-in's name, or your own flight "
        "software: plugin:MODULE:FACTORY or library:libfsw.so (docs/flight_software.md)",
    )
    run.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a plug-in controller's parameter (repeatable; VALUE read as TOML)",
    )
    run.add_argument("--table", help="lookup table CSV (default: the packaged table)")
    run.add_argument(
        "--no-fire-band-deg",
        type=float,
        metavar="DEG",
        help="lookup no-firing half-width [deg] (default: the scenario's; 0 = off)",
    )
    add_vehicle_args(run)
    _add_out(run, "scenario run")
    run.set_defaults(func=run_run)

    cmp_ = cmds.add_parser(
        "compare",
        help="fly every scenario with both controllers; write comparison.csv/.md",
    )
    cmp_.add_argument("--table", help="lookup table CSV (default: the packaged table)")
    cmp_.add_argument("--names", nargs="+", metavar="NAME", help="scenarios (default: all)")
    add_vehicle_args(cmp_)
    _add_out(cmp_, "scenario compare")
    cmp_.set_defaults(func=run_compare)

    fig = cmds.add_parser(
        "figures",
        help="write the lookup figure set (lookup_*.png, as in docs/figures)",
    )
    fig.add_argument("--table", help="lookup table CSV (default: the packaged table)")
    _add_out(fig, "scenario figures")
    fig.set_defaults(func=run_figures)


def _add_out(parser, command: str) -> None:
    parser.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help=f"output directory (created; an existing one is refused unless it "
        f"holds an earlier `rcsim {command}`'s outputs and --overwrite is "
        "given)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help=f"replace DIR if it holds an earlier `rcsim {command}`'s outputs",
    )


def _check_table(table):
    from rcsim.models.tables import PAPER_LOOKUP_TABLES

    if table is not None and table not in PAPER_LOOKUP_TABLES and not Path(table).is_file():
        raise InputError(
            f"--table {table}: file not found (a CSV path, or {' / '.join(PAPER_LOOKUP_TABLES)})"
        )


def _controller_problem(args, vehicle, controllers, table) -> None:
    """Refuse (one line) a controller that cannot fly ``vehicle``
    (:func:`rcsim.lookup.registry.vehicle_problem`)."""
    from rcsim.lookup.registry import vehicle_problem

    for name in controllers:
        problem = vehicle_problem(name, table if name in TABLE_CONTROLLERS else None, vehicle,
                                  table_option="--table")  # fmt: skip
        if problem is not None:
            raise InputError(f"--vehicle {vehicle.label}: {name}: {problem[1]}")


def _scenario_vehicle(args, scenario, controllers, table):
    """The vehicle ``--vehicle`` / ``--control`` name (the paper's without them), checked
    against the controllers and the scenario's disturbance before any flight."""
    from rcsim.analysis.engine.scenarios.flying import check_scenario_vehicle

    vehicle = flown_vehicle(args)
    _controller_problem(args, vehicle, controllers, table)
    check_scenario_vehicle(scenario, vehicle)
    return vehicle


def run_list(args: argparse.Namespace) -> int:
    from rcsim.analysis.engine.scenarios import all_scenarios

    width = max(len(n) for n in all_scenarios())
    for s in all_scenarios().values():
        print(
            f"{s.name:<{width}}  {s.figures:<11} {s.description} "
            f"({s.n_runs} run{'s' if s.n_runs > 1 else ''}, {s.duration_s:g} s)"
        )
    return 0


def run_run(args: argparse.Namespace) -> int:
    import math

    import numpy as np

    from rcsim.analysis.apps.cli.maneuver import fly_plugin_scenario, plugin_params
    from rcsim.analysis.engine.output import check_out_dir
    from rcsim.analysis.engine.scenarios import (
        fly_scenario,
        get_scenario,
        summarize,
        write_scenario,
    )
    from rcsim.lookup.registry import check_controller_name, is_plugin

    try:
        check_controller_name(args.controller)
    except InputError as exc:
        raise InputError(f"--controller: {exc}") from None
    plugin = is_plugin(args.controller)
    if args.param and not plugin:
        raise InputError(f"--param is only for a plug-in controller, not {args.controller!r}")
    scn = get_scenario(args.name)
    _check_table(args.table)
    if args.controller not in TABLE_CONTROLLERS and (
        args.table or args.no_fire_band_deg is not None
    ):
        raise InputError(
            "--table and --no-fire-band-deg are only for --controller lookup or adaptive"
        )
    overrides: dict = {}
    if args.no_fire_band_deg is not None:
        if not math.isfinite(args.no_fire_band_deg) or args.no_fire_band_deg < 0:
            raise InputError(f"--no-fire-band-deg must be >= 0, got {args.no_fire_band_deg}")
        overrides["no_fire_band_rad"] = float(np.radians(args.no_fire_band_deg))
    vehicle = _scenario_vehicle(args, scn, (args.controller,), args.table)
    out = check_out_dir(  # before the work
        args.out, "scenario run", overwrite=args.overwrite, inputs={"--table": args.table}
    )
    if plugin:
        hist = fly_plugin_scenario(scn, args.controller, vehicle, plugin_params(args.param))
    else:
        hist = fly_scenario(scn, args.controller, table=args.table, vehicle=vehicle, **overrides)
    paths = write_scenario(
        hist,
        scn,
        out,
        controller=args.controller,
        command="scenario run",
        overwrite=args.overwrite,
        vehicle=vehicle,
    )
    from rcsim.analysis.engine.scenarios import scenario_metrics

    s = summarize(scenario_metrics(hist, scn, vehicle.control))
    t = s["att_rate_settled_time_s"]
    settle = "not settled" if math.isnan(t) else f"from {t:.2f} s"
    print(
        f"{args.controller} {scn.name}: final attitude error {s['final_att_err_deg']:.3f} deg, "
        f"rate error {s['final_rate_err_deg_s']:.4f} deg/s, {s['firings']} firings, "
        f"{s['propellant_kg']:.4f} kg, settled {settle}"
    )
    print(f"outputs in {Path(args.out)}/: " + ", ".join(p.name for p in paths.values()))
    return 0


def run_compare(args: argparse.Namespace) -> int:
    from rcsim.analysis.engine.scenarios import get_scenario
    from rcsim.analysis.engine.scenarios.flying import COMPARISON_ORDER
    from rcsim.analysis.engine.scenarios.outputs import write_comparison

    _check_table(args.table)
    vehicle = None
    if args.vehicle is not None or args.control:
        vehicle = flown_vehicle(args)
        for name in args.names or ():
            get_scenario(name)  # an unknown name before the vehicle's problems
        _controller_problem(args, vehicle, COMPARISON_ORDER, args.table)
    _, md = write_comparison(
        args.out, args.names, table=args.table, overwrite=args.overwrite, vehicle=vehicle
    )
    print(md, end="")
    print(f"outputs in {Path(args.out)}/: comparison.csv, comparison.md")
    return 0


def run_figures(args: argparse.Namespace) -> int:
    from rcsim.analysis.engine.scenarios.outputs import write_figures

    _check_table(args.table)
    names = write_figures(args.out, table=args.table, overwrite=args.overwrite)
    print(f"wrote {len(names)} figures in {Path(args.out)}/: " + ", ".join(names))
    return 0
