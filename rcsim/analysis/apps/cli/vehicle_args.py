"""The flags every command that flies takes for its vehicle: ``--vehicle`` and ``--control``.

``--vehicle FILE`` names the vehicle flown (a packaged one by name: ``paper``, ``canted16``,
``canted12``, ``service_module``; default the paper's); ``--control KEY=VALUE`` (repeatable)
overrides a key of its flight-software profile (the vehicle file's ``[control]``, e.g. ``--control
maneuver_limit_deg=0.8``).  :func:`flown_vehicle` resolves both once into the
:class:`~rcsim.spacecraft.vehicle.Vehicle` the command hands on.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from rcsim.spacecraft.control_profile import CONTROL_KEYS, parse_assignments

if TYPE_CHECKING:  # imported when a vehicle is resolved: `rcsim --help` stays quick
    from rcsim.spacecraft.vehicle import Vehicle

VEHICLE_HELP = (
    'vehicle file to fly (a packaged one by name: "paper", "canted16", "canted12", '
    '"service_module"); any number of jets; default the paper\'s vehicle'
)


def add_vehicle_args(p: argparse.ArgumentParser, *, vehicle_help: str = VEHICLE_HELP) -> None:
    """Add ``--vehicle`` and ``--control`` to a command's parser."""
    p.add_argument("--vehicle", metavar="FILE", help=vehicle_help)
    p.add_argument(
        "--control",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a key of the vehicle's flight-software profile (its [control]), "
        "repeatable, e.g. --control maneuver_limit_deg=0.8; keys: " + ", ".join(CONTROL_KEYS),
    )


def control_overrides(args: argparse.Namespace) -> dict:
    """``--control`` as a dict of profile keys to numbers (empty when not given)."""
    return parse_assignments(getattr(args, "control", None) or [])


def flown_vehicle(args: argparse.Namespace) -> Vehicle:
    """The vehicle ``--vehicle`` names (the paper's without it) with the ``--control``
    overrides, resolved once.

    Raises
    ------
    InputError
        An invalid vehicle file, or an override that is no profile key or breaks a check, in
        one line naming the file or ``--control``, the key and the value.
    """
    from rcsim.spacecraft.vehicle import Vehicle

    vehicle = Vehicle.load(args.vehicle, control=control_overrides(args), control_from="--control")
    warn_vehicle(vehicle)
    return vehicle


def warn_vehicle(vehicle: Vehicle) -> None:
    """Print the vehicle's sanity warnings (:meth:`Vehicle.warnings`) to stderr, one
    ``rcsim: warning:`` line each, before a command's work: odd values, flown as given."""
    for line in vehicle.warnings():
        print(f"rcsim: warning: {vehicle.label}: {line}", file=sys.stderr)
