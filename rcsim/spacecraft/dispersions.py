"""Monte Carlo dispersions of the vehicle (Gambone Table 5), drawn run by run.

Model
-----
Every Table 5 entry is normal about the nominal vehicle with standard deviation
``three_sigma / 3`` (times a campaign's scale factor, e.g. 3 for the stress runs of Figs 13-14):

* ``mass``: vehicle mass [kg];
* ``cg_x``: x coordinate of the centre of gravity [m] (Table 5 disperses CG_x only);
* ``ixx, iyy, izz``: the moments of inertia about body x, y, z through the CG [kg m^2], i.e. the
  diagonal entries of the inertia tensor in B, independently (for the paper's vehicle, whose
  principal axes are B, its principal moments; "Inertia" below);
* ``thrust``: the thrust of *each* jet [N], independently per jet (the paper's vehicle has 16;
  a vehicle file any number);
* ``thruster_angle``: the pointing of *each* jet.  Its force direction is tilted away from the
  nominal direction by an angle ``theta ~ N(0, sigma)`` about an azimuth ``phi ~ U[0, 2 pi)``
  measured in the plane normal to the nominal direction.  The misalignment angle (between the
  dispersed and the nominal thrust direction) is then exactly ``|theta|``, so Table 5's 3-sigma
  of 5 deg is the 3-sigma of the angle an engineer would measure on the vehicle; the azimuth is
  uniform because Table 5 prefers no direction.  (Two orthogonal normal tilts of the same sigma
  would instead make the misalignment Rayleigh-distributed, with a mean 1.57 times larger.)

Beyond Table 5 (not in the paper, 0 unless a campaign spec or vehicle file gives them):

* ``cg_y``, ``cg_z``: the y and z coordinates of the CG [m], independently (MuJoCo's
  ``body_ipos``: the jets' moment arms about the CG follow);
* ``ixy, ixz, iyz``: the products of inertia [kg m^2], independently, added to the tensor's
  off-diagonal entries in B (MuJoCo's ``fullinertia`` convention, ``I_xy = -sum m x y``).

Inertia
-------
MuJoCo holds a body's inertia as principal moments (``body_inertia``, sorted in descending
order when it compiles a ``fullinertia``) in a principal frame (``body_iquat``), so a vehicle
file's moments need not come out in x, y, z order.  The dispersions act on the tensor in B
instead: a run's tensor is the nominal one in B (the compiled moments in the compiled frame,
:func:`rcsim.spacecraft.propellant.inertia_tensor_B`: the vehicle file's tensor to rounding, 1e-15
relative) plus ``diag(d_xx, d_yy, d_zz)`` and the dispersed products, and it is flown as its
own principal moments and frame (:func:`rcsim.spacecraft.propellant.principal`, per run).  A vehicle
whose principal axes are B and whose products are not dispersed (the paper's) skips the round
trip: its moments are the diagonal, dispersed in place, bit for bit as they always were.

Physical tensors
----------------
A symmetric tensor ``I`` is a rigid body's inertia exactly when its second moments of mass
``S = tr(I)/2 E - I`` (``S = sum m r r^T``) are positive semidefinite, i.e. when its largest
principal moment is at most half its trace: the triangle inequality ``a + b >= c`` (which also
makes ``I`` positive definite when strict).  Independent normal draws of moments and products
can leave that set, so the 3-sigma values are limited where they are read
(:func:`inertia_scale_limit`): along any unit direction ``v`` the second moment ``v^T S v`` of a
dispersed tensor is normal, its mean at least the nominal vehicle's smallest second moment
``s_min = tr(I0)/2 - max principal moment`` and its standard deviation at most
``sqrt((s_xx^2 + s_yy^2 + s_zz^2)/4 + s_xy^2 + s_xz^2 + s_yz^2)/3`` (3-sigma values ``s``;
``|v^T A v| <= ||A||`` for each entry's unit change ``A``: 1/2 for a moment, 1 for a product).
Requiring ``s_min`` to exceed three of those standard deviations -- every second moment stays
positive out to 3 sigma, the rule Table 5's other rows follow (a 3-sigma draw stays a vehicle)
-- is ``sqrt(...) < s_min``.  A draw in the far tail that still breaks the triangle inequality
is not flown: the simulation records the run failed with that reason
(:func:`rcsim.spacecraft.simulation.invalid_runs`), never a silent redraw.

Reproducibility
---------------
Run ``i`` of a campaign with root ``seed`` uses ``SeedSequence(seed, spawn_key=(i,))``, spawned
into ``(dispersion, noise)`` streams in that fixed order (a new random source appends a spawn,
never reorders).  The dispersion stream always draws the same count of standard variates
(:func:`n_normals` normals then :func:`n_uniforms` uniforms) whatever the sigmas, so changing
one sigma (or setting it to zero) never changes the other dispersions of a run.  The quantities
beyond Table 5 (CG y and z, products of inertia) draw :data:`N_MASS_EXTRAS` normals from a
*child* of the dispersion stream ``D``, ``SeedSequence(D.entropy, spawn_key=D.spawn_key +
(0,))`` (:func:`mass_extra_stream`), only when one of their sigmas is non-zero: the dispersion
stream's own draws are untouched, so a campaign without them flies every run exactly as before.
A run's vehicle is therefore a function of ``(seed, i)`` and the sigmas only: independent of
the chunk it is simulated in, of the worker and of the order.

The counts depend on the vehicle's jets only (``n_jets``: :func:`n_normals`,
:func:`n_uniforms`): mass, CG x, three inertias, then a thrust and a tilt normal per jet, and an
azimuth uniform per jet.  The paper's vehicle (16 jets) draws 37 normals and 16 uniforms, as it
always has; a vehicle of ``n`` jets draws ``5 + 2 n`` and ``n`` in the same layout (the mass
extras are 5 whatever the jets).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from rcsim.models.errors import InputError
from rcsim.spacecraft.propellant import inertia_tensor_B, principal
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: Dispersions this module models: Table 5's names in the order they are drawn, then the ones
#: beyond Table 5 (CG y and z, products of inertia; drawn from the mass-extras stream).
DISPERSION_NAMES = (
    "mass",
    "cg_x",
    "ixx",
    "iyy",
    "izz",
    "thrust",
    "thruster_angle",
    "cg_y",
    "cg_z",
    "ixy",
    "ixz",
    "iyz",
)
#: The 3-sigma keys of input files (campaign specs' ``[dispersions.three_sigma]``, vehicle
#: files' ``[dispersions]``): key -> (dispersion name, factor to SI).
THREE_SIGMA_KEYS = {
    "mass_kg": ("mass", 1.0),
    "cg_x_m": ("cg_x", 1.0),
    "cg_y_m": ("cg_y", 1.0),
    "cg_z_m": ("cg_z", 1.0),
    "ixx_kg_m2": ("ixx", 1.0),
    "iyy_kg_m2": ("iyy", 1.0),
    "izz_kg_m2": ("izz", 1.0),
    "ixy_kg_m2": ("ixy", 1.0),
    "ixz_kg_m2": ("ixz", 1.0),
    "iyz_kg_m2": ("iyz", 1.0),
    "thrust_n": ("thrust", 1.0),
    "thruster_angle_deg": ("thruster_angle", math.pi / 180.0),
}
#: Inertia dispersions and the norm of the change of the second moments ``S`` a unit change of
#: each makes (module docstring, "Physical tensors"): 1/2 for a moment, 1 for a product.
INERTIA_ENTRIES = {"ixx": 0.5, "iyy": 0.5, "izz": 0.5, "ixy": 1.0, "ixz": 1.0, "iyz": 1.0}

# Standard-normal layout of one run's draw: mass, cg_x, ixx, iyy, izz, then thrust and tilt,
# one per jet each (_Z_JETS is where the thrusts start).
_Z_MASS, _Z_CG, _Z_INERTIA, _Z_JETS = 0, 1, slice(2, 5), 5
#: Standard normals drawn per run from the mass-extras stream: cg_y, cg_z, ixy, ixz, iyz.
N_MASS_EXTRAS = 5
#: Child of a run's dispersion stream that the mass extras draw from.
MASS_EXTRAS = 0


def n_normals(n_jets: int) -> int:
    """Standard normals drawn per run of a vehicle of ``n_jets`` jets (37 for the paper's)."""
    return _Z_JETS + 2 * int(n_jets)


def n_uniforms(n_jets: int) -> int:
    """Uniforms drawn per run (jet tilt azimuths): one per jet."""
    return int(n_jets)


@dataclass(frozen=True)
class DispersionSigmas:
    """One-sigma dispersions in SI (zero: not dispersed).

    Attributes
    ----------
    mass_kg, cg_x_m : float
    inertia_kg_m2 : tuple of 3 floats
        Ixx, Iyy, Izz: the tensor's diagonal entries in B (module docstring, "Inertia").
    thrust_n : float
        Per jet.
    thruster_angle_rad : float
        Tilt of each jet's thrust direction (see the module docstring).
    cg_y_m, cg_z_m : float
        CG y and z (beyond Table 5).
    products_kg_m2 : tuple of 3 floats
        Ixy, Ixz, Iyz: the tensor's off-diagonal entries in B (beyond Table 5).
    """

    mass_kg: float = 0.0
    cg_x_m: float = 0.0
    inertia_kg_m2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    thrust_n: float = 0.0
    thruster_angle_rad: float = 0.0
    cg_y_m: float = 0.0
    cg_z_m: float = 0.0
    products_kg_m2: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        if len(self.inertia_kg_m2) != 3 or len(self.products_kg_m2) != 3:
            raise ValueError("inertia_kg_m2 and products_kg_m2 need 3 values each")
        values = [
            self.mass_kg,
            self.cg_x_m,
            *self.inertia_kg_m2,
            self.thrust_n,
            self.thruster_angle_rad,
            self.cg_y_m,
            self.cg_z_m,
            *self.products_kg_m2,
        ]
        if not all(np.isfinite(v) and v >= 0 for v in values):
            raise ValueError(f"sigmas must be finite and >= 0, got {values}")

    @property
    def disperses_products(self) -> bool:
        """Some product of inertia is dispersed: runs get their own principal frames (and
        runs.parquet records the products,
        :func:`rcsim.analysis.engine.runs_table.records_products`)."""
        return any(v > 0 for v in self.products_kg_m2)

    @property
    def disperses_inertia(self) -> bool:
        """Some entry of the inertia tensor (a moment or a product) is dispersed."""
        return any(v > 0 for v in self.inertia_kg_m2) or self.disperses_products

    @property
    def has_mass_extras(self) -> bool:
        """Some dispersion beyond Table 5 (CG y or z, a product of inertia) is non-zero: the
        runs draw from their mass-extras streams (module docstring)."""
        return self.cg_y_m > 0 or self.cg_z_m > 0 or self.disperses_products

    @classmethod
    def from_table(cls, table: pd.DataFrame, scale: float = 1.0) -> DispersionSigmas:
        """Sigmas from a :func:`rcsim.models.tables.load_dispersions` frame (3-sigma, SI) times
        ``scale``.

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
            cg_y_m=sig["cg_y"],
            cg_z_m=sig["cg_z"],
            products_kg_m2=(sig["ixy"], sig["ixz"], sig["iyz"]),
        )


@dataclass(frozen=True)
class DispersedRuns:
    """The vehicles of a set of runs and the raw tilt draws behind their jet pointing.

    Attributes
    ----------
    run_ids : ndarray of int, (n,)
    params : RunParameters
        One entry per run.
    tilt_rad : ndarray, (n, n_jets)
        Signed tilt ``theta`` of each jet; the misalignment angle is ``|theta|`` [rad].
    azimuth_rad : ndarray, (n, n_jets)
        Tilt azimuth ``phi`` in [0, 2 pi) [rad].
    """

    run_ids: np.ndarray
    params: RunParameters
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


def run_stream(seed: int, run_id: int, which: int) -> np.random.SeedSequence:
    """Stream ``which`` (0: dispersion, 1: noise) of :func:`run_streams`, built directly:
    ``spawn`` gives child ``k`` the parent's entropy and ``spawn_key + (k,)``, so this is that
    child without making its parent and sibling (4 us against 12 us a run; a 500-run chunk's
    draws ask it 500 times)."""
    return np.random.SeedSequence(int(seed), spawn_key=(int(run_id), int(which)))


def run_generators(seed: int, run_id: int) -> tuple[np.random.Generator, np.random.Generator]:
    """Generators on the ``(first, second)`` streams of :func:`run_streams` ``(seed, run_id)``:
    (dispersion, noise) for a campaign; any two independent per-run sources for a study."""
    first, second = run_streams(seed, run_id)
    return np.random.default_rng(first), np.random.default_rng(second)


def standard_draws(rng: np.random.Generator, n_jets: int) -> tuple[np.ndarray, np.ndarray]:
    """One run's standard variates for a vehicle of ``n_jets`` jets: normals
    ``(n_normals(n_jets),)`` then uniforms ``(n_uniforms(n_jets),)``."""
    return rng.standard_normal(n_normals(n_jets)), rng.random(n_uniforms(n_jets))


def mass_extra_stream(seed: int, run_id: int) -> np.random.SeedSequence:
    """Child :data:`MASS_EXTRAS` of run ``run_id``'s dispersion stream ``D``:
    ``SeedSequence(D.entropy, spawn_key=D.spawn_key + (0,))`` (what ``D.spawn`` would give
    first, without its counter).  CG y, CG z and the products of inertia draw from it."""
    disp = run_stream(seed, run_id, 0)
    return np.random.SeedSequence(disp.entropy, spawn_key=tuple(disp.spawn_key) + (MASS_EXTRAS,))


def mass_extra_draws(seed: int, run_ids) -> np.ndarray:
    """Standard normals of the mass extras of runs ``run_ids``, (n, N_MASS_EXTRAS): cg_y, cg_z,
    ixy, ixz, iyz, always all five whatever the sigmas."""
    run_ids = np.asarray(run_ids, dtype=np.int64).reshape(-1)
    x = np.empty((run_ids.size, N_MASS_EXTRAS))
    for k, i in enumerate(run_ids):
        x[k] = np.random.default_rng(mass_extra_stream(seed, i)).standard_normal(N_MASS_EXTRAS)
    return x


def second_moment_slack(inertia_B: np.ndarray) -> float:
    """The smallest second moment of mass of a tensor (3, 3) [kg m^2]: ``tr(I)/2 - max
    principal moment``, half the slack of its triangle inequality (>= 0 for a rigid body)."""
    moments = np.linalg.eigvalsh(np.asarray(inertia_B, float))
    return float(moments.sum() / 2.0 - moments[-1])


def inertia_spread(three_sigma: dict) -> float:
    """``sqrt((s_xx^2 + s_yy^2 + s_zz^2)/4 + s_xy^2 + s_xz^2 + s_yz^2)`` of the inertia
    3-sigma values ``three_sigma`` (name -> kg m^2; absent names are 0): three times the
    largest standard deviation a second moment of the dispersed tensor can have (module
    docstring, "Physical tensors")."""
    return math.sqrt(
        sum((c * float(three_sigma.get(n, 0.0))) ** 2 for n, c in INERTIA_ENTRIES.items())
    )


#: The inertia rule in words (messages of campaign specs and vehicle files); ``{slack}`` is
#: :func:`second_moment_slack` of the nominal tensor.
INERTIA_RULE = (
    "sqrt((Ixx^2 + Iyy^2 + Izz^2)/4 + Ixy^2 + Ixz^2 + Iyz^2) of the inertia 3-sigma values "
    "times scale must stay below the nominal vehicle's smallest second moment of mass, "
    "tr(I)/2 - its largest principal moment = {slack:.4g} kg m^2 (the slack of the triangle "
    "inequality), so that every second moment stays positive out to 3 sigma and the dispersed "
    "tensor stays a rigid body's"
)


def largest_inertia_sigma(
    inertia_B: np.ndarray, three_sigma: dict, name: str, scale: float = 1.0
) -> float:
    """Largest 3-sigma [kg m^2] of inertia entry ``name`` (``ixx`` ... ``iyz``) that keeps the
    inertia rule with the other values of ``three_sigma`` and ``scale``; 0 when none does."""
    rest = inertia_spread({n: v for n, v in three_sigma.items() if n != name}) ** 2
    room = (second_moment_slack(inertia_B) / scale) ** 2 - rest
    return math.sqrt(room) / INERTIA_ENTRIES[name] if room > 0 else 0.0


def three_sigma_bounds(
    mass_kg: float, moments_kg_m2, thrust_n, cg_B, jet_pos_B
) -> dict[str, tuple[float, str]]:
    """Upper bounds of single 3-sigma values [SI] of a vehicle, each with its reason: a 3-sigma
    draw must stay a vehicle.

    Parameters
    ----------
    mass_kg : float
    moments_kg_m2 : 3 floats
        The nominal Ixx, Iyy, Izz: the tensor's diagonal in B, which ``ixx, iyy, izz``
        disperse (not MuJoCo's sorted principal moments).
    thrust_n : array of floats
        Every jet's nominal thrust (the smallest bounds the per-jet dispersion).
    cg_B, jet_pos_B : (3,) and (n_jets, 3)
        Nominal CG and jet positions in B [m].

    Returns
    -------
    dict
        Dispersion name -> (bound, reason): the nominal mass, moments and thrust (a 3-sigma
        draw must stay positive), 90 deg of thruster tilt (a jet must still push forwards), and
        for each CG coordinate the distance from the nominal CG to the farthest jet (the jets
        sit on the structure: a CG beyond all of them is outside the vehicle).  The products of
        inertia have no single bound: the tensor as a whole is limited
        (:func:`inertia_scale_limit`).
    """
    moments = [float(m) for m in moments_kg_m2]
    arms = np.asarray(jet_pos_B, float) - np.asarray(cg_B, float)
    reach = float(np.max(np.linalg.norm(arms, axis=1)))
    bounds = {
        "mass": (float(mass_kg), "the nominal mass"),
        "ixx": (moments[0], "the nominal Ixx"),
        "iyy": (moments[1], "the nominal Iyy"),
        "izz": (moments[2], "the nominal Izz"),
        "thrust": (float(np.min(thrust_n)), "the nominal thrust"),
        "thruster_angle": (math.pi / 2, "a 90 deg tilt (the jet would no longer push forwards)"),
    }
    for axis in "xyz":
        bounds[f"cg_{axis}"] = (reach, "the distance from the nominal CG to the farthest jet")
    return bounds


def inertia_scale_limit(inertia_B: np.ndarray, three_sigma: dict) -> float:
    """Largest factor on the inertia 3-sigma values ``three_sigma`` (name -> kg m^2) that keeps
    every second moment of mass of the dispersed tensor positive out to 3 sigma (module
    docstring, "Physical tensors"): ``second_moment_slack / inertia_spread``; inf when nothing
    is dispersed.  A scale must stay strictly below it."""
    spread = inertia_spread(three_sigma)
    return math.inf if spread == 0 else second_moment_slack(inertia_B) / spread


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
    (:func:`rcsim.analysis.engine.runs_table.vehicles_from_runs`).

    Parameters
    ----------
    nominal_dir_S : ndarray, (..., n_jets, 3)
        Nominal directions (need not be unit), broadcast against the angles.
    tilt_rad : ndarray, (n, n_jets)
        Signed tilt ``theta`` [rad]; the misalignment angle is ``|theta|``.
    azimuth_rad : ndarray, (n, n_jets)
        Azimuth ``phi`` of the tilt in the plane normal to the nominal direction [rad].

    Returns
    -------
    ndarray, (n, n_jets, 3)
        Unit directions.
    """
    d = nominal_dir_S / np.linalg.norm(nominal_dir_S, axis=-1, keepdims=True)
    e1, e2 = _perpendicular_basis(d)
    lateral = np.cos(azimuth_rad)[..., None] * e1 + np.sin(azimuth_rad)[..., None] * e2
    direction = np.cos(tilt_rad)[..., None] * d + np.sin(tilt_rad)[..., None] * lateral
    # Renormalise: cos/sin rounding leaves |direction| off 1 by ~1e-16, inside check()'s 1e-9.
    return direction / np.linalg.norm(direction, axis=-1, keepdims=True)


def apply_draws(
    nominal: RunParameters,
    sigmas: DispersionSigmas,
    z: np.ndarray,
    u: np.ndarray,
    x: np.ndarray | None = None,
) -> tuple[RunParameters, np.ndarray, np.ndarray]:
    """Dispersed vehicles from standard variates.

    Parameters
    ----------
    nominal : RunParameters
        The nominal vehicle (one run; broadcast to all) of ``n_jets`` jets.
    sigmas : DispersionSigmas
    z : ndarray, (n, n_normals(n_jets))
        Standard normals, laid out as :func:`standard_draws` returns them.
    u : ndarray, (n, n_uniforms(n_jets))
        Uniforms in [0, 1).
    x : ndarray, (n, N_MASS_EXTRAS), optional
        The mass extras' standard normals (:func:`mass_extra_draws`); required when
        ``sigmas.has_mass_extras``.

    Returns
    -------
    params : RunParameters, n runs
    tilt_rad, azimuth_rad : ndarray, (n, n_jets)
    """
    n, jets = z.shape[0], nominal.n_jets
    if z.shape[1:] != (n_normals(jets),) or u.shape != (n, n_uniforms(jets)):
        raise ValueError(
            f"draws of shapes {z.shape}, {u.shape} do not fit a vehicle of {jets} jets "
            f"({n_normals(jets)} normals, {n_uniforms(jets)} uniforms per run)"
        )
    thrust_z = slice(_Z_JETS, _Z_JETS + jets)
    tilt_z = slice(_Z_JETS + jets, _Z_JETS + 2 * jets)
    base = nominal.take(np.zeros(n, int))
    mass = base.mass_kg + sigmas.mass_kg * z[:, _Z_MASS]
    cg = base.cg_B.copy()
    cg[:, 0] += sigmas.cg_x_m * z[:, _Z_CG]
    moments = np.asarray(sigmas.inertia_kg_m2) * z[:, _Z_INERTIA]  # Ixx, Iyy, Izz in B
    thrust = base.thrust_n + sigmas.thrust_n * z[:, thrust_z]
    tilt = sigmas.thruster_angle_rad * z[:, tilt_z]
    azimuth = 2.0 * np.pi * u
    direction = pointing(base.jet_dir_S, tilt, azimuth)
    if sigmas.has_mass_extras:
        if x is None:
            raise ValueError("sigmas beyond Table 5 need the mass extras' draws x")
        cg[:, 1] += sigmas.cg_y_m * x[:, 0]
        cg[:, 2] += sigmas.cg_z_m * x[:, 1]
    if base.iquat is None and not sigmas.disperses_products:
        # Principal axes along B (the paper's vehicle): the moments are the tensor's diagonal.
        inertia, iquat = base.inertia_B + moments, None
    elif not sigmas.disperses_inertia:
        inertia, iquat = base.inertia_B, base.iquat  # the nominal as compiled
    else:
        # The nominal tensor in B, its diagonal and products dispersed, flown as its principal
        # moments and frame (module docstring, "Inertia").
        tensor = inertia_tensor_B(base)
        tensor[:, [0, 1, 2], [0, 1, 2]] += moments
        if sigmas.disperses_products:
            assert x is not None  # has_mass_extras, checked above
            for (a, b), sigma, k in zip(((0, 1), (0, 2), (1, 2)), sigmas.products_kg_m2, (2, 3, 4)):
                tensor[:, a, b] += sigma * x[:, k]
                tensor[:, b, a] = tensor[:, a, b]
        inertia, iquat = principal(tensor)
    params = RunParameters(
        mass_kg=mass,
        cg_B=cg,
        inertia_B=inertia,
        thrust_n=thrust,
        jet_dir_S=direction,
        isp_s=nominal.isp_s,
        iquat=iquat,
    )
    return params, tilt, azimuth


#: Runs dispersed at a time by :func:`draw_runs` (bounds its temporaries).
DRAW_BLOCK_RUNS = 4096


def draw_runs(
    nominal: RunParameters, sigmas: DispersionSigmas, seed: int, run_ids
) -> DispersedRuns:
    """Dispersed vehicles of campaign runs ``run_ids`` (any order, any subset).

    Each run draws from its own generator on ``run_streams(seed, i)[0]``
    (:func:`run_stream`); this Python loop
    over runs costs about 45 microseconds per run, negligible beside the flight.  Runs are
    dispersed :data:`DRAW_BLOCK_RUNS` at a time: the pointing's per-jet frames are ~3.5 KB of
    temporaries a run (90 MB for the 26,000 runs a paper-size evaluation draws at once), and
    each run's arithmetic is its own, so the blocks change no value.
    """
    run_ids = np.asarray(run_ids, dtype=np.int64).reshape(-1)
    if run_ids.size > DRAW_BLOCK_RUNS:
        parts = [
            draw_runs(nominal, sigmas, seed, run_ids[i : i + DRAW_BLOCK_RUNS])
            for i in range(0, run_ids.size, DRAW_BLOCK_RUNS)
        ]
        return DispersedRuns(
            run_ids=run_ids,
            params=RunParameters.concat([p.params for p in parts]),
            tilt_rad=np.concatenate([p.tilt_rad for p in parts]),
            azimuth_rad=np.concatenate([p.azimuth_rad for p in parts]),
        )
    jets = nominal.n_jets
    z = np.empty((run_ids.size, n_normals(jets)))
    u = np.empty((run_ids.size, n_uniforms(jets)))
    for k, i in enumerate(run_ids):
        z[k], u[k] = standard_draws(np.random.default_rng(run_stream(seed, i, 0)), jets)
    x = mass_extra_draws(seed, run_ids) if sigmas.has_mass_extras else None
    params, tilt, azimuth = apply_draws(nominal, sigmas, z, u, x)
    return DispersedRuns(run_ids=run_ids, params=params, tilt_rad=tilt, azimuth_rad=azimuth)
