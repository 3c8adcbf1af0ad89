"""The MJCF of a vehicle file: the structure every vehicle shares, numbers from the file.

One free body ``vehicle`` with the mass, CG and inertia of the file (``diaginertia`` when the
products are zero, else ``fullinertia``: MuJoCo diagonalises it and stores the principal frame
in ``body_iquat``), one site and one site actuator per jet (force along the site's z axis,
``gainprm`` = thrust; the actuators are named ``jet_01``, ``jet_02``... in the file's order,
whatever the jets' own labels, as the simulation finds jets by those names), the three
body-frame disturbance torques, and the packaged options (zero gravity, every unused pipeline
stage disabled).  Numbers are written as the shortest
text that reads back as the same double, so the paper's vehicle file compiles to the packaged
model bit for bit (``tests/spacecraft/vehicle/test_paper_vehicle.py``).
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np

from rcsim.spacecraft.vehicle.definition import VehicleDef
from rcsim.spacecraft.vehicle.model import BODY, DIST_NAMES, route_mujoco_warnings
from rcsim.spacecraft.vehicle.run_parameters import RunParameters, jet_force_torque_B

# The disabled stages: one free body with actuators has no work for any of them, yet MuJoCo
# enters each every RK4 sub-step; off, the state is bit-identical (docs/performance.md).
_FLAGS = (
    'contact="disable" gravity="disable" constraint="disable" equality="disable" '
    'frictionloss="disable" limit="disable" spring="disable" damper="disable" '
    'warmstart="disable" filterparent="disable" sensor="disable" midphase="disable" '
    'eulerdamp="disable" refsafe="disable" nativeccd="disable" island="disable"'
)


def _num(x: float) -> str:
    """Shortest text of a float that reads back as the same double."""
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return repr(x)


def _vec(xs) -> str:
    return " ".join(_num(x) for x in xs)


def to_mjcf(vehicle: VehicleDef) -> str:
    """MJCF text of ``vehicle`` (module docstring)."""
    inertia = vehicle.inertia_kg_m2
    if inertia[0, 1] == 0 and inertia[0, 2] == 0 and inertia[1, 2] == 0:
        inertial = f'diaginertia="{_vec(np.diag(inertia))}"'
    else:
        full = [inertia[0, 0], inertia[1, 1], inertia[2, 2]]
        full += [inertia[0, 1], inertia[0, 2], inertia[1, 2]]
        inertial = f'fullinertia="{_vec(full)}"'
    lines = [
        f"<!-- rcsim vehicle {vehicle.name!r} from {vehicle.source} -->",
        '<mujoco model="rcs_vehicle">',
        '  <compiler angle="radian" autolimits="true"/>',
        f'  <option timestep="{_num(vehicle.timestep_s)}" integrator="{vehicle.integrator}" '
        'gravity="0 0 0" density="0" viscosity="0">',
        f"    <flag {_FLAGS}/>",
        "  </option>",
        "  <worldbody>",
        f'    <body name="{BODY}" pos="0 0 0">',
        '      <freejoint name="root"/>',
        f'      <inertial pos="{_vec(vehicle.cg_m)}" mass="{_num(vehicle.mass_kg)}" {inertial}/>',
    ]
    if vehicle.hull_half_m is not None:
        lines.append(
            f'      <geom name="hull" type="box" size="{_vec(vehicle.hull_half_m)}" '
            f'pos="{_vec(vehicle.hull_center_m)}" rgba="0.7 0.7 0.75 1" contype="0" '
            'conaffinity="0" mass="0"/>'
        )
    lines.append(f'      <site name="cg" pos="{_vec(vehicle.cg_m)}"/>')
    for k, jet in enumerate(vehicle.jets):
        lines.append(
            f'      <site name="j{k + 1:02d}" pos="{_vec(jet.position_m)}" '
            f'zaxis="{_vec(jet.direction_text)}"/>'
        )
    lines += ["    </body>", "  </worldbody>", "  <actuator>"]
    for k, jet in enumerate(vehicle.jets):
        lines.append(
            f'    <general name="jet_{k + 1:02d}" site="j{k + 1:02d}" gear="0 0 1 0 0 0" '
            f'gainprm="{_num(jet.thrust_n)}" ctrlrange="0 1"/>'
        )
    for name, gear in zip(DIST_NAMES, ("1 0 0", "0 1 0", "0 0 1")):
        lines.append(
            f'    <general name="{name}" joint="root" gear="0 0 0 {gear}" gainprm="1" '
            'ctrllimited="false"/>'
        )
    lines += ["  </actuator>", "</mujoco>", ""]
    return "\n".join(lines)


def build_model(vehicle: VehicleDef) -> mujoco.MjModel:
    """The compiled MuJoCo model of ``vehicle``."""
    route_mujoco_warnings()
    return mujoco.MjModel.from_xml_string(to_mjcf(vehicle))


def force_torque(vehicle: VehicleDef) -> np.ndarray:
    """Force [N] and torque about the CG [N m] of each jet of ``vehicle`` at full thrust,
    (6, n_jets): rows Fx, Fy, Fz, Tx, Ty, Tz in B.

    Derived once, as the flight derives it: :func:`jet_force_torque_B` of the nominal run on
    the compiled model (the site frames MuJoCo flies, whose directions may differ from the
    file's in the last bits), so the authority checks and the controllers' design read the
    same numbers.  Compiled once per MJCF text in a process.
    """
    return _force_torque(to_mjcf(vehicle), vehicle.isp_s).copy()


@functools.lru_cache(maxsize=32)
def _force_torque(mjcf_text: str, isp_s: float) -> np.ndarray:
    route_mujoco_warnings()
    model = mujoco.MjModel.from_xml_string(mjcf_text)
    force, torque = jet_force_torque_B(RunParameters.nominal(1, model, isp_s=isp_s), model)
    return np.vstack([force[0].T, torque[0].T])
