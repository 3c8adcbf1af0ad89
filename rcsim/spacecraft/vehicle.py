"""Per-run vehicle parameters and the MuJoCo model they are written into.

The nominal vehicle is the packaged MJCF (Gambone Table 1 mass properties, the jet geometry of
``rcsim/models/vehicle/README.md``), or a vehicle file's model
(:mod:`rcsim.spacecraft.vehicle_file`) with any number of jets.  A batch of runs is a
:class:`VehicleParams` whose arrays have a leading ``n_runs`` axis and, per jet, an ``n_jets`` axis;
dispersions replace some of them.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from rcsim.models import vehicle_xml

# ``N_JETS`` (16) is the *paper's* jet count (Gambone Table 2), re-exported for what is the
# paper's: its jet map and its 26 x 16 lookup tables.  Nothing on the flight path uses it: a
# vehicle's own count is its compiled model's (:func:`jet_count`) or its parameters'
# (:attr:`VehicleParams.n_jets`), and every per-jet array is that wide.
from rcsim.models.tables import N_JETS as N_JETS

DIST_NAMES = ("dist_x", "dist_y", "dist_z")
AXES = ("roll", "pitch", "yaw")
BODY = "vehicle"
#: MuJoCo's identity quaternion (w, x, y, z): principal axes along the body axes.
IDENTITY_QUAT = (1.0, 0.0, 0.0, 0.0)

# Standard gravity for Isp -> mass flow [m/s^2] (CGPM 1901 definition).
G0_M_S2 = 9.80665


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


def load_model(*, timestep_s: float | None = None, integrator: str | None = None) -> mujoco.MjModel:
    """Compile the packaged vehicle MJCF.

    Parameters
    ----------
    timestep_s : float, optional
        Physics step [s]; default the MJCF's (chosen in ``docs/convergence.md``).
    integrator : {"RK4", "Euler", "implicit", "implicitfast"}, optional
        MuJoCo integrator; default the MJCF's.
    """
    route_mujoco_warnings()
    model = mujoco.MjModel.from_xml_path(str(vehicle_xml()))
    if timestep_s is not None:
        model.opt.timestep = float(timestep_s)
    if integrator is not None:
        model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    return model


def jet_name(number: int) -> str:
    """Actuator name of jet ``number`` (1-based): ``jet_01``, ``jet_02``, ... ``jet_100``."""
    return f"jet_{number:02d}"


def jet_actuator_ids(model: mujoco.MjModel) -> np.ndarray:
    """Actuator ids of the vehicle's jets in jet order, shape ``(n_jets,)``.

    The jets are the actuators named ``jet_01``, ``jet_02``, ... (the packaged MJCF's 16, a
    vehicle file's any number: :mod:`rcsim.spacecraft.vehicle_file.mjcf`), counted up to the first
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
    (:attr:`VehicleParams.n_jets` is the same number, read from the per-jet arrays)."""
    return int(jet_actuator_ids(model).size)


def dist_actuator_ids(model: mujoco.MjModel) -> np.ndarray:
    """Actuator ids of the body-frame disturbance torques x, y, z, shape (3,)."""
    return np.array([model.actuator(name).id for name in DIST_NAMES])


@dataclass(frozen=True)
class VehicleParams:
    """Physical parameters of ``n_runs`` vehicles (SI units, body frame B).

    Attributes
    ----------
    mass_kg : ndarray, (n_runs,)
    cg_B : ndarray, (n_runs, 3)
        Centre of gravity in the body frame [m].
    inertia_B : ndarray, (n_runs, 3)
        Principal moments of inertia about the CG [kg m^2], along the principal axes
        ``iquat`` (the body axes B for the packaged vehicle and any vehicle without products
        of inertia).
    thrust_n : ndarray, (n_runs, n_jets)
        Thrust of each jet [N] (``n_jets``: the vehicle's, :func:`jet_count`).
    jet_dir_S : ndarray, (n_runs, n_jets, 3)
        Unit direction of each jet's force in its site frame; nominal (0, 0, 1).
    isp_s : float
        Specific impulse [s], for propellant accounting: the vehicle file's ``[propellant]
        isp_s`` (:attr:`rcsim.spacecraft.vehicle_file.Vehicle.isp_s`).
    iquat : ndarray, (n_runs, 4), or None
        Principal frame of each run's inertia in B, as MuJoCo's ``body_iquat`` (w, x, y, z);
        None: the model's own frame, the identity for the packaged vehicle.  Set by
        :meth:`nominal` for a model whose principal axes are not B (a vehicle file with
        products of inertia) and by dispersed products of inertia
        (:mod:`rcsim.spacecraft.dispersions`).
    """

    mass_kg: np.ndarray
    cg_B: np.ndarray
    inertia_B: np.ndarray
    thrust_n: np.ndarray
    jet_dir_S: np.ndarray
    isp_s: float
    iquat: np.ndarray | None = None

    @property
    def n_runs(self) -> int:
        return int(self.mass_kg.shape[0])

    @property
    def n_jets(self) -> int:
        """The vehicle's jet count (the width of ``thrust_n``)."""
        return int(self.thrust_n.shape[-1])

    @classmethod
    def nominal(cls, n_runs: int, model: mujoco.MjModel, *, isp_s: float) -> VehicleParams:
        """The vehicle of ``model`` repeated ``n_runs`` times, with specific impulse ``isp_s``
        [s]; its principal frame as ``iquat`` when that is not the identity.  A vehicle's own:
        :meth:`rcsim.spacecraft.vehicle_file.Vehicle.nominal`."""
        if n_runs < 1:
            raise ValueError(f"n_runs must be >= 1, got {n_runs}")
        body = model.body(BODY).id
        jets = jet_actuator_ids(model)
        rep = lambda a: np.repeat(np.asarray(a, float)[None], n_runs, axis=0)  # noqa: E731
        frame = model.body_iquat[body]
        return cls(
            mass_kg=rep(model.body_mass[body]),
            cg_B=rep(model.body_ipos[body]),
            inertia_B=rep(model.body_inertia[body]),
            thrust_n=rep(model.actuator_gainprm[jets, 0]),
            jet_dir_S=rep(model.actuator_gear[jets, 0:3]),
            isp_s=isp_s,
            iquat=None if np.array_equal(frame, IDENTITY_QUAT) else rep(frame),
        )

    @classmethod
    def concat(cls, parts: Sequence[VehicleParams]) -> VehicleParams:
        """The runs of ``parts`` one after another (same jet count, same ``isp_s``; ``iquat``
        None in all of them or in none)."""
        first = parts[0]
        frames = [p.iquat for p in parts]
        if any(f is None for f in frames) and not all(f is None for f in frames):
            raise ValueError("some parts have their own principal frames and some do not")
        join = lambda name: np.concatenate([getattr(p, name) for p in parts])  # noqa: E731
        return replace(
            first,
            mass_kg=join("mass_kg"),
            cg_B=join("cg_B"),
            inertia_B=join("inertia_B"),
            thrust_n=join("thrust_n"),
            jet_dir_S=join("jet_dir_S"),
            iquat=None if frames[0] is None else join("iquat"),
        )

    def take(self, index) -> VehicleParams:
        """The runs selected by ``index`` (slice, int array or boolean mask)."""
        index = np.atleast_1d(np.arange(self.n_runs)[index])
        return replace(
            self,
            mass_kg=self.mass_kg[index],
            cg_B=self.cg_B[index],
            inertia_B=self.inertia_B[index],
            thrust_n=self.thrust_n[index],
            jet_dir_S=self.jet_dir_S[index],
            iquat=None if self.iquat is None else self.iquat[index],
        )

    def check(self) -> None:
        """Raise ValueError if any array has the wrong shape or a non-physical value."""
        n = self.n_runs
        shapes = {
            "mass_kg": (n,),
            "cg_B": (n, 3),
            "inertia_B": (n, 3),
            "thrust_n": (n, self.n_jets),
            "jet_dir_S": (n, self.n_jets, 3),
            "iquat": (n, 4),
        }
        for name, shape in shapes.items():
            value = getattr(self, name)
            if value is None and name == "iquat":
                continue
            if value.shape != shape:
                raise ValueError(f"VehicleParams.{name}: shape {value.shape}, expected {shape}")
            if not np.all(np.isfinite(value)):
                raise ValueError(f"VehicleParams.{name}: non-finite value")
        for name in ("mass_kg", "inertia_B"):
            if np.any(getattr(self, name) <= 0):
                raise ValueError(f"VehicleParams.{name}: values must be > 0")
        if np.any(self.thrust_n < 0):
            raise ValueError("VehicleParams.thrust_n: values must be >= 0")
        norms = np.linalg.norm(self.jet_dir_S, axis=-1)
        if not np.allclose(norms, 1.0, atol=1e-9):
            raise ValueError("VehicleParams.jet_dir_S: directions must be unit vectors")
        if self.iquat is not None and not np.allclose(
            np.linalg.norm(self.iquat, axis=-1), 1.0, atol=1e-9
        ):
            raise ValueError("VehicleParams.iquat: quaternions must be unit")


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


def torque_per_jet_B(params: VehicleParams, model: mujoco.MjModel) -> np.ndarray:
    """Torque of each jet about each run's CG, firing alone at its thrust [N m].

    Shape ``(n_runs, n_jets, 3)``.  Used by the phase-plane controller's design (nominal
    vehicle) and by tests; the simulation itself never needs it (MuJoCo applies forces at the
    sites).
    """
    jets = jet_actuator_ids(model)
    sites = model.actuator_trnid[jets, 0]
    pos_B, _ = jet_geometry_B(model)
    mats = np.empty((len(jets), 9))
    for k, s in enumerate(sites):
        mujoco.mju_quat2Mat(mats[k], model.site_quat[s])
    # Force in B: site rotation applied to the (possibly dispersed) site-frame direction.
    force_B = np.einsum("jab,njb->nja", mats.reshape(-1, 3, 3), params.jet_dir_S)
    force_B = force_B * params.thrust_n[..., None]
    arm_B = pos_B[None] - params.cg_B[:, None, :]
    return np.cross(arm_B, force_B)
