"""What the closed loop flies: a batched controller (:class:`Controller`), a protocol.

A controller is a step function over arrays shaped ``(n_runs, ...)`` with explicit state: the
navigation errors of every run in, every jet's on-time for the cycle and the next state out.
One run is a batch of one.  The controllers rcsim builds are in :mod:`rcsim.lookup`
(:func:`rcsim.lookup.registry.make_controller`); the smallest one is
:class:`rcsim.lookup.open_loop.OpenLoopController`.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from rcsim.spacecraft.navigation import NavState


class Controller(Protocol):
    """A batched controller: explicit state in, jet on-times and new state out.

    ``cycle_s`` is the control cycle the controller's logic assumes (timers, firings split
    into cycles) [s]: the vehicle's profile's, given to the controller when it is built;
    :meth:`BatchSimulation.run` refuses a controller on another cycle.
    """

    @property
    def cycle_s(self) -> float: ...

    def initial_state(self, n_runs: int) -> Any: ...

    def step(self, nav: NavState, state: Any) -> tuple[np.ndarray, Any]:
        """Return on-times this cycle [s], shape (n_runs, n_jets), and the next state
        (``n_jets``: the flown vehicle's)."""
