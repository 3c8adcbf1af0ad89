"""The modes in MuJoCo: child bodies of the vehicle body, and their copy in the flight model.

Each mode is a child body of the vehicle (hub) body, placed at the hub's origin-relative
point it hangs from, on joints whose spring and damper are the mode's
(:mod:`rcsim.spacecraft.modes.definition`):

* a spring slosh mode: a body at its rest position with one slide joint per direction
  (``stiffness`` k, ``damping`` c);
* a pendulum: a body at the pivot with two hinges about the axes normal to the rod
  (``damping`` only), its point mass ``length_m`` down the rod;
* a panel: a body at the hinge point with one hinge (``stiffness``, ``damping``), its CG at
  the offset.

The vehicle's MJCF disables MuJoCo's spring and damper stages (a rigid vehicle has none); a
vehicle with modes enables them.  Joint qpos and qvel follow the free joint's 7 and 6, in the
order of :func:`rcsim.spacecraft.modes.definition.mode_coordinates`.

The flight model (:mod:`rcsim.spacecraft.flight_model`) rebuilds the same child bodies from a
compiled model (:func:`child_bodies_xml`) and copies their compiled values
(:func:`copy_child_values`), so it integrates the same mechanism bit for bit.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rcsim.spacecraft.modes.definition import POINT_GYRATION_M as _R
from rcsim.spacecraft.modes.definition import Appendage, SloshMode, normal_axes


def _r(x: float) -> str:
    return repr(float(x))


def _v(xs) -> str:
    return " ".join(_r(x) for x in np.ravel(xs))


def mode_flags(flags: str) -> str:
    """``flags`` (the vehicle's ``<flag .../>`` attributes) with the spring and damper stages
    enabled: a vehicle with modes needs its joints' springs and dampers."""
    return flags.replace('spring="disable" ', "").replace('damper="disable" ', "")


def _slosh_xml(mode: SloshMode, indent: str) -> list[str]:
    m = mode.mass_kg
    inertial = f'<inertial pos="{{pos}}" mass="{_r(m)}" diaginertia="{_v([m * _R**2] * 3)}"/>'
    if mode.model == "spring":
        lines = [f'{indent}<body name="{mode.name}" pos="{_v(mode.position_m)}">']
        for (joint, _), d in zip(mode.coordinates(), mode.directions):
            lines.append(
                f'{indent}  <joint name="{joint}" type="slide" axis="{_v(d)}" '
                f'stiffness="{_r(mode.stiffness)}" damping="{_r(mode.damping)}"/>'
            )
        lines.append(f"{indent}  " + inertial.format(pos="0 0 0"))
    else:
        assert mode.pivot_m is not None  # a pendulum has its pivot
        lines = [f'{indent}<body name="{mode.name}" pos="{_v(mode.pivot_m)}">']
        for (joint, _), axis in zip(mode.coordinates(), normal_axes(mode.directions[0])):
            lines.append(
                f'{indent}  <joint name="{joint}" type="hinge" axis="{_v(axis)}" '
                f'damping="{_r(mode.damping)}"/>'
            )
        rod = np.asarray(mode.directions[0]) * mode.length_m
        lines.append(f"{indent}  " + inertial.format(pos=_v(rod)))
    lines.append(f"{indent}</body>")
    return lines


def _panel_xml(panel: Appendage, indent: str) -> list[str]:
    i = np.asarray(panel.inertia_kg_m2, float)
    full = [i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]]
    ((joint, _),) = panel.coordinates()
    return [
        f'{indent}<body name="{panel.name}" pos="{_v(panel.hinge_m)}">',
        f'{indent}  <joint name="{joint}" type="hinge" axis="{_v(panel.axis)}" '
        f'stiffness="{_r(panel.stiffness)}" damping="{_r(panel.damping)}"/>',
        f'{indent}  <inertial pos="{_v(panel.cg_offset_m)}" mass="{_r(panel.mass_kg)}" '
        f'fullinertia="{_v(full)}"/>',
        f"{indent}</body>",
    ]


def modes_xml(modes, indent: str = "      ") -> list[str]:
    """MJCF lines of ``modes`` (:class:`SloshMode` and :class:`Appendage`, in order), to go
    inside the vehicle body."""
    lines: list[str] = []
    for mode in modes:
        lines += (
            _slosh_xml(mode, indent) if isinstance(mode, SloshMode) else _panel_xml(mode, indent)
        )
    return lines


# ------------------------------------------------------------------------ the flight model --
_JOINT_TYPES = {
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}


def child_bodies(model: mujoco.MjModel, hub: int) -> list[int]:
    """The bodies below ``hub``, in model order (parents before children)."""
    below = {hub}
    out = []
    for b in range(hub + 1, model.nbody):
        if model.body_parentid[b] in below:
            below.add(b)
            out.append(b)
    return out


def mode_joint_problem(model: mujoco.MjModel, hub: int) -> str:
    """Why ``model`` is not one free hub with slide/hinge children, or ''."""
    children = set(child_bodies(model, hub))
    if model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE or model.jnt_bodyid[0] != hub:
        return "its first joint is not the hub's free joint"
    if len(children) != model.nbody - 2:
        return "it has bodies outside the hub"
    for j in range(1, model.njnt):
        if int(model.jnt_type[j]) not in _JOINT_TYPES or model.jnt_bodyid[j] not in children:
            return f"joint {j} is not a slide or hinge of a child of the hub"
    return ""


def child_bodies_xml(model: mujoco.MjModel, hub: int) -> str:
    """MJCF of the bodies below ``hub`` in ``model`` with their joints and inertials, nested
    as in ``model`` (values as compiled; :func:`copy_child_values` makes them exact)."""

    def body(b: int, indent: str) -> list[str]:
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        lines = [
            f'{indent}<body name="{name}" pos="{_v(model.body_pos[b])}" '
            f'quat="{_v(model.body_quat[b])}">'
        ]
        for j in np.flatnonzero(model.jnt_bodyid == b):
            jname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(j))
            dof = model.jnt_dofadr[j]
            lines.append(
                f'{indent}  <joint name="{jname}" type="{_JOINT_TYPES[int(model.jnt_type[j])]}" '
                f'pos="{_v(model.jnt_pos[j])}" axis="{_v(model.jnt_axis[j])}" '
                f'stiffness="{_r(model.jnt_stiffness[j])}" damping="{_r(model.dof_damping[dof])}"/>'
            )
        lines.append(
            f'{indent}  <inertial pos="{_v(model.body_ipos[b])}" quat="{_v(model.body_iquat[b])}" '
            f'mass="{_r(model.body_mass[b])}" diaginertia="{_v(model.body_inertia[b])}"/>'
        )
        for c in np.flatnonzero(model.body_parentid == b):
            if c != b:
                lines += body(int(c), indent + "  ")
        lines.append(f"{indent}</body>")
        return lines

    out: list[str] = []
    for c in np.flatnonzero(model.body_parentid == hub):
        if c != hub:
            out += body(int(c), "      ")
    return "\n".join(out)


_BODY_FIELDS = ("body_pos", "body_quat", "body_ipos", "body_iquat", "body_mass", "body_inertia")
_JOINT_FIELDS = ("jnt_pos", "jnt_axis", "jnt_stiffness", "qpos_spring")


def copy_child_values(model: mujoco.MjModel, flight: mujoco.MjModel, hub: int) -> None:
    """The compiled values of ``model``'s bodies below ``hub`` onto ``flight``'s (same names):
    positions, frames, inertials, joint axes, springs and dampers, bit for bit."""
    for b in child_bodies(model, hub):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        fb = flight.body(name).id
        for f in _BODY_FIELDS:
            getattr(flight, f)[fb] = getattr(model, f)[b]
    for j in range(1, model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        fj = flight.joint(name).id
        flight.jnt_pos[fj] = model.jnt_pos[j]
        flight.jnt_axis[fj] = model.jnt_axis[j]
        flight.jnt_stiffness[fj] = model.jnt_stiffness[j]
        flight.qpos_spring[flight.jnt_qposadr[fj]] = model.qpos_spring[model.jnt_qposadr[j]]
        flight.dof_damping[flight.jnt_dofadr[fj]] = model.dof_damping[model.jnt_dofadr[j]]
        flight.dof_armature[flight.jnt_dofadr[fj]] = model.dof_armature[model.jnt_dofadr[j]]
