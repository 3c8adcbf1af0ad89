"""The vehicle's MuJoCo model: its names, the warning route, jet geometry and jet torque.

A vehicle's model is compiled from its file (:mod:`rcsim.spacecraft.vehicle.mjcf`): one free body
``vehicle``, one site actuator per jet named ``jet_01``, ``jet_02``... and the three body-frame
disturbance torques.  This module reads that structure back: the jets' actuator ids and count,
and their geometry (each run's jet force and torque from it:
:func:`rcsim.spacecraft.vehicle.run_parameters.jet_force_torque_B`).
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

# ``N_JETS`` (16) is the *paper's* jet count (Gambone Table 2), re-exported for what is the
# paper's: its jet map and its 26 x 16 lookup tables.  Nothing on the flight path uses it: a
# vehicle's own count is its compiled model's (:func:`jet_count`) or its parameters'
# (:attr:`RunParameters.n_jets`), and every per-jet array is that wide.
from rcsim.models.tables import N_JETS as N_JETS

DIST_NAMES = ("dist_x", "dist_y", "dist_z")
AXES = ("roll", "pitch", "yaw")
BODY = "vehicle"
#: MuJoCo's identity quaternion (w, x, y, z): principal axes along the body axes.
IDENTITY_QUAT = (1.0, 0.0, 0.0, 0.0)


#: Logger that receives MuJoCo's warning messages (see :func:`route_mujoco_warnings`).
MUJOCO_LOGGER = logging.getLogger("rcsim.mujoco")


def _log_mujoco_warning(message: str) -> None:
    # Called by MuJoCo, possibly from a batch's worker threads (the bindings take the GIL).
    MUJOCO_LOGGER.info("MuJoCo warning: %s", message)


def route_mujoco_warnings() -> None:
    """Send MuJoCo's warning messages to the ``rcsim.mujoco`` logger (level INFO).

    Without a handler, MuJoCo prints each warning and appends it to ``MUJOCO_LOG.TXT`` in the
    current directory: a stray file in the user's directory.  What a warning means for a run
    is recorded in that run's own failure reason (:mod:`rcsim.spacecraft.simulation` reads the
    per-run warning counters), so the message itself is only logged.  A handler the caller
    installed (``mujoco.set_mju_user_warning``) is kept.  Idempotent; process-wide, as
    MuJoCo's handler is.
    """
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_log_mujoco_warning)


def jet_name(number: int) -> str:
    """Actuator name of jet ``number`` (1-based): ``jet_01``, ``jet_02``, ... ``jet_100``."""
    return f"jet_{number:02d}"


def jet_actuator_ids(model: mujoco.MjModel) -> np.ndarray:
    """Actuator ids of the vehicle's jets in jet order, shape ``(n_jets,)``.

    The jets are the actuators named ``jet_01``, ``jet_02``, ... (the packaged MJCF's 16, a
    vehicle file's any number: :mod:`rcsim.spacecraft.vehicle.mjcf`), counted up to the first
    number that is missing.
    """
    ids: list[int] = []
    while True:
        k = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, jet_name(len(ids) + 1))
        if k < 0:
            return np.array(ids, dtype=int)
        ids.append(k)


def jet_count(model: mujoco.MjModel) -> int:
    """How many jets the vehicle ``model`` has: the one owner of a vehicle's jet count
    (:attr:`RunParameters.n_jets` is the same number, read from the per-jet arrays)."""
    return int(jet_actuator_ids(model).size)


def dist_actuator_ids(model: mujoco.MjModel) -> np.ndarray:
    """Actuator ids of the body-frame disturbance torques x, y, z, shape (3,)."""
    return np.array([model.actuator(name).id for name in DIST_NAMES])


def jet_geometry_B(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Nominal jet positions and force directions in the body frame.

    Returns
    -------
    pos_B : ndarray, (n_jets, 3)
        Site positions [m] relative to the body origin.
    dir_B : ndarray, (n_jets, 3)
        Unit force directions (site z axes) in B.
    """
    jets = jet_actuator_ids(model)
    sites = model.actuator_trnid[jets, 0]
    pos = model.site_pos[sites].copy()
    dirs = np.empty((len(jets), 3))
    for k, s in enumerate(sites):
        mat = np.empty(9)
        mujoco.mju_quat2Mat(mat, model.site_quat[s])
        dirs[k] = mat.reshape(3, 3) @ model.actuator_gear[jets[k], 0:3]
    return pos, dirs
