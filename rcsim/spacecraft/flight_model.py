"""The model MuJoCo integrates: one free body pushed by a six-component wrench.

The vehicle's MJCF (built from ``rcsim/models/vehicle/paper.toml`` or a user's vehicle file)
describes every jet as a site actuator, and stays the vehicle's definition: geometry, thrust,
nominal values and the read-back all come from it. Stepping that model costs MuJoCo one site
Jacobian per jet per RK4 stage, although the jets only ever add up to one force and one torque on
one rigid body. The flight model keeps the body and its options and replaces the jets by six
actuators: a force along each body axis at the body origin (site ``wrench``) and a torque about
each body axis (the free joint's rotational dofs, which MuJoCo expresses in the body frame). The
jets' sum is taken here, per run, with a matrix (:func:`jet_wrench_B`):

    F_B   = sum_j u_j T_j d_j            (d_j: jet j's unit force direction in B)
    tau_O = sum_j u_j T_j (p_j x d_j)    (p_j: jet j's site position, about the body origin O)

which is exactly what MuJoCo's site transmissions apply, summed in another order: flights
agree with the jet model to rounding (``tests/spacecraft/test_flight_model.py``, 1e-12) and a
step costs less (measured in ``docs/performance.md``).  The disturbance torque is added to the
torque components.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rcsim.spacecraft.vehicle.model import BODY, jet_actuator_ids
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

#: Actuator names of the flight model, in control order: force x, y, z [N] at the body
#: origin, torque x, y, z [N m]; all in body axes B.
WRENCH_NAMES = ("force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z")

_XML = """<mujoco model="rcsim flight model">
  <compiler angle="radian"/>
  <worldbody>
    <body name="{body}">
      <freejoint name="root"/>
      <inertial pos="{ipos}" quat="{iquat}" mass="{mass}" diaginertia="{inertia}"/>
      <site name="wrench" pos="0 0 0"/>
    </body>
  </worldbody>
  <actuator>
    <general name="force_x" site="wrench" gear="1 0 0 0 0 0" ctrllimited="false"/>
    <general name="force_y" site="wrench" gear="0 1 0 0 0 0" ctrllimited="false"/>
    <general name="force_z" site="wrench" gear="0 0 1 0 0 0" ctrllimited="false"/>
    <general name="torque_x" joint="root" gear="0 0 0 1 0 0" ctrllimited="false"/>
    <general name="torque_y" joint="root" gear="0 0 0 0 1 0" ctrllimited="false"/>
    <general name="torque_z" joint="root" gear="0 0 0 0 0 1" ctrllimited="false"/>
  </actuator>
</mujoco>
"""


def _numbers(values) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _copy_options(source: mujoco.MjOption, target: mujoco.MjOption) -> None:
    """Every physics option of ``source`` onto ``target`` (step, integrator, flags, ...)."""
    for name in dir(source):
        if name.startswith("_"):
            continue
        value = getattr(source, name)
        if callable(value):
            continue
        if isinstance(value, np.ndarray):
            getattr(target, name)[...] = value
        else:
            setattr(target, name, value)


def flight_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """The wrench model of the vehicle ``model`` (see the module docstring).

    Its body has ``model``'s mass, CG, inertia and inertia frame, its options are ``model``'s
    (time step, integrator, disabled stages), and it has no geoms, sites or actuators but the
    six of :data:`WRENCH_NAMES`.

    Raises
    ------
    ValueError
        ``model`` is not one free body: the wrench sum assumes a single rigid body.
    """
    if model.nbody != 2 or model.njnt != 1 or model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise ValueError(
            "the flight model needs a vehicle of one free body "
            f"(got {model.nbody - 1} bodies, {model.njnt} joints)"
        )
    body = model.body(BODY).id
    ipos = model.body_ipos[body]
    # A body whose CG is at its origin with principal axes along its own compiles as
    # "simple": a diagonal mass matrix with no translation-rotation coupling, a structure
    # mj_setConst keeps.  A run's dispersed CG needs that coupling (without it a coasting
    # smallsat8 lost 3e-5 of its angular momentum in 20 s; MuJoCo 4 refuses such a run), so
    # such a vehicle is compiled with its CG one metre off, then given its own values below.
    simple = not np.any(ipos) and np.array_equal(model.body_iquat[body], [1.0, 0.0, 0.0, 0.0])
    flight = mujoco.MjModel.from_xml_string(
        _XML.format(
            body=BODY,
            ipos=_numbers(ipos + [1.0, 0.0, 0.0] if simple else ipos),
            iquat=_numbers(model.body_iquat[body]),
            mass=repr(float(model.body_mass[body])),
            inertia=_numbers(model.body_inertia[body]),
        )
    )
    _copy_options(model.opt, flight.opt)
    # The body's inertial values exactly as compiled (the XML round trip is exact for the
    # repr of a double; this makes it independent of the compiler's own arithmetic).
    for name in ("body_mass", "body_ipos", "body_iquat", "body_inertia"):
        getattr(flight, name)[1] = getattr(model, name)[body]
    mujoco.mj_setConst(flight, mujoco.MjData(flight))
    return flight


def jet_sites_B(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Jet site positions and site-to-body rotations of the vehicle ``model``.

    Returns
    -------
    pos_B : ndarray, (n_jets, 3)
        Site positions relative to the body origin [m].
    rot_BS : ndarray, (n_jets, 3, 3)
        Rotation of each site frame into B (a site-frame direction ``d_S`` is ``rot_BS @ d_S``).
    """
    sites = model.actuator_trnid[jet_actuator_ids(model), 0]
    rot = np.empty((len(sites), 9))
    for k, s in enumerate(sites):
        mujoco.mju_quat2Mat(rot[k], model.site_quat[s])
    return model.site_pos[sites].copy(), rot.reshape(-1, 3, 3)


def jet_wrench_B(params: RunParameters, model: mujoco.MjModel) -> np.ndarray:
    """Wrench of each jet firing alone at full thrust, per run.

    Parameters
    ----------
    params : RunParameters
        Thrust [N] and site-frame directions of each run's jets.
    model : mujoco.MjModel
        The vehicle (jet sites), see :func:`jet_sites_B`.

    Returns
    -------
    ndarray, (n_runs, 6, n_jets)
        Rows force x, y, z [N] at the body origin and torque x, y, z about it [N m], in B;
        a control cycle's flight-model controls are this matrix times the jets' on-fractions.
    """
    pos_B, rot_BS = jet_sites_B(model)
    force_B = np.einsum("jab,njb->nja", rot_BS, params.jet_dir_S) * params.thrust_n[..., None]
    torque_B = np.cross(pos_B[None], force_B)
    return np.concatenate([force_B, torque_B], axis=2).transpose(0, 2, 1).copy()
