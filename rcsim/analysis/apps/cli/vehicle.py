"""``rcsim vehicle check FILE``: what a vehicle file's jets can do, before flying it.

Prints the jet-by-jet force and torque matrix, the control authority per axis and direction,
the directions that cannot be reached and the jet-out cases that lose an axis
(:mod:`rcsim.spacecraft.vehicle.authority`), and the translation each pure rate change
leaves with the propellant it costs, per allocation mode
(:mod:`rcsim.lookup.translation_coupling`).  A bad file is one ``rcsim: error:`` line naming
the file, the key and the value.
"""

from __future__ import annotations

import argparse


def register(subparsers) -> None:
    """Add the ``vehicle`` command group (``check``)."""
    vehicle = subparsers.add_parser(
        "vehicle",
        help="check a vehicle file (jets, authority, jet-out cases)",
        description="Work with vehicle files (TOML: mass properties, jets, propellant, "
        "dispersions; rcsim/models/vehicle/paper.toml is the paper's vehicle in that format).",
    )
    sub = vehicle.add_subparsers(
        dest="vehicle_command", metavar="ACTION", parser_class=type(vehicle)
    )
    sub.required = True
    check = sub.add_parser(
        "check",
        help="print the jets' force/torque matrix, authority per axis, unreachable "
        "directions, the jet-out cases that lose an axis and the translation coupling",
        description="Validate a vehicle file and print what its jets can do: the force [N] and "
        "torque about the CG [N m] of each jet, the control authority per axis and direction "
        "(angular acceleration with the other axes held at zero, as a pure couple too, and the "
        "least propellant per deg/s), the directions no jet combination reaches, for each "
        "jet failed off the axis directions lost, and the translation coupling: the delta-v "
        "[m/s] and propellant [kg] per deg/s of each pure rate change in each allocation mode "
        "(propellant, propellant+translation, translation-first).",
    )
    check.add_argument(
        "vehicle",
        metavar="FILE",
        help="a vehicle TOML file, or a packaged one by name "
        '("paper", "canted16", "canted12", "service_module")',
    )
    check.add_argument(
        "--no-pairs",
        action="store_true",
        help="skip the two-jets-out search (n (n - 1) / 2 cases)",
    )
    check.add_argument(
        "--yes",
        action="store_true",
        help="start even if the estimate is over 30 minutes (the estimate is printed first)",
    )
    check.set_defaults(func=_check)


def _check(args: argparse.Namespace) -> int:
    import sys

    from tqdm import tqdm

    from rcsim.analysis.apps.estimates import check_vehicle_cost
    from rcsim.lookup.translation_coupling import coupling_text
    from rcsim.spacecraft.modes.report import modes_text
    from rcsim.spacecraft.vehicle import Vehicle
    from rcsim.spacecraft.vehicle.authority import check_text, check_vehicle

    flown = Vehicle.load(args.vehicle)
    vehicle = flown.definition
    pairs = not args.no_pairs
    # Its cost grows with the jets (n^2 with the pairs): estimated before the work.
    check_vehicle_cost(vehicle, pairs=pairs, yes=args.yes, source=args.vehicle)
    cases = vehicle.n_jets + (vehicle.n_jets * (vehicle.n_jets - 1) // 2 if pairs else 0)
    with tqdm(
        total=cases, unit="case", desc="jets out", file=sys.stderr, disable=not sys.stderr.isatty()
    ) as bar:
        result = check_vehicle(vehicle, pairs=pairs, step=bar.update)
    print(check_text(vehicle, result), end="")
    print(coupling_text(flown), end="")
    print(modes_text(vehicle.modes, flown.model), end="")
    return 0
