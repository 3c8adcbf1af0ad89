"""A flight-software plug-in written from scratch: a batched switching-line controller.

On each axis it forms the switching function ``s = rate_err + att_err / tau`` and, while
``|s|`` exceeds the deadband, fires for the whole cycle the jets that turn that axis alone in
the direction that reduces ``s`` (the vehicle's ``axis_signs``). It holds no state. It is a
teaching example of the Controller protocol (rcsim/spacecraft/controller.py), not a tuned
controller: rcsim's phase-plane controller is the real thing.

Parameters (``[controller.params]`` or ``--param``): ``deadband_deg_s`` (default 0.02) and
``tau_s``, the time constant of the attitude term (default 20).
"""

import math

import numpy as np


class SwitchingLine:
    def __init__(self, axis_signs, cycle_s, deadband_rad_s, tau_s):
        signs = np.asarray(axis_signs)
        pure = np.count_nonzero(signs, axis=1) == 1  # jets that turn one axis only
        # (3, n_jets) 0/1: the jets that add positive / negative rate on each axis.
        self.plus = ((signs == 1) & pure[:, None]).T.astype(float)
        self.minus = ((signs == -1) & pure[:, None]).T.astype(float)
        self._cycle_s = float(cycle_s)
        self.deadband = float(deadband_rad_s)
        self.tau_s = float(tau_s)

    @property
    def cycle_s(self):
        return self._cycle_s

    def initial_state(self, n_runs):
        return None

    def step(self, nav, state):
        s = nav.rate_err_B + nav.att_err_B / self.tau_s  # (n_runs, 3) [rad/s]
        high = (s > self.deadband).astype(float)  # too fast (or too far ahead): slow down
        low = (s < -self.deadband).astype(float)
        fire = high @ self.minus + low @ self.plus  # (n_runs, n_jets)
        return np.where(fire > 0, self._cycle_s, 0.0), state


def make_controller(vehicle, params):
    """Factory: ``(vehicle, params) -> Controller``."""
    unknown = set(params) - {"deadband_deg_s", "tau_s"}
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; takes deadband_deg_s, tau_s")
    deadband_deg_s = float(params.get("deadband_deg_s", 0.02))
    tau_s = float(params.get("tau_s", 20.0))
    if not (deadband_deg_s > 0 and tau_s > 0):
        raise ValueError(f"deadband_deg_s and tau_s must be > 0, got {deadband_deg_s}, {tau_s}")
    return SwitchingLine(
        vehicle.axis_signs, vehicle.control.cycle_s, math.radians(deadband_deg_s), tau_s
    )
