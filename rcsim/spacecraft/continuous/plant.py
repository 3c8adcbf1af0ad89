"""The DAI spacecraft in MuJoCo, many runs at once, and the closed loop around it.

:class:`ContinuousPlant` holds ``n_runs`` copies of ``rcsim/models/dai/dai_spacecraft.xml`` in one
:class:`mujoco.batch.Batch` (native threads, GIL released), each with its own inertia (the
principal moments and principal frame MuJoCo stores, from the full 3x3 tensor).  The step size
is the paper's fixed step, RK4 (``docs/convergence.md`` standard; the step is checked by the
convergence test in ``tests/spacecraft/test_continuous.py``).

:func:`fly` runs the closed loop: every step each run's Euler angles are measured (plus any
given sensor noise), one vectorized controller step gives the commanded torque, the actuator
(ideal, or the CMG array of :mod:`.cmg`) turns it into the delivered torque, the switchable
disturbances are added, and MuJoCo advances all runs by one step with the torque held (zero-
order hold, as the papers' fixed-step Simulink models).  No Python loop over runs.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Protocol

import mujoco
import numpy as np
from mujoco.batch import Batch

from rcsim.models.dai import Damage, dai_xml
from rcsim.models.errors import InputError
from rcsim.spacecraft.continuous.cmg import CmgArray
from rcsim.spacecraft.continuous.disturbances import Disturbances
from rcsim.spacecraft.continuous.kinematics import euler321_from_quat
from rcsim.spacecraft.mujoco_timers import quiet_stage_timers
from rcsim.spacecraft.vehicle.model import route_mujoco_warnings

BODY = "spacecraft"
TORQUE_ACTUATORS = ("torque_x", "torque_y", "torque_z")
_CTRL = int(mujoco.mjtState.mjSTATE_CTRL)


def load_dai_model(timestep_s: float) -> mujoco.MjModel:
    """The packaged DAI spacecraft with physics step ``timestep_s`` [s] (RK4)."""
    if not (math.isfinite(timestep_s) and timestep_s > 0):
        raise InputError(f"must be > 0, got {timestep_s}", parameter="timestep_s", value=timestep_s)
    route_mujoco_warnings()  # a diverging run's warning goes to the log, not MUJOCO_LOG.TXT
    model = mujoco.MjModel.from_xml_path(str(dai_xml()))
    model.opt.timestep = timestep_s
    return model


def principal_inertia(inertia_B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (n, 3) and the quaternions (n, 4) of the principal frames in B."""
    moments, vecs = np.linalg.eigh(inertia_B)
    vecs = vecs * np.sign(np.linalg.det(vecs))[:, None, None]  # right-handed
    quats = np.empty((len(moments), 4))
    for i, v in enumerate(vecs):  # once per run at set-up (or damage), not per step
        mujoco.mju_mat2Quat(quats[i], np.ascontiguousarray(v).ravel())
    return moments, quats


class ContinuousPlant:
    """``n_runs`` rigid DAI spacecraft, each with its own inertia.

    Parameters
    ----------
    inertia_B : ndarray, (n_runs, 3, 3)
        True inertia of each run [kg m^2].
    timestep_s : float
        Physics (= control) step [s].
    nthread : int
        MuJoCo worker threads (0: all CPUs).
    """

    def __init__(self, inertia_B: np.ndarray, *, timestep_s: float, nthread: int = 0):
        inertia_B = np.asarray(inertia_B, float)
        if inertia_B.ndim != 3 or inertia_B.shape[1:] != (3, 3):
            raise InputError(
                f"must have shape (n_runs, 3, 3), got {inertia_B.shape}", parameter="inertia_B"
            )
        self.model = load_dai_model(timestep_s)
        quiet_stage_timers()
        self.dt_s = timestep_s
        self.n_runs = inertia_B.shape[0]
        self._batch = Batch(self.model, self.n_runs, nthread)
        self._body = self.model.body(BODY).id
        self._act = np.array([self.model.actuator(n).id for n in TORQUE_ACTUATORS])
        self.set_inertia(inertia_B)
        self._qpos = self._batch.bind("qpos")
        self._qvel = self._batch.bind("qvel")

    def set_inertia(self, inertia_B: np.ndarray) -> None:
        """Give every run a new inertia (also mid-flight: the simulated damage)."""
        moments, quats = principal_inertia(np.asarray(inertia_B, float))
        self._batch.expand("body_inertia")[:, self._body] = moments
        self._batch.expand("body_iquat")[:, self._body] = quats
        # body_inertia / body_iquat feed constants (dof_invweight0...) only mj_setConst updates.
        self._batch.set_const()
        self.inertia_B = np.array(inertia_B, float)

    def reset(self, q0_BN: np.ndarray | None = None, omega0_B: np.ndarray | None = None) -> None:
        """Every run to attitude ``q0_BN`` (n_runs, 4) and body rate ``omega0_B`` (n_runs, 3)."""
        self._batch.reset(stage=int(mujoco.mjtStage.mjSTAGE_NONE))
        if q0_BN is not None:
            q = np.asarray(q0_BN, float).reshape(self.n_runs, 4)
            self._qpos[:] = q / np.linalg.norm(q, axis=1, keepdims=True)
        if omega0_B is not None:
            self._qvel[:] = np.asarray(omega0_B, float).reshape(self.n_runs, 3)
        self._batch.forward()

    @property
    def q_BN(self) -> np.ndarray:
        """Attitudes (n_runs, 4), a copy."""
        return self._qpos.copy()

    @property
    def omega_B(self) -> np.ndarray:
        """Body rates [rad/s] (n_runs, 3), a copy (a ball joint's qvel is in body axes)."""
        return self._qvel.copy()

    def step(self, torque_B: np.ndarray, n_steps: int = 1) -> None:
        """Advance every run ``n_steps`` physics steps with body torque ``torque_B`` held."""
        control = np.zeros((self.n_runs, n_steps, self.model.nu))
        control[:, :, self._act] = np.asarray(torque_B, float)[:, None, :]
        self._batch.rollout(n_steps, control=control, control_spec=_CTRL, record=())


class Controller(Protocol):
    """A batched continuous-torque controller with explicit state (``rcsim.lookup.continuous``)."""

    def initial_state(self, n_runs: int) -> Any: ...

    def step(self, t_s: float, euler_meas: np.ndarray, state: Any) -> tuple[np.ndarray, Any]:
        """Commanded body torque [N m] (n_runs, 3) and the next state."""


@dataclass
class ContinuousHistory:
    """Per-step record (sample k at ``t_s[k]``, before the step's torque is applied).

    Attributes
    ----------
    t_s : (n_steps,)
    q_BN : (n_runs, n_steps, 4)
    omega_B, u_cmd_B, u_act_B, dist_B : (n_runs, n_steps, 3)
        Body rate [rad/s], commanded, delivered and disturbance torque [N m].
    cmg_det : (n_runs, n_steps) or None
        det A of the CMG array (None: ideal actuator).
    cmg_singular : (n_runs, n_steps) bool or None
    telemetry : dict of (n_runs, n_steps, k) arrays
        What the controller reports (``controller.telemetry(state)``), e.g. Theta_hat.
    wall_s : float
        Wall time of the loop [s].
    """

    t_s: np.ndarray
    q_BN: np.ndarray
    omega_B: np.ndarray
    u_cmd_B: np.ndarray
    u_act_B: np.ndarray
    dist_B: np.ndarray
    cmg_det: np.ndarray | None = None
    cmg_singular: np.ndarray | None = None
    telemetry: dict = field(default_factory=dict)
    wall_s: float = 0.0


def fly(
    plant: ContinuousPlant,
    controller: Controller,
    duration_s: float,
    *,
    cmg: CmgArray | None = None,
    disturbances: Disturbances | None = None,
    damage: Damage | None = None,
    angle_noise: np.ndarray | None = None,
    q0_BN: np.ndarray | None = None,
    omega0_B: np.ndarray | None = None,
) -> ContinuousHistory:
    """Fly every run of ``plant`` for ``duration_s`` (rounded to whole steps).

    Parameters
    ----------
    plant : ContinuousPlant
    controller : Controller
    duration_s : float
        > 0 [s].
    cmg : CmgArray, optional
        Actuate through three CMGs; default the ideal three-axis torque actuator.
    disturbances : Disturbances, optional
    damage : Damage, optional
        At ``damage.time_s`` every run's inertia diagonal is multiplied by ``damage.factors``
        (001 App. A.2).
    angle_noise : ndarray, (n_runs, n_steps, 3), optional
        Added to the measured Euler angles [rad] (drawn by the caller from each run's stream).
    q0_BN, omega0_B : optional
        Initial state; default identity and rest (001 App. C, 002 Sec. 3).
    """
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise InputError(f"must be > 0, got {duration_s}", parameter="duration_s", value=duration_s)
    n, dt = plant.n_runs, plant.dt_s
    k_max = int(round(duration_s / dt))
    if angle_noise is not None and angle_noise.shape != (n, k_max, 3):
        raise InputError(
            f"must have shape {(n, k_max, 3)}, got {angle_noise.shape}", parameter="angle_noise"
        )
    plant.reset(q0_BN, omega0_B)
    state = controller.initial_state(n)
    cmg_state = cmg.initial_state(n) if cmg is not None else None
    # Damage at the first step whose start time reaches damage.time_s (integer ticks).
    k_damage = int(math.ceil(damage.time_s / dt - 1e-9)) if damage is not None else -1
    rec = {name: np.empty((k_max, n, 3)) for name in ("omega", "u_cmd", "u_act", "dist")}
    rec_q = np.empty((k_max, n, 4))
    det = np.empty((k_max, n)) if cmg is not None else None
    sing = np.zeros((k_max, n), bool) if cmg is not None else None
    telemetry: dict[str, list] = {}
    wall0 = time.perf_counter()
    for k in range(k_max):
        t = k * dt
        if damage is not None and k == k_damage:
            damaged = plant.inertia_B.copy()
            idx = np.arange(3)
            damaged[:, idx, idx] *= damage.factors
            plant.set_inertia(damaged)
        q, omega = plant.q_BN, plant.omega_B
        euler = euler321_from_quat(q)
        if angle_noise is not None:
            euler = euler + angle_noise[:, k]
        u_cmd, state = controller.step(t, euler, state)
        if cmg is not None and cmg_state is not None and det is not None and sing is not None:
            out, cmg_state = cmg.steer(u_cmd, omega, cmg_state, dt)
            u_act = out.torque_B
            det[k], sing[k] = out.det, out.singular
        else:
            u_act = u_cmd
        dist = (
            disturbances.torque_B(t, q, plant.inertia_B)
            if disturbances is not None
            else np.zeros((n, 3))
        )
        rec_q[k], rec["omega"][k], rec["u_cmd"][k] = q, omega, u_cmd
        rec["u_act"][k], rec["dist"][k] = u_act, dist
        if hasattr(controller, "telemetry"):
            for key, value in controller.telemetry(state).items():
                telemetry.setdefault(key, []).append(value)
        plant.step(u_act + dist)
    wall = time.perf_counter() - wall0
    sw = lambda a: a.swapaxes(0, 1)  # noqa: E731  (steps, runs, ...) -> (runs, steps, ...)
    return ContinuousHistory(
        t_s=np.arange(k_max) * dt,
        q_BN=sw(rec_q),
        omega_B=sw(rec["omega"]),
        u_cmd_B=sw(rec["u_cmd"]),
        u_act_B=sw(rec["u_act"]),
        dist_B=sw(rec["dist"]),
        cmg_det=None if det is None else det.T,
        cmg_singular=None if sing is None else sing.T,
        telemetry={k: sw(np.asarray(v)) for k, v in telemetry.items()},
        wall_s=wall,
    )
