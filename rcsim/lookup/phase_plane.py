"""Phase-plane attitude controller (the paper's baseline, after the Morpheus roll controller).

Per axis, with attitude error ``e`` and rate error ``r = omega - omega_cmd``:

* the *switching function* ``s = e + r |r| / (2 a)`` predicts the attitude error once the rate
  error has been braked to zero at the axis's control acceleration ``a`` (the classic
  minimum-time parabola; Wie, *Space Vehicle Dynamics and Control*, sec. 7.3; Feron,
  *Attitude Control with Thrusters*);
* a maneuver starts when ``|s|`` leaves the attitude deadband: the target rate becomes
  ``omega_cmd - sign(s) * maneuver_rate``; it ends (target back to ``omega_cmd``) when ``s``
  crosses zero -- this hysteresis lands the attitude near the middle of the deadband instead of
  at its edge;
* when the axis's jets are idle and ``|omega - target|`` exceeds the rate deadband, a firing of
  ``|omega - target| / a`` seconds is commanded on the jets whose torque sign (the vehicle's
  own Table 2, from its geometry) opposes the rate error; it is delivered over as many control
  cycles as it needs.

See ``docs/phase_plane.md`` for the diagram.  The controller knows the nominal mass properties
and the jet map (unlike the lookup controller); the control acceleration comes from them.  It
flies a vehicle whose jets each turn one axis (the paper's; :func:`rcsim.lookup.registry.
vehicle_problem` refuses a coupled layout).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rcsim.spacecraft.navigation import NavState
from rcsim.spacecraft.propellant import inertia_tensor_B
from rcsim.spacecraft.vehicle.run_parameters import torque_per_jet_B

if TYPE_CHECKING:
    from rcsim.spacecraft.vehicle import Vehicle


@dataclass(frozen=True)
class PhasePlaneParams:
    """Phase-plane gains and the vehicle knowledge it needs (a vehicle's own:
    :meth:`for_vehicle`; the paper vehicle's values in brackets).

    Attributes
    ----------
    jet_map : ndarray of int, (n_jets, 3)
        Sign of each jet's torque about roll, pitch, yaw (0: not used): the vehicle's own
        Table 2, from its geometry (:attr:`rcsim.spacecraft.vehicle.Vehicle.axis_signs`).
    accel_rad_s2 : ndarray, (3,)
        Angular acceleration of one firing group per axis [rad/s^2] (nominal vehicle).
    att_deadband_rad : float
        Attitude deadband half-width [rad] (0.25 deg).
    rate_deadband_rad_s : float
        Rate error below which no firing is commanded [rad/s] (0.03 deg/s).
    maneuver_rate_rad_s : float
        Maneuver rate limit [rad/s] (0.2 deg/s).
    cycle_s : float
        Control cycle [s] the firings are split into (40 ms): the vehicle's profile's, the
        simulation's.
    """

    jet_map: np.ndarray
    accel_rad_s2: np.ndarray
    att_deadband_rad: float
    rate_deadband_rad_s: float
    maneuver_rate_rad_s: float
    cycle_s: float

    @classmethod
    def for_vehicle(cls, vehicle: Vehicle, **gains) -> PhasePlaneParams:
        """Gains for the vehicle's nominal parameters and its profile (``gains``: overrides
        of the deadbands or the maneuver rate).  ``a`` = torque of the jets that turn the axis
        the positive way / inertia (the tensor's diagonal in B,
        :func:`rcsim.spacecraft.propellant.inertia_tensor_B`)."""
        control = vehicle.control
        params = vehicle.nominal(1)
        torque = torque_per_jet_B(params, vehicle.model)[0]  # (n_jets, 3)
        jet_map = vehicle.axis_signs
        # Torque of the positive jets of each axis (a firing pair) about that axis.
        pair = np.array([torque[jet_map[:, a] > 0, a].sum() for a in range(3)])
        axis_inertia = np.diagonal(inertia_tensor_B(params)[0])
        base = {
            "att_deadband_rad": control.phase_plane_att_deadband_rad,
            "rate_deadband_rad_s": control.phase_plane_rate_deadband_rad_s,
            "maneuver_rate_rad_s": control.maneuver_rate_rad_s,
            "cycle_s": control.cycle_s,
        }
        return cls(jet_map=jet_map, accel_rad_s2=pair / axis_inertia, **{**base, **gains})


@dataclass
class PhasePlaneState:
    """Per-run, per-axis controller state (arrays shaped ``(n_runs, 3)``).

    ``mode``: -1, 0, +1, the sign of the maneuver rate being flown.  ``remaining_s``: on-time
    left in the current firing [s].  ``direction``: its torque sign (+1/-1, 0 when idle).
    """

    mode: np.ndarray
    remaining_s: np.ndarray
    direction: np.ndarray


class PhasePlaneController:
    """Batched phase-plane controller; see the module docstring for the logic."""

    def __init__(self, params: PhasePlaneParams):
        self.params = params
        jm = np.asarray(params.jet_map)
        # (2, 3, 16) masks: jets that torque axis a in the negative [0] / positive [1] sense.
        self._jets = np.stack([(jm.T < 0), (jm.T > 0)]).astype(float)

    @property
    def cycle_s(self) -> float:
        """Control cycle the controller assumes [s] (checked by the simulation)."""
        return self.params.cycle_s

    def initial_state(self, n_runs: int) -> PhasePlaneState:
        z = np.zeros((n_runs, 3))
        return PhasePlaneState(mode=z.copy(), remaining_s=z.copy(), direction=z.copy())

    def step(self, nav: NavState, state: PhasePlaneState) -> tuple[np.ndarray, PhasePlaneState]:
        """One control cycle.

        Returns
        -------
        on_time_s : ndarray, (n_runs, 16)
            On-time of each jet this cycle [s].
        state : PhasePlaneState
        """
        p = self.params
        e, r = nav.att_err_B, nav.rate_err_B
        s = e + r * np.abs(r) / (2.0 * p.accel_rad_s2)
        # Hysteresis: start a maneuver outside the deadband, end it when s crosses zero.
        start = (state.mode == 0) & (np.abs(s) > p.att_deadband_rad)
        mode = np.where(start, -np.sign(s), state.mode)
        mode = np.where((mode != 0) & (mode * s >= 0), 0.0, mode)
        target_err = mode * p.maneuver_rate_rad_s  # target of the rate *error*
        delta = r - target_err

        idle = state.remaining_s <= 1e-12
        fire = idle & (np.abs(delta) > p.rate_deadband_rad_s)
        remaining = np.where(fire, np.abs(delta) / p.accel_rad_s2, state.remaining_s)
        direction = np.where(fire, -np.sign(delta), np.where(idle, 0.0, state.direction))

        on_axis = np.minimum(remaining, p.cycle_s)  # (n, 3)
        pos = (direction > 0) * on_axis
        neg = (direction < 0) * on_axis
        on_time = pos @ self._jets[1] + neg @ self._jets[0]  # (n, 16)
        remaining = np.maximum(remaining - p.cycle_s, 0.0)
        direction = np.where(remaining > 0, direction, 0.0)
        return on_time, PhasePlaneState(mode=mode, remaining_s=remaining, direction=direction)
