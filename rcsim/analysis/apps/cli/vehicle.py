"""``rcsim vehicle check FILE``: what a vehicle file's jets can do, before flying it.

Prints the jet-by-jet force and torque matrix, the control authority per axis and direction,
the directions that cannot be reached and the jet-out cases that lose an axis
(:mod:`rcsim.spacecraft.vehicle_file.authority`).  A bad file is one ``rcsim: error:`` line naming
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
        "directions and the jet-out cases that lose an axis",
        description="Validate a vehicle file and print what its jets can do: the force [N] and "
        "torque about the CG [N m] of each jet, the control authority per axis and direction "
        "(angular acceleration with the other axes held at zero, as a pure couple too, and the "
        "least propellant per deg/s), the directions no jet combination reaches, and, for each "
        "jet failed off, the axis directions lost.",
    )
    check.add_argument(
        "vehicle",
        metavar="FILE",
        help='a vehicle TOML file, or a packaged one by name ("paper", "canted16", "canted12")',
    )
    check.add_argument(
        "--no-pairs",
        action="store_true",
        help="skip the two-jets-out search (n (n - 1) / 2 cases)",
    )
    check.set_defaults(func=_check)


def _check(args: argparse.Namespace) -> int:
    from rcsim.spacecraft.vehicle_file.authority import vehicle_report

    print(vehicle_report(args.vehicle, pairs=not args.no_pairs), end="")
    return 0
