"""The modes' frequencies from the compiled model, linearised about rest (``rcsim vehicle
check``).

With ``q = (hub's 6 free dofs, mode coordinates)`` the undamped motion about rest is
``M q'' + K q = 0``: ``M`` MuJoCo's joint-space mass matrix at rest (``mj_fullM``), ``K`` the
joints' springs on the mode coordinates.  The hub has no spring, so its 6 dofs are eliminated
(the momentum they carry is conserved): the modes see the *effective* mass matrix
``M_e = M_mm - M_mh M_hh^-1 M_hm`` (the Schur complement), and the coupled (free-hub)
frequencies are ``sqrt(eig(M_e^-1 K_mm)) / (2 pi)``.  A clamped frequency is one coordinate's
alone with the hub held still: ``sqrt(K_ii / M_ii) / (2 pi)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True)
class ModeTable:
    """The linearised modes of a vehicle.

    Attributes
    ----------
    names : tuple of str
        The mode coordinates (joint names), in qpos order after the free joint.
    kinds : tuple of str
        ``slide`` [m] or ``angle`` [rad] each.
    clamped_hz : ndarray (n,)
        Each coordinate's frequency with the hub held still (0: no spring).
    mass : ndarray (n,)
        ``M_ii``: the coordinate's mass [kg] or inertia about its joint [kg m^2], hub clamped.
    effective_mass : ndarray (n,)
        ``(M_e)_ii``: the same with the hub free (less: the hub moves against it).
    coupled_hz : ndarray (n,)
        The free-hub frequencies, ascending (0 for a coordinate without a spring).
    coupled_owner : tuple of str
        Per coupled frequency, the coordinate its mode shape moves most (scaled by ``M_e``).
    """

    names: tuple
    kinds: tuple
    clamped_hz: np.ndarray
    mass: np.ndarray
    effective_mass: np.ndarray
    coupled_hz: np.ndarray
    coupled_owner: tuple


def mode_table(model: mujoco.MjModel) -> ModeTable:
    """The linearised modes of ``model`` (a free hub and its slide/hinge children) at rest."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    h, m = slice(0, 6), slice(6, model.nv)
    m_mm, m_mh, m_hh = full[m, m], full[m, h], full[h, h]
    m_eff = m_mm - m_mh @ np.linalg.solve(m_hh, m_mh.T)
    joints = range(1, model.njnt)
    k = np.diag([float(model.jnt_stiffness[j]) for j in joints])
    names = tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in joints)
    slide = int(mujoco.mjtJoint.mjJNT_SLIDE)
    kinds = tuple("slide" if int(model.jnt_type[j]) == slide else "angle" for j in joints)
    clamped = np.sqrt(np.diag(k) / np.diag(m_mm)) / (2 * math.pi)
    # Symmetric form: L^-1 K L^-T with M_e = L L' has the same eigenvalues, real and >= 0.
    chol = np.linalg.cholesky(m_eff)
    inv = np.linalg.inv(chol)
    w2, vec = np.linalg.eigh(inv @ k @ inv.T)
    shapes = inv.T @ vec  # mode shapes in the coordinates
    owner = tuple(
        names[int(i)] for i in np.argmax(np.abs(shapes * np.diag(m_eff)[:, None] ** 0.5), axis=0)
    )
    return ModeTable(
        names=names,
        kinds=kinds,
        clamped_hz=clamped,
        mass=np.diag(m_mm).copy(),
        effective_mass=np.diag(m_eff).copy(),
        coupled_hz=np.sqrt(np.clip(w2, 0.0, None)) / (2 * math.pi),
        coupled_owner=owner,
    )


def mode_coupled_hz(model: mujoco.MjModel, joints, data: mujoco.MjData | None = None) -> float:
    """The lowest coupled frequency [Hz] of one mode on the free hub: the coordinates
    ``joints`` (joint names) with the hub's six dofs eliminated and every other mode held at
    rest on the hub (rigid with it): ``M_e`` and ``K`` of :func:`mode_table` restricted to
    ``joints`` (a sub-block of the Schur complement is that of the hub and this mode alone,
    the others' masses counted in the hub's block).  0 for a mode without a spring.

    Near other modes of the same frequency the whole vehicle's modes mix them
    (:func:`mode_table`'s ``coupled_hz``); this is the mode's own, one number per mode.
    ``data``: a scratch MjData of ``model`` to reuse (its state is reset to rest here);
    making one costs more than the rest of the call."""
    if data is None:
        data = mujoco.MjData(model)
    else:
        mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    ids = [model.joint(name).id for name in joints]
    dofs = [int(model.jnt_dofadr[j]) for j in ids]
    h = slice(0, 6)
    m_mm = full[np.ix_(dofs, dofs)]
    m_mh = full[dofs, h]
    m_eff = m_mm - m_mh @ np.linalg.solve(full[h, h], m_mh.T)
    k = np.diag([float(model.jnt_stiffness[j]) for j in ids])
    chol = np.linalg.cholesky(m_eff)
    inv = np.linalg.inv(chol)
    w2 = np.linalg.eigvalsh(inv @ k @ inv.T)
    return float(np.sqrt(max(float(w2.min()), 0.0)) / (2 * math.pi))
