"""Time and memory estimates before long work, and a ceiling that needs ``--yes``.

A command that would fly for more than about a minute says how long first; one that would fly
beyond :data:`CEILING_S` refuses to start unless the user confirms (``--yes``): a mistyped
``--runs-per-case 100000`` is a day of a 2-core machine, found out before, not after.  Work
whose memory would exceed half of the machine's (:func:`check_memory`) is refused outright,
``--yes`` or not: it would end in a ``MemoryError`` or the system's out-of-memory killer.

The estimate is simulated seconds over a measured rate, not a promise: the lookup-table
campaign flies about 7,500 simulated seconds per wall second on one core of the development
machine (``docs/performance.md``); :data:`SIM_S_PER_CORE_S` takes two thirds of
that, so that a loaded machine is rarely slower than the estimate.  Commands whose cost is not
simulated time have their own measured rates below (``lookup database``, ``vehicle
check``, ``lookup refine``'s memory).
"""

from __future__ import annotations

import os
import sys
import time

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
    what: str,
    seconds: float,
    *,
    yes: bool,
    parameter: str | None,
    value,
    source: str = "",
    instead: str = "",
) -> None:
    """Announce work over :data:`ANNOUNCE_S` on stderr; refuse work over :data:`CEILING_S`
    unless ``yes`` (an :class:`InputError` naming ``parameter``, before anything is done).

    ``source`` names where ``value`` came from when it is not the parameter's flag (a spec
    file's key, ``"spec.toml: runs_per_case = 100000"``); then ``parameter`` is None.
    ``instead``: what else the user can do, ending the message (``"or --no-pairs"``).
    """
    if seconds > CEILING_S and not yes:
        raise InputError(
            f"{source or value}: {what} would take about {human_duration(seconds)} on this "
            f"machine (more than {human_duration(CEILING_S)}); pass --yes to start it anyway"
            + (f", {instead}" if instead else ""),
            parameter=parameter,
            value=value,
        )
    if seconds > ANNOUNCE_S:
        print(f"rcsim: {what}: about {human_duration(seconds)} on this machine", file=sys.stderr)


def check_memory(
    what: str, need_bytes: float, *, parameter: str | None, value, source: str = "", advice: str
) -> None:
    """Refuse work whose memory estimate exceeds half of this machine's memory (the budget of
    :func:`rcsim.spacecraft.guards.memory_budget_bytes`), ``--yes`` or not."""
    from rcsim.spacecraft.guards import human_bytes, memory_budget_bytes

    budget = memory_budget_bytes()
    if budget is not None and need_bytes > budget:
        raise InputError(
            f"{source or value}: {what} needs about {human_bytes(need_bytes)} of memory, more "
            f"than the {human_bytes(budget)} allowed (half of this machine's memory); {advice}",
            parameter=parameter,
            value=value,
        )


#: ``lookup database``: wall seconds per flight (one jet, one on-time, one dispersed vehicle),
#: and the fixed start.  Measured on the 2-core development machine, loaded by other work:
#: 64, 512 and 2,048 vehicles of the paper's 16 jets (6,144 to 196,608 flights) took 6.1,
#: 16.8 and 35.9 s, 130 us per flight beyond the start.
DATABASE_S_PER_FLIGHT = 150e-6
DATABASE_START_S = 6.0
#: ``lookup database``: bytes per flight per jet of the vehicle (its on-times, forces and
#: parameters are per jet).  Measured: peak RSS 603 MB at 49,152 flights and 1,739 MB at
#: 196,608 flights of 16 jets, 7.7 kB per flight, 480 bytes per jet.
DATABASE_BYTES_PER_FLIGHT_JET = 500


def check_database_cost(vehicle, n_vehicles: int, *, yes: bool) -> None:
    """``lookup database``'s time and memory for ``n_vehicles`` dispersed copies of
    ``vehicle`` (a file or packaged name): refused over the limits, announced when long."""
    from rcsim.lookup.response_database import ON_TIMES_S, flown_on_times
    from rcsim.spacecraft.vehicle import load_vehicle

    if isinstance(n_vehicles, bool) or not isinstance(n_vehicles, int) or n_vehicles < 1:
        return  # the library's own check names it
    definition = load_vehicle(vehicle)
    on_times = flown_on_times(ON_TIMES_S, definition.min_on_s)[0].size
    flights = definition.n_jets * on_times * n_vehicles
    what = (
        f"the database ({flights:,} flights: {definition.n_jets} jets x {on_times} on-times x "
        f"{n_vehicles:,} vehicles)"
    )
    check_memory(
        what,
        flights * definition.n_jets * DATABASE_BYTES_PER_FLIGHT_JET,
        parameter="n_vehicles",
        value=n_vehicles,
        advice="fewer vehicles",
    )
    confirm(
        what,
        DATABASE_START_S + flights * DATABASE_S_PER_FLIGHT,
        yes=yes,
        parameter="n_vehicles",
        value=n_vehicles,
    )


#: ``vehicle check``: bytes per two-jets-out pair kept in the result (two names in a tuple).
PAIR_BYTES = 200


def check_vehicle_cost(vehicle, *, pairs: bool, yes: bool, source: str) -> None:
    """``vehicle check``'s time (linear programs, :func:`rcsim.spacecraft.vehicle.
    authority.lp_count`, at a rate measured on this vehicle now) and, with the pairs, memory:
    refused over the limits, announced when long."""
    import numpy as np

    from rcsim.spacecraft.vehicle.authority import lp_count, reachable
    from rcsim.spacecraft.vehicle.mjcf import force_torque

    n = vehicle.n_jets
    n_pairs = n * (n - 1) // 2
    accel = np.linalg.solve(vehicle.inertia_kg_m2, force_torque(vehicle)[3:])
    every = np.ones(n, bool)
    t0 = time.perf_counter()
    for axis in range(3):  # three of the LPs the check solves, timed on this vehicle
        reachable(accel, axis, 1, every)
    per_lp = (time.perf_counter() - t0) / 3
    what = f"the check of its {n} jets" + (f" and {n_pairs:,} two-jets-out pairs" if pairs else "")
    if pairs:
        check_memory(
            what,
            n_pairs * PAIR_BYTES,
            parameter=None,
            value=n,
            source=f"{source}: {n} jets",
            advice="pass --no-pairs",
        )
    confirm(
        what,
        lp_count(n, pairs=pairs) * per_lp,
        yes=yes,
        parameter=None,
        value=n,
        source=f"{source}: {n} jets",
        instead="or --no-pairs" if pairs else "",
    )


#: ``lookup refine``: bytes per dispersed run of a case (its drawn vehicle, its rows for every
#: table flown).  Measured: peak RSS 344 MB with 200 runs and 360 MB with 1,600 runs of 4
#: cases, 2.8 kB per run beyond the start; rounded up.
REFINE_BYTES_PER_RUN = 4096
