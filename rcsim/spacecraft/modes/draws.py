"""Dispersions of the modes: each run's slosh masses, clamped frequencies and damping ratios,
drawn run by run, and the MuJoCo values they make.

Model (a ``[[slosh]]`` or ``[[appendage]]`` block's ``mass_kg_3sigma``,
``frequency_hz_3sigma``, ``damping_ratio_3sigma``: 3-sigma, absolute, normal, per mode;
``docs/vehicles.md``, "Dispersions of the modes"):

* a slosh mass ``m + sigma z`` (spring or pendulum): the mode's body alone; the hub is not
  changed (its own mass is ``[dispersions] mass_kg``'s), so the whole vehicle's mass moves
  with the draw;
* a clamped frequency ``f + sigma z`` and a damping ratio ``zeta + sigma z`` (a spring slosh
  mode or a panel), each run's spring and damper following the definitions
  (:mod:`rcsim.spacecraft.modes.definition`): ``k = m (2 pi f)^2``, ``c = 2 zeta sqrt(k m)``
  for a spring slosh mode (its drawn mass), ``k = I_h (2 pi f)^2``, ``c = 2 zeta sqrt(k I_h)``
  for a panel (``I_h`` its nominal inertia about the hinge).

The readers keep each 3-sigma draw a mode (:mod:`rcsim.spacecraft.modes.reader`); a draw in
the far tail beyond that is clipped (mass at :data:`MIN_MASS_FRACTION` of the nominal,
frequency at :data:`~rcsim.spacecraft.modes.reader.MIN_FREQUENCY_HZ`, damping ratio at 0), and
what a run flew is what it records.

Seeding: child :data:`MODES` of run ``i``'s noise stream
(:func:`rcsim.spacecraft.effect_draws.effect_stream`, after the pulses' 4), ``3 n_modes``
standard normals always (mass, frequency, damping ratio of each mode in the file's order:
slosh blocks, then appendages) whatever the sigmas, so no sigma shifts another draw, and a
vehicle without these dispersions draws nothing: every run flies as before.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from rcsim.spacecraft.effect_draws import effect_stream
from rcsim.spacecraft.guards import invalid_runs
from rcsim.spacecraft.modes.definition import POINT_GYRATION_M, Appendage, SloshMode
from rcsim.spacecraft.modes.linear import mode_coupled_hz
from rcsim.spacecraft.modes.reader import MIN_FREQUENCY_HZ, Modes
from rcsim.spacecraft.vehicle.model import BODY
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: Child of a run's noise stream the modes' dispersions draw from (after the pulses' 4).
MODES = 5
#: Standard normals per mode and run: mass, frequency, damping ratio.
NORMALS_PER_MODE = 3
#: Smallest slosh mass a far-tail draw is clipped to, as a fraction of the nominal (MuJoCo
#: refuses a moving body without mass; the reader keeps 3-sigma below the nominal).
MIN_MASS_FRACTION = 1e-3


@dataclass(frozen=True)
class ModeRuns:
    """The modes each run flies, one column per mode (the file's order: slosh, then panels).

    Attributes
    ----------
    modes : tuple of SloshMode and Appendage
        The nominal modes.
    mass_kg : ndarray, (n_runs, n_modes)
        Each mode's mass [kg] (a panel's: its nominal).
    frequency_hz : ndarray, (n_runs, n_modes)
        Clamped frequency [Hz] (0 for a pendulum).
    damping_ratio : ndarray, (n_runs, n_modes)
        Damping ratio (0 for a pendulum).
    """

    modes: tuple
    mass_kg: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray

    @property
    def n_runs(self) -> int:
        return int(self.mass_kg.shape[0])

    def take(self, index) -> ModeRuns:
        """The runs ``index`` selects (int array, slice or mask)."""
        return ModeRuns(
            self.modes, self.mass_kg[index], self.frequency_hz[index], self.damping_ratio[index]
        )

    def stiffness(self) -> np.ndarray:
        """Each mode's joint spring, (n_runs, n_modes): ``k = m (2 pi f)^2`` [N/m] for a
        spring slosh mode, ``I_h (2 pi f)^2`` [N m/rad] for a panel, 0 for a pendulum."""
        return self._joint_mass() * (2 * math.pi * self.frequency_hz) ** 2

    def damping(self) -> np.ndarray:
        """Each mode's joint damper, (n_runs, n_modes): ``c = 2 zeta sqrt(k m)`` (``I_h`` for
        a panel); a pendulum's ``damping_n_m_s`` [N m s/rad]."""
        c = 2 * self.damping_ratio * np.sqrt(self.stiffness() * self._joint_mass())
        for j, mode in enumerate(self.modes):
            if isinstance(mode, SloshMode) and mode.model == "pendulum":
                c[:, j] = mode.damping_n_m_s
        return c

    def _joint_mass(self) -> np.ndarray:
        """The mass [kg] or hinge inertia [kg m^2] each mode's spring acts on, (n, n_modes)."""
        out = self.mass_kg.copy()
        for j, mode in enumerate(self.modes):
            if isinstance(mode, Appendage):
                out[:, j] = mode.hinge_inertia
        return out

    def write(self, model: mujoco.MjModel, expand) -> None:
        """Each run's mode values into a batch's per-simulation fields of ``model`` (the
        flight model): ``expand(name)`` returns the live (n_runs, ...) array of field
        ``name`` (:meth:`mujoco.batch.Batch.expand`).  Body mass and a slosh point's own
        inertia (``m r^2``, :data:`~rcsim.spacecraft.modes.definition.POINT_GYRATION_M`), each
        joint's ``jnt_stiffness`` and ``dof_damping``; the caller runs ``set_const``."""
        k, c = self.stiffness(), self.damping()
        mass, inertia = expand("body_mass"), expand("body_inertia")
        stiffness, damping = expand("jnt_stiffness"), expand("dof_damping")
        for j, mode in enumerate(self.modes):
            body = model.body(mode.name).id
            if isinstance(mode, SloshMode):
                mass[:, body] = self.mass_kg[:, j]
                inertia[:, body] = (self.mass_kg[:, j] * POINT_GYRATION_M**2)[:, None]
            for joint, _ in mode.coordinates():
                jid = model.joint(joint).id
                stiffness[:, jid] = k[:, j]
                damping[:, model.jnt_dofadr[jid]] = c[:, j]


def mode_normals(seed: int, run_ids, n_modes: int) -> np.ndarray:
    """The standard normals of runs ``run_ids``, ``(n, 3 n_modes)``."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    z = np.empty((run_ids.size, NORMALS_PER_MODE * n_modes))
    for k, i in enumerate(run_ids):  # a few variates a run; the flight dominates
        z[k] = np.random.default_rng(effect_stream(seed, int(i), MODES)).standard_normal(z.shape[1])
    return z


def draw_modes(modes: Modes, seed: int, run_ids) -> ModeRuns:
    """The modes runs ``run_ids`` fly (module docstring); the nominal ones where a mode has no
    dispersion (bit for bit its nominal values)."""
    run_ids = np.asarray(run_ids, np.int64).reshape(-1)
    every = modes.all
    n = run_ids.size
    z = mode_normals(seed, run_ids, len(every)).reshape(n, len(every), NORMALS_PER_MODE)
    sigmas = modes.sigmas or ()
    mass = np.empty((n, len(every)))
    freq = np.empty((n, len(every)))
    zeta = np.empty((n, len(every)))
    for j, mode in enumerate(every):
        s = sigmas[j] if sigmas else None
        m0, f0, z0 = mode.mass_kg, mode.frequency_hz, mode.damping_ratio
        mass[:, j] = m0
        freq[:, j] = f0
        zeta[:, j] = z0
        if s is None:
            continue
        if s.mass_kg:
            mass[:, j] = np.maximum(m0 + s.mass_kg * z[:, j, 0], MIN_MASS_FRACTION * m0)
        if s.frequency_hz:
            freq[:, j] = np.maximum(f0 + s.frequency_hz * z[:, j, 1], MIN_FREQUENCY_HZ)
        if s.damping_ratio:
            zeta[:, j] = np.maximum(z0 + s.damping_ratio * z[:, j, 2], 0.0)
    return ModeRuns(tuple(every), mass, freq, zeta)


_HUB_FIELDS = ("body_mass", "body_ipos", "body_inertia", "body_iquat")


def mode_kind(mode) -> str:
    """``spring``, ``pendulum`` (slosh) or ``panel``: which runs.parquet columns a mode has
    (:func:`flown_values`)."""
    return "panel" if isinstance(mode, Appendage) else mode.model


def flown_values(flight: mujoco.MjModel, hub: RunParameters, runs: ModeRuns) -> dict:
    """What each run's modes flew, for ``runs.parquet``: per mode ``<name>``,

    * ``mode_<name>_freq_hz``: the clamped frequency [Hz] (spring slosh, panel);
    * ``mode_<name>_coupled_freq_hz``: the mode's lowest coupled frequency [Hz] on that run's
      hub, the other modes held at rest on it
      (:func:`rcsim.spacecraft.modes.linear.mode_coupled_hz` of the run's own model: its
      hub's mass, CG and inertia ``hub``, its modes' masses and springs); a run whose hub
      parameters are invalid is recorded failed on the nominal hub
      (:class:`rcsim.spacecraft.batch_physics.BatchPhysics`), and so is its value here;
    * ``mode_<name>_damping``: the damping ratio (spring slosh, panel);
    * ``mode_<name>_mass_kg`` (slosh) or ``mode_<name>_inertia_kg_m2`` (a panel's inertia
      about its hinge, not dispersed).

    ``flight`` is the vehicle's flight model (:mod:`rcsim.spacecraft.flight_model`), copied
    once and given each run's values in turn (a loop over runs: a mass matrix at rest a run,
    beside a flight's hundreds of steps).  Returns name -> (n_runs,) array.
    """
    n = runs.n_runs
    out: dict = {}
    coupled = np.zeros((n, len(runs.modes)))
    model = copy.copy(flight)
    body = model.body(BODY).id
    invalid = invalid_runs(hub)
    data = mujoco.MjData(model)
    nominal = {f: getattr(flight, f)[body].copy() for f in _HUB_FIELDS}
    for i in range(n):
        if invalid[i]:  # flown (and failed) with the nominal hub: BatchPhysics' rule
            for f in _HUB_FIELDS:
                getattr(model, f)[body] = nominal[f]
        else:
            model.body_mass[body] = hub.mass_kg[i]
            model.body_ipos[body] = hub.cg_B[i]
            model.body_inertia[body] = hub.inertia_B[i]
            model.body_iquat[body] = nominal["body_iquat"] if hub.iquat is None else hub.iquat[i]
        runs.take([i]).write(model, lambda name: getattr(model, name)[None])
        mujoco.mj_setConst(model, data)
        for j, mode in enumerate(runs.modes):
            if mode_kind(mode) != "pendulum":
                joints = [joint for joint, _ in mode.coordinates()]
                coupled[i, j] = mode_coupled_hz(model, joints, data)
    for j, mode in enumerate(runs.modes):
        kind, name = mode_kind(mode), f"mode_{mode.name}"
        if kind != "pendulum":
            out[f"{name}_freq_hz"] = runs.frequency_hz[:, j].copy()
            out[f"{name}_coupled_freq_hz"] = coupled[:, j]
            out[f"{name}_damping"] = runs.damping_ratio[:, j].copy()
        if kind == "panel":
            out[f"{name}_inertia_kg_m2"] = np.full(n, mode.hinge_inertia)
        else:
            out[f"{name}_mass_kg"] = runs.mass_kg[:, j].copy()
    return out
