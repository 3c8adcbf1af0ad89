"""An open-loop controller: each jet fires for a set time from t = 0, cycle by cycle.

For replaying a firing pattern without feedback (a table entry flown as it stands, a pulse test,
a coasting vehicle), and the oracle flights of the propulsion and integration tests: the
impulse and timing it commands are known exactly.
"""

from __future__ import annotations

import numpy as np


class OpenLoopController:
    """Fire jet ``j`` of run ``i`` for ``total_s[i, j]`` seconds from t = 0; no feedback.

    Parameters
    ----------
    total_s : array_like, (n_runs, n_jets) or (n_jets,)
        Total on-time of each of the vehicle's ``n_jets`` jets [s]; a row is every run's.
        ``np.zeros(n_jets)`` coasts.  The simulation refuses a width other than its vehicle's.
    cycle_s : float
        Control cycle [s]: the flown vehicle's (``vehicle.control.cycle_s``); the simulation
        refuses another.

    Notes
    -----
    The state is the number of cycles done: cycle ``k`` delivers
    ``clip(total_s - k cycle_s, 0, cycle_s)``, so a firing is one contiguous pulse from t = 0.
    """

    def __init__(self, total_s, cycle_s: float):
        self.total_s = np.asarray(total_s, float)
        if self.total_s.ndim not in (1, 2) or self.total_s.shape[-1] < 1:
            raise ValueError(
                f"total_s must have shape (n_runs, n_jets) or (n_jets,), got {self.total_s.shape}"
            )
        self.cycle_s = float(cycle_s)

    def initial_state(self, n_runs: int) -> int:
        if self.total_s.ndim == 2 and self.total_s.shape[0] != n_runs:
            raise ValueError(f"total_s has {self.total_s.shape[0]} runs, asked for {n_runs}")
        return 0

    def step(self, nav, k: int) -> tuple[np.ndarray, int]:
        """On-times of cycle ``k`` [s], shape (n_runs, n_jets), and the next state."""
        on = np.clip(self.total_s - k * self.cycle_s, 0.0, self.cycle_s)
        return np.broadcast_to(on, (nav.n_runs, on.shape[-1])).copy(), k + 1
