"""Time estimates before long work, and a ceiling that needs ``--yes``.

A command that would fly for more than about a minute says how long first; one that would fly
beyond :data:`CEILING_S` refuses to start unless the user confirms (``--yes``): a mistyped
``--runs-per-case 100000`` is a day of a 2-core machine, found out before, not after.

The estimate is simulated seconds over a measured rate, not a promise: the lookup-table
campaign flies about 7,500 simulated seconds per wall second on one core of the development
machine (``docs/performance.md``, issue 19); :data:`SIM_S_PER_CORE_S` takes two thirds of
that, so that a loaded machine is rarely slower than the estimate.
"""

from __future__ import annotations

import os
import sys

from rcsim.models.errors import InputError

#: Simulated seconds per wall second and core the estimates assume (see the module docstring).
SIM_S_PER_CORE_S = 5_000.0
#: A single run (a maneuver) gets no batching: its rate per core [sim-s per wall-s].
SINGLE_RUN_SIM_S_PER_S = 200.0
#: Work estimated beyond this needs ``--yes`` [s].
CEILING_S = 30 * 60.0
#: Work estimated beyond this is announced before it starts [s].
ANNOUNCE_S = 60.0


def human_duration(seconds: float) -> str:
    """``45 s``, ``12 min``, ``3.4 h``, ``2.1 days``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    if seconds < 48 * 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def flying_seconds(simulated_s: float, *, runs: int, cores: int | None = None) -> float:
    """Estimated wall seconds to fly ``simulated_s`` simulated seconds over ``runs`` runs."""
    if runs <= 1:
        return simulated_s / SINGLE_RUN_SIM_S_PER_S
    cores = max(1, min(cores or os.cpu_count() or 1, runs))
    return simulated_s / (SIM_S_PER_CORE_S * cores)


def confirm(
    what: str, seconds: float, *, yes: bool, parameter: str | None, value, source: str = ""
) -> None:
    """Announce work over :data:`ANNOUNCE_S` on stderr; refuse work over :data:`CEILING_S`
    unless ``yes`` (an :class:`InputError` naming ``parameter``, before anything is done).

    ``source`` names where ``value`` came from when it is not the parameter's flag (a spec
    file's key, ``"spec.toml: runs_per_case = 100000"``); then ``parameter`` is None.
    """
    if seconds > CEILING_S and not yes:
        raise InputError(
            f"{source or value}: {what} would take about {human_duration(seconds)} on this "
            f"machine (more than {human_duration(CEILING_S)}); pass --yes to start it anyway",
            parameter=parameter,
            value=value,
        )
    if seconds > ANNOUNCE_S:
        print(f"rcsim: {what}: about {human_duration(seconds)} on this machine", file=sys.stderr)
