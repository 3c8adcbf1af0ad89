"""Monte Carlo dispersions of the vehicle (Gambone Table 5), drawn run by run.

Model
-----
Every Table 5 entry is normal about the nominal vehicle with standard deviation
``three_sigma / 3`` (times a campaign's scale factor, e.g. 3 for the stress runs of Figs 13-14):

* ``mass``: vehicle mass [kg];
* ``cg_x``: x coordinate of the centre of gravity [m] (Table 5 disperses CG_x only);
* ``ixx, iyy, izz``: principal moments of inertia about the CG [kg m^2], independently;
* ``thrust``: the thrust of *each* of the 16 jets [N], independently per jet;
* ``thruster_angle``: the pointing of *each* jet.  Its force direction is tilted away from the
  nominal direction by an angle ``theta ~ N(0, sigma)`` about an azimuth ``phi ~ U[0, 2 pi)``
  measured in the plane normal to the nominal direction.  The misalignment angle (between the
  dispersed and the nominal thrust direction) is then exactly ``|theta|``, so Table 5's 3-sigma
  of 5 deg is the 3-sigma of the angle an engineer would measure on the vehicle; the azimuth is
  uniform because Table 5 prefers no direction.  (Two orthogonal normal tilts of the same sigma
  would instead make the misalignment Rayleigh-distributed, with a mean 1.57 times larger.)

Reproducibility
---------------
Run ``i`` of a campaign with root ``seed`` uses ``SeedSequence(seed, spawn_key=(i,))``, spawned
into ``(dispersion, noise)`` streams in that fixed order (a new random source appends a spawn,
never reorders).  The dispersion stream always draws the same count of standard variates
(:data:`N_NORMALS` normals then :data:`N_UNIFORMS` uniforms) whatever the sigmas, so changing
one sigma (or setting it to zero) never changes the other dispersions of a run.  A run's
vehicle is therefore a function of ``(seed, i)`` and the sigmas only: independent of the
chunk it is simulated in, of the worker and of the order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from models.errors import InputError
from spacecraft.vehicle import N_JETS, VehicleParams

#: Table 5 names this module models, in the order they are drawn.
DISPERSION_NAMES = ("mass", "cg_x", "ixx", "iyy", "izz", "thrust", "thruster_angle")
#: The 3-sigma keys of input files (campaign specs' ``[dispersions.three_sigma]``, vehicle
#: files' ``[dispersions]``): key -> (Table 5 name, factor to SI).
THREE_SIGMA_KEYS = {
    "mass_kg": ("mass", 1.0),
    "cg_x_m": ("cg_x", 1.0),
    "ixx_kg_m2": ("ixx", 1.0),
    "iyy_kg_m2": ("iyy", 1.0),
    "izz_kg_m2": ("izz", 1.0),
    "thrust_n": ("thrust", 1.0),
    "thruster_angle_deg": ("thruster_angle", math.pi / 180.0),
}

# Standard-normal layout of one run's draw: mass, cg_x, ixx, iyy, izz, thrust x16, tilt x16.
_Z_MASS, _Z_CG, _Z_INERTIA, _Z_THRUST, _Z_TILT = 0, 1, slice(2, 5), slice(5, 21), slice(21, 37)
#: Standard normals drawn per run.
N_NORMALS = 37
#: Uniforms drawn per run (jet tilt azimuths).
N_UNIFORMS = N_JETS


@dataclass(frozen=True)
class DispersionSigmas:
    """One-sigma dispersions in SI (zero: not dispersed).

    Attributes
    ----------
    mass_kg, cg_x_m : float
    inertia_kg_m2 : tuple of 3 floats
        Ixx, Iyy, Izz.
    thrust_n : float
        Per jet.
    thruster_angle_rad : float
        Tilt of each jet's thrust direction (see the module docstring).
    """

    mass_kg: float = 0.0
    cg_x_m: float = 0.0
    inertia_kg_m2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    thrust_n: float = 0.0
    thruster_angle_rad: float = 0.0

    def __post_init__(self):
        values = [
            self.mass_kg,
            self.cg_x_m,
            *self.inertia_kg_m2,
            self.thrust_n,
            self.thruster_angle_rad,
        ]
        if len(self.inertia_kg_m2) != 3:
            raise ValueError("inertia_kg_m2 needs 3 values")
        if not all(np.isfinite(v) and v >= 0 for v in values):
            raise ValueError(f"sigmas must be finite and >= 0, got {values}")

    @classmethod
    def from_table(cls, table: pd.DataFrame, scale: float = 1.0) -> DispersionSigmas:
        """Sigmas from a :func:`models.tables.load_dispersions` frame (3-sigma, SI) times ``scale``.

        Raises
        ------
        InputError
            A row names a dispersion this vehicle model does not have, or ``scale`` < 0.
        """
        if not (np.isfinite(scale) and scale >= 0):
            raise InputError(f"dispersion scale must be a finite number >= 0, got {scale!r}")
        sig = {name: 0.0 for name in DISPERSION_NAMES}
        for name, three_sigma in zip(table["name"], table["three_sigma"]):
            if name not in sig:
                raise InputError(
                    f"dispersion {name!r} is not modelled; known: {', '.join(DISPERSION_NAMES)}"
                )
            sig[name] = float(three_sigma) / 3.0 * float(scale)
        return cls(
            mass_kg=sig["mass"],
            cg_x_m=sig["cg_x"],
            inertia_kg_m2=(sig["ixx"], sig["iyy"], sig["izz"]),
            thrust_n=sig["thrust"],
            thruster_angle_rad=sig["thruster_angle"],
        )


@dataclass(frozen=True)
class DispersedRuns:
    """The vehicles of a set of runs and the raw tilt draws behind their jet pointing.

    Attributes
    ----------
    run_ids : ndarray of int, (n,)
    params : VehicleParams
        One entry per run.
    tilt_rad : ndarray, (n, 16)
        Signed tilt ``theta`` of each jet; the misalignment angle is ``|theta|`` [rad].
    azimuth_rad : ndarray, (n, 16)
        Tilt azimuth ``phi`` in [0, 2 pi) [rad].
    """

    run_ids: np.ndarray
    params: VehicleParams
    tilt_rad: np.ndarray
    azimuth_rad: np.ndarray


#: Largest campaign seed.  Seeds are recorded as int64 (runs.parquet, manifests, loop.json),
#: so a larger one would fly and then fail to be written; every command refuses it up front.
MAX_SEED = 2**63 - 1


def run_streams(seed: int, run_id: int) -> tuple[np.random.SeedSequence, np.random.SeedSequence]:
    """The ``(dispersion, noise)`` seed sequences of run ``run_id`` of a campaign.

    THE per-run seeding rule of rcsim: ``SeedSequence(seed, spawn_key=(run_id,)).spawn(2)``.
    Every Monte Carlo (campaigns, studies) draws run ``i`` through it or :func:`run_generators`.
    """
    disp_ss, noise_ss = np.random.SeedSequence(int(seed), spawn_key=(int(run_id),)).spawn(2)
    return disp_ss, noise_ss


def run_generators(seed: int, run_id: int) -> tuple[np.random.Generator, np.random.Generator]:
    """Generators on the ``(first, second)`` streams of :func:`run_streams` ``(seed, run_id)``:
    (dispersion, noise) for a campaign; any two independent per-run sources for a study."""
    first, second = run_streams(seed, run_id)
    return np.random.default_rng(first), np.random.default_rng(second)


def standard_draws(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """One run's standard variates: normals (N_NORMALS,) then uniforms (N_UNIFORMS,)."""
    return rng.standard_normal(N_NORMALS), rng.random(N_UNIFORMS)


def _perpendicular_basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors ``e1, e2`` completing unit vectors ``d`` (..., 3) to right-handed frames.

    For the nominal jet direction (0, 0, 1) this is the site frame's own x and y axes.
    """
    helper = np.where(np.abs(d[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = helper - np.sum(helper * d, axis=-1, keepdims=True) * d
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return e1, np.cross(d, e1)


def pointing(
    nominal_dir_S: np.ndarray, tilt_rad: np.ndarray, azimuth_rad: np.ndarray
) -> np.ndarray:
    """Jet force directions tilted from their nominal ones (the module docstring's model).

    The one definition of how a tilt and its azimuth point a jet: the draws use it, and so
    does everything that rebuilds a flown vehicle from its recorded tilt and azimuth
    (:func:`analysis.engine.runs_table.vehicles_from_runs`).

    Parameters
    ----------
    nominal_dir_S : ndarray, (..., 16, 3)
        Nominal directions (need not be unit), broadcast against the angles.
    tilt_rad : ndarray, (n, 16)
        Signed tilt ``theta`` [rad]; the misalignment angle is ``|theta|``.
    azimuth_rad : ndarray, (n, 16)
        Azimuth ``phi`` of the tilt in the plane normal to the nominal direction [rad].

    Returns
    -------
    ndarray, (n, 16, 3)
        Unit directions.
    """
    d = nominal_dir_S / np.linalg.norm(nominal_dir_S, axis=-1, keepdims=True)
    e1, e2 = _perpendicular_basis(d)
    lateral = np.cos(azimuth_rad)[..., None] * e1 + np.sin(azimuth_rad)[..., None] * e2
    direction = np.cos(tilt_rad)[..., None] * d + np.sin(tilt_rad)[..., None] * lateral
    # Renormalise: cos/sin rounding leaves |direction| off 1 by ~1e-16, inside check()'s 1e-9.
    return direction / np.linalg.norm(direction, axis=-1, keepdims=True)


def apply_draws(
    nominal: VehicleParams, sigmas: DispersionSigmas, z: np.ndarray, u: np.ndarray
) -> tuple[VehicleParams, np.ndarray, np.ndarray]:
    """Dispersed vehicles from standard variates.

    Parameters
    ----------
    nominal : VehicleParams
        The nominal vehicle (one run; broadcast to all).
    sigmas : DispersionSigmas
    z : ndarray, (n, N_NORMALS)
        Standard normals, laid out as :func:`standard_draws` returns them.
    u : ndarray, (n, N_UNIFORMS)
        Uniforms in [0, 1).

    Returns
    -------
    params : VehicleParams, n runs
    tilt_rad, azimuth_rad : ndarray, (n, 16)
    """
    n = z.shape[0]
    base = nominal.take(np.zeros(n, int))
    mass = base.mass_kg + sigmas.mass_kg * z[:, _Z_MASS]
    cg = base.cg_B.copy()
    cg[:, 0] += sigmas.cg_x_m * z[:, _Z_CG]
    inertia = base.inertia_B + np.asarray(sigmas.inertia_kg_m2) * z[:, _Z_INERTIA]
    thrust = base.thrust_n + sigmas.thrust_n * z[:, _Z_THRUST]
    tilt = sigmas.thruster_angle_rad * z[:, _Z_TILT]
    azimuth = 2.0 * np.pi * u
    direction = pointing(base.jet_dir_S, tilt, azimuth)
    params = VehicleParams(
        mass_kg=mass,
        cg_B=cg,
        inertia_B=inertia,
        thrust_n=thrust,
        jet_dir_S=direction,
        isp_s=nominal.isp_s,
    )
    return params, tilt, azimuth


def draw_runs(
    nominal: VehicleParams, sigmas: DispersionSigmas, seed: int, run_ids
) -> DispersedRuns:
    """Dispersed vehicles of campaign runs ``run_ids`` (any order, any subset).

    Each run draws from its own generator on ``run_streams(seed, i)[0]``; this Python loop
    over runs costs about 45 microseconds per run, negligible beside the flight.
    """
    run_ids = np.asarray(run_ids, dtype=np.int64).reshape(-1)
    z = np.empty((run_ids.size, N_NORMALS))
    u = np.empty((run_ids.size, N_UNIFORMS))
    for k, i in enumerate(run_ids):
        z[k], u[k] = standard_draws(np.random.default_rng(run_streams(seed, i)[0]))
    params, tilt, azimuth = apply_draws(nominal, sigmas, z, u)
    return DispersedRuns(run_ids=run_ids, params=params, tilt_rad=tilt, azimuth_rad=azimuth)
