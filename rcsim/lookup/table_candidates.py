"""Jet-table firing times under valve timing: the firing loop's neighbours, flown open loop.

The paper's rule (:mod:`rcsim.lookup.table_generation`) fires whole cycles on each commanded axis,
reads the rate at every cycle's end, and keeps the whole number of cycles whose end rate is
nearest the command.  Without valve timing that end rate is the rate a table row of that many
cycles ends at.  With it (:mod:`rcsim.spacecraft.valves`: command delay ``d``, valve latencies
``d_o``, ``d_c``) it is not: a row of ``k`` cycles thrusts over ``[d + d_o, d + k T + d_c]``,
so its rate keeps changing ``d + d_c`` after the row's last cycle, while the firing loop's
rate at the ``k``-th cycle's end has seen only ``k T - d - d_o`` of thrust.  The rate the
loop reads lags the row's by ``d + d_c`` (less than a cycle, :meth:`ValveTiming.check
<rcsim.spacecraft.valves.ValveTiming.check>`), so the nearest row has the loop's cycles or one
fewer; one more only through the rotation's nonlinearity.

:func:`nearest_rows` therefore flies, for every case, each commanded axis's ``cycles - 1``,
``cycles`` and ``cycles + 1`` (none below 0) in every combination, open loop from the case's
initial rate with the vehicle's delays (as the lookup controller fires a table row), watches
them ``settle_window_s`` more, and keeps per case the combination whose final rate error (all
three axes, squared) is least: the channel tables' step 2 (:mod:`rcsim.lookup.channel_generation`).
Without timing it is not used, and the paper's rule stands as it was.

Imports ``models``, ``spacecraft`` and ``lookup`` only.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.simulation import simulate_batch
from rcsim.spacecraft.valves import JetFaults, ValveTiming
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle


def nearest_rows(
    found_cycles: np.ndarray,
    direction: np.ndarray,
    target_rad_s: np.ndarray,
    omega0_rad_s: np.ndarray,
    jet_map: np.ndarray,
    row_times: Callable[[np.ndarray, np.ndarray], np.ndarray],
    *,
    params: RunParameters,
    vehicle: Vehicle,
    timing: ValveTiming,
    faults: JetFaults | None,
    settle_window_s: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The cycles per case and axis whose open-loop flight ends nearest the command (module
    docstring), from the firing loop's.

    Parameters
    ----------
    found_cycles, direction : ndarray of int, (n, 3)
        The firing loop's cycles and torque signs per case and axis
        (:func:`rcsim.lookup.table_generation.sweep`).
    target_rad_s, omega0_rad_s : ndarray, (n, 3)
        Commanded and initial body rates [rad/s].
    jet_map : ndarray of int, (16, 3)
        The jets that may fire (Table 2, failed jets zeroed).
    row_times : callable
        ``(cycles (m, 3), direction (m, 3)) -> (m, 16)`` per-jet firing times [s] of rows
        (:func:`rcsim.lookup.table_generation.firing_times` on ``jet_map``).
    params : RunParameters
        The ``n`` vehicles, of ``vehicle``.
    timing : ValveTiming
        The ``n`` runs' delays; ``faults``: their jet faults (None: none).

    Returns
    -------
    cycles : ndarray of int, (n, 3)
        Chosen per case and axis.
    end_rate_err_rad_s : ndarray, (n, 3)
        The chosen rows' rate errors ``settle_window_s`` after the longest candidate's firing.
    """
    cyc = vehicle.control.cycle_s
    jm = np.asarray(jet_map, int)
    served = (direction != 0) & np.stack(
        [(jm[None, :, a] == direction[:, a, None]).any(axis=1) for a in range(3)], axis=1
    )
    combos, owner = [], []
    for i in range(direction.shape[0]):  # 26 cases, at most 27 combinations each
        axes = [
            range(max(c - 1, 0), c + 2) if s else (0,)
            for c, s in zip(found_cycles[i], served[i], strict=True)
        ]
        for combo in itertools.product(*axes):
            combos.append(combo)
            owner.append(i)
    cycles = np.array(combos, int)
    rows = np.array(owner, int)
    times = row_times(cycles, direction[rows])
    duration = np.ceil((float(times.max()) + settle_window_s) / cyc - 1e-9) * cyc
    hist = simulate_batch(
        params.take(rows),
        OpenLoopController(times, cyc),
        Guidance.rate(np.asarray(target_rad_s, float)[rows]),
        float(duration),
        omega0_B=np.asarray(omega0_rad_s, float)[rows],
        vehicle=vehicle,
        timing=timing.take(rows),
        faults=None if faults is None else faults.take(rows),
    )
    score = (hist.final.rate_err_B**2).sum(axis=1)
    best = np.array(
        [np.flatnonzero(rows == i)[np.argmin(score[rows == i])] for i in range(len(direction))]
    )
    return cycles[best], hist.final.rate_err_B[best].copy()
