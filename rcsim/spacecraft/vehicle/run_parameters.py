"""Each run's physical parameters: :class:`RunParameters`, the vehicle as one run flies it.

A batch of runs is one :class:`RunParameters` whose arrays have a leading ``n_runs`` axis and,
per jet, an ``n_jets`` axis: the nominal vehicle repeated (:meth:`RunParameters.nominal`, from
its compiled model) with dispersions replacing some of them
(:mod:`rcsim.spacecraft.dispersions`).  Any number of jets: the vehicle's model's.

:func:`jet_force_torque_B` is the one computation of each run's jet forces and torques about
its CG (the controllers' design, :meth:`Vehicle.force_torque
<rcsim.spacecraft.vehicle.vehicle.Vehicle.force_torque>`, the authority checks and the driver
analysis all use it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from rcsim.spacecraft.vehicle.model import BODY, IDENTITY_QUAT, jet_actuator_ids, jet_geometry_B

# Standard gravity for Isp -> mass flow [m/s^2] (CGPM 1901 definition).
G0_M_S2 = 9.80665


@dataclass(frozen=True)
class RunParameters:
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
        isp_s`` (:attr:`rcsim.spacecraft.vehicle.Vehicle.isp_s`).
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
    def nominal(cls, n_runs: int, model: mujoco.MjModel, *, isp_s: float) -> RunParameters:
        """The vehicle of ``model`` repeated ``n_runs`` times, with specific impulse ``isp_s``
        [s]; its principal frame as ``iquat`` when that is not the identity.  A vehicle's own:
        :meth:`rcsim.spacecraft.vehicle.Vehicle.nominal`."""
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
    def concat(cls, parts: Sequence[RunParameters]) -> RunParameters:
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

    def take(self, index) -> RunParameters:
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
                raise ValueError(f"RunParameters.{name}: shape {value.shape}, expected {shape}")
            if not np.all(np.isfinite(value)):
                raise ValueError(f"RunParameters.{name}: non-finite value")
        for name in ("mass_kg", "inertia_B"):
            if np.any(getattr(self, name) <= 0):
                raise ValueError(f"RunParameters.{name}: values must be > 0")
        if np.any(self.thrust_n < 0):
            raise ValueError("RunParameters.thrust_n: values must be >= 0")
        norms = np.linalg.norm(self.jet_dir_S, axis=-1)
        if not np.allclose(norms, 1.0, atol=1e-9):
            raise ValueError("RunParameters.jet_dir_S: directions must be unit vectors")
        if self.iquat is not None and not np.allclose(
            np.linalg.norm(self.iquat, axis=-1), 1.0, atol=1e-9
        ):
            raise ValueError("RunParameters.iquat: quaternions must be unit")


def jet_force_torque_B(
    params: RunParameters, model: mujoco.MjModel
) -> tuple[np.ndarray, np.ndarray]:
    """Force and torque about each run's CG of each jet firing alone at its thrust.

    The one place a jet's force and torque are derived: from the compiled model's site frames
    and positions (the geometry MuJoCo flies) and each run's parameters (thrust, site-frame
    direction, CG), so a dispersed run's torques are its own.

    Returns
    -------
    force_B : ndarray, (n_runs, n_jets, 3)
        Force on the vehicle in B [N].
    torque_B : ndarray, (n_runs, n_jets, 3)
        Torque about the run's CG in B [N m].
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
    return force_B, np.cross(arm_B, force_B)


def torque_per_jet_B(params: RunParameters, model: mujoco.MjModel) -> np.ndarray:
    """Torque of each jet about each run's CG, firing alone at its thrust [N m], shape
    ``(n_runs, n_jets, 3)``: the torque of :func:`jet_force_torque_B`.  Used by the
    controllers' design (phase plane, allocator), the driver analysis and tests; the
    simulation itself never needs it (MuJoCo applies forces at the sites)."""
    return jet_force_torque_B(params, model)[1]
