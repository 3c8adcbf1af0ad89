"""Propellant that runs out: mass flow, exhaustion, and mass properties that follow it.

Model (stated)
--------------
* Mass flow of a firing jet: ``mdot = F / (Isp g0)`` [kg/s], F its thrust (as flown: dispersed,
  degraded), Isp the vehicle's specific impulse, ``g0`` = 9.80665 m/s^2 (the definition of Isp
  in seconds).  Propellant used over a cycle = ``sum_j F_j * thrust-time_j / (Isp g0)``, the
  impulse divided by the effective exhaust velocity, exact for the cycle's pieces.
* The vehicle's mass, CG and inertia at t = 0 are the *wet* vehicle.  The usable propellant
  ``m_p0`` is a point mass at the tank position ``p`` (B frame); using ``u`` kg of it removes a
  point mass ``u`` there (a point mass has no inertia of its own about itself)::

      m(u)   = m0 - u
      c(u)   = (m0 c0 - u p) / (m0 - u)
      I_O(u) = I_O0 - u (|p|^2 E - p p^T)            about the body origin O
      I_c(u) = I_O(u) - m(u) (|c|^2 E - c c^T)       about the new CG (parallel axes)

  with ``I_O0 = I_c0 + m0 (|c0|^2 E - c0 c0^T)``.  The body rate is continuous across a change
  (the expelled mass carries its own momentum away; jet damping is neglected).  The mass
  properties are updated once per control cycle, after the cycle's firing (the largest change
  in one 40 ms cycle of all 16 paper jets at once is 0.013 kg of 3505 kg, 4e-6 relative).
* Exhaustion: the instant in a cycle at which the propellant left is used up, found exactly
  from the cycle's pieces (constant jets within a piece); every jet's on-interval is ended
  there (the jets stop) and the run records ``propellant exhausted at t = ... s``
  (:func:`exhausted_text`), a failure reason of its campaign row and the ``reason`` of a
  maneuver's summary.  The run flies on without thrust.
* Firings after exhaustion: a controller keeps commanding, but a jet without propellant
  delivers nothing, so a command in a control cycle that starts at or after the exhaustion
  instant is not counted as a firing (``PropulsionState.firings``, a campaign's
  ``firings_*`` columns); the firings of the cycle in which the propellant runs out count
  (they were commanded with propellant left).  The recorded commands themselves
  (``History.on_time_s``) stay what the controller asked for.

The mass properties written to MuJoCo are the principal moments and the principal frame
(``body_inertia``, ``body_iquat``) of ``I_c(u)``; a diagonal tensor keeps the identity frame
exactly.  This module owns that conversion both ways (:func:`principal`, :func:`full_inertia`,
:func:`inertia_tensor_B`): the dispersions, the read-back of ``runs.parquet`` and the
controllers' nominal models go through it.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle.run_parameters import G0_M_S2, RunParameters

_DIAG = [0, 1, 2]  # index of a tensor's diagonal entries


@dataclass(frozen=True)
class PropellantTank:
    """Propellant tracked per run.

    Attributes
    ----------
    initial_kg : ndarray, (n_runs,)
        Usable propellant at t = 0 [kg], part of the vehicle's mass.
    position_B : ndarray, (3,)
        Tank position (the point mass) in B [m].
    """

    initial_kg: np.ndarray
    position_B: np.ndarray

    @classmethod
    def of(cls, n_runs: int, initial_kg, position_B) -> PropellantTank:
        """A tank broadcast to ``n_runs`` runs."""
        initial = np.broadcast_to(np.asarray(initial_kg, float), (n_runs,)).copy()
        position = np.asarray(position_B, float).reshape(3)
        if not (np.isfinite(initial).all() and (initial >= 0).all()):
            raise InputError(
                "must be finite and >= 0", parameter="propellant_kg", value=initial.tolist()
            )
        if not np.isfinite(position).all():
            raise InputError("must be finite", parameter="tank_position_m", value=position.tolist())
        return cls(initial, position)


def exhausted_text(t_s: float) -> str:
    """The failure reason of a run whose propellant ran out at ``t_s`` [s] (one wording for
    campaigns and maneuvers)."""
    return f"propellant exhausted at t = {t_s:.4f} s"


def exhausted_before(times_s: np.ndarray, exhausted_s: np.ndarray | None) -> np.ndarray | None:
    """(n, K) bool: cycle ``k`` of run ``i`` starts at or after the run's propellant ran out
    (``times_s`` (K,) the cycles' start times, ``exhausted_s`` (n,) the exhaustion instants,
    inf when it did not); None when propellant is not tracked.  Its commands are no firings
    (module docstring)."""
    if exhausted_s is None:
        return None
    return np.asarray(times_s)[None, :] >= np.asarray(exhausted_s)[:, None]


def mass_flow_kg_s(thrust_n: np.ndarray, isp_s: float | np.ndarray) -> np.ndarray:
    """``F / (Isp g0)`` [kg/s], any shape."""
    return np.asarray(thrust_n, float) / (isp_s * G0_M_S2)


def _point_tensor(v: np.ndarray) -> np.ndarray:
    """``|v|^2 E - v v^T`` (the inertia of a unit point mass at v), (..., 3) -> (..., 3, 3)."""
    return np.einsum("...i,...i->...", v, v)[..., None, None] * np.eye(3) - (
        v[..., :, None] * v[..., None, :]
    )


def mass_properties(
    mass0_kg: np.ndarray,
    cg0_B: np.ndarray,
    inertia0_B: np.ndarray,
    tank_B: np.ndarray,
    used_kg: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mass (n,), CG (n, 3) and full inertia about the CG (n, 3, 3) after ``used_kg`` (n,)
    of propellant left the tank at ``tank_B`` (3,), from the wet values (module docstring)."""
    m0 = np.asarray(mass0_kg, float)
    used = np.asarray(used_kg, float)
    c0 = np.asarray(cg0_B, float)
    tank = np.asarray(tank_B, float)
    inertia_O = (
        np.asarray(inertia0_B, float)
        + m0[:, None, None] * _point_tensor(c0)
        - used[:, None, None] * _point_tensor(tank)
    )
    m = m0 - used
    c = (m0[:, None] * c0 - used[:, None] * tank) / m[:, None]
    return m, c, inertia_O - m[:, None, None] * _point_tensor(c)


def full_inertia(moments_B: np.ndarray, iquat: np.ndarray) -> np.ndarray:
    """Full tensors (n, 3, 3) from principal moments (n, 3) in the frame ``iquat``: one
    quaternion (4,) for every run, or one per run (n, 4) (a batch whose runs share one frame
    is computed as with a single quaternion, to the bit)."""
    iquat = np.asarray(iquat, float)
    moments_B = np.asarray(moments_B, float)
    if iquat.ndim == 2:
        if (iquat == iquat[:1]).all():
            return full_inertia(moments_B, iquat[0])
        mats = np.empty((iquat.shape[0], 9))
        for k in range(iquat.shape[0]):  # mju_quat2Mat has no batched form; ~1 us a run
            mujoco.mju_quat2Mat(mats[k], iquat[k])
        rots = mats.reshape(-1, 3, 3)
        return np.einsum("nij,nj,nkj->nik", rots, moments_B, rots)
    flat = np.empty(9)
    mujoco.mju_quat2Mat(flat, iquat)
    rot = flat.reshape(3, 3)
    return np.einsum("ij,nj,kj->nik", rot, moments_B, rot)


def inertia_tensor_B(params: RunParameters) -> np.ndarray:
    """Each run's inertia tensor about the CG in B, (n, 3, 3) [kg m^2]: its principal moments
    ``params.inertia_B`` in its frame ``params.iquat`` (:func:`full_inertia`).

    ``iquat`` None is the identity, as :meth:`RunParameters.nominal` gives it for a model whose
    principal axes are B (the packaged vehicle, a vehicle file without products): the tensor
    is then ``diag(inertia_B)`` exactly, its diagonal the moments to the bit.  Its diagonal is
    what Ixx, Iyy, Izz mean everywhere in rcsim (dispersions, runs.parquet, authority)."""
    if params.iquat is None:
        tensor = np.zeros((params.n_runs, 3, 3))
        tensor[:, _DIAG, _DIAG] = params.inertia_B
        return tensor
    return full_inertia(params.inertia_B, params.iquat)


def principal(inertia_B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (n, 3) and their frame as MuJoCo ``body_iquat`` (n, 4) of full tensors
    (n, 3, 3); a diagonal tensor gives its diagonal and the identity exactly."""
    n = inertia_B.shape[0]
    moments = np.empty((n, 3))
    quats = np.zeros((n, 4))
    quats[:, 0] = 1.0
    diag = (inertia_B[:, 0, 1] == 0) & (inertia_B[:, 0, 2] == 0) & (inertia_B[:, 1, 2] == 0)
    moments[diag] = np.diagonal(inertia_B[diag], axis1=1, axis2=2)
    if (~diag).any():
        w, vecs = np.linalg.eigh(inertia_B[~diag])
        vecs = vecs * np.sign(np.linalg.det(vecs))[:, None, None]  # right-handed
        moments[~diag] = w
        quats[~diag] = mat2quat(vecs.reshape(-1, 9))
    return moments, quats


def mat2quat(mat: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) of rotation matrices (n, 9), row-major: MuJoCo's
    ``mju_mat2Quat`` batched, the same branches and operations (bit for bit on 600,000
    random rotations, and in ``tests/spacecraft/test_propellant.py``).

    Called every cycle for the runs that burned propellant, where a loop over runs calling
    ``mju_mat2Quat`` (~1 us a run) would be a Python loop in the hot path.
    """
    m0, m1, m2, m3, m4, m5, m6, m7, m8 = (mat[:, i] for i in range(9))
    with np.errstate(invalid="ignore", divide="ignore"):  # the branches not taken
        a = 0.5 * np.sqrt(1 + m0 + m4 + m8)  # w largest
        b = 0.5 * np.sqrt(1 + m0 - m4 - m8)  # x largest
        c = 0.5 * np.sqrt(1 - m0 + m4 - m8)  # y largest
        d = 0.5 * np.sqrt(1 - m0 - m4 + m8)  # z largest
        by_w = np.stack([a, 0.25 * (m7 - m5) / a, 0.25 * (m2 - m6) / a, 0.25 * (m3 - m1) / a], 1)
        by_x = np.stack([0.25 * (m7 - m5) / b, b, 0.25 * (m1 + m3) / b, 0.25 * (m2 + m6) / b], 1)
        by_y = np.stack([0.25 * (m2 - m6) / c, 0.25 * (m1 + m3) / c, c, 0.25 * (m5 + m7) / c], 1)
        by_z = np.stack([0.25 * (m3 - m1) / d, 0.25 * (m2 + m6) / d, 0.25 * (m5 + m7) / d, d], 1)
    use_w = m0 + m4 + m8 > 0
    use_x = ~use_w & (m0 > m4) & (m0 > m8)
    use_y = ~use_w & ~use_x & (m4 > m8)
    q = np.where(
        use_w[:, None], by_w, np.where(use_x[:, None], by_x, np.where(use_y[:, None], by_y, by_z))
    )
    # mju_normalize4: rescaled only when the norm is off 1 by more than mjMINVAL (1e-15).
    norm = np.sqrt(q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2] + q[:, 3] * q[:, 3])
    return np.where((np.abs(norm - 1) > 1e-15)[:, None], q * (1 / norm)[:, None], q)


def exhaustion_time_s(
    length_s: np.ndarray, thrust_time: np.ndarray, mdot_kg_s: np.ndarray, left_kg: np.ndarray
) -> np.ndarray:
    """Instant in the cycle [s] at which the propellant left runs out; inf if it does not.

    Parameters
    ----------
    length_s : ndarray, (n, P)
        Piece lengths (:class:`rcsim.spacecraft.pieces.Pieces`).
    thrust_time : ndarray, (n, P, n_jets)
        Fraction of full thrust of each jet in each piece (on x level).
    mdot_kg_s : ndarray, (n, n_jets)
        Mass flow of each jet at full thrust [kg/s].
    left_kg : ndarray, (n,)
        Propellant left at the cycle's start [kg].
    """
    rate = np.einsum("npj,nj->np", thrust_time, mdot_kg_s)  # kg/s in each piece
    used_end = np.cumsum(rate * length_s, axis=1)
    start = np.cumsum(length_s, axis=1) - length_s
    before = used_end - rate * length_s
    crosses = (used_end >= left_kg[:, None]) & (rate > 0)
    p = np.argmax(crosses, axis=1)
    r = np.arange(len(p))
    t = start[r, p] + (left_kg - before[r, p]) / np.where(rate[r, p] > 0, rate[r, p], 1.0)
    return np.where(crosses.any(axis=1), np.maximum(t, 0.0), np.inf)
