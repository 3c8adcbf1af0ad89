"""The modes in a vehicle file: the hub left by them (the whole vehicle unchanged, checked on
MuJoCo's compiled bodies), the springs and dampers derived from the frequencies, and a rigid
vehicle's model untouched."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from rcsim.spacecraft.modes.linear import mode_table
from rcsim.spacecraft.vehicle import Vehicle

EXAMPLE = Path("docs/examples/canted16_modes.toml")


def composite(model: mujoco.MjModel) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, CG and inertia about the CG of every body of ``model`` at rest, summed here from
    the compiled bodies (world frame = B at qpos0)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    masses = model.body_mass[1:]
    mass = float(masses.sum())
    cg = (masses[:, None] * data.xipos[1:]).sum(axis=0) / mass
    inertia = np.zeros((3, 3))
    for b in range(1, model.nbody):
        rot = data.ximat[b].reshape(3, 3)
        d = data.xipos[b] - cg
        inertia += rot @ np.diag(model.body_inertia[b]) @ rot.T
        inertia += model.body_mass[b] * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, cg, inertia


def test_the_whole_vehicle_is_the_files():
    """The hub plus the modes at rest, as MuJoCo compiled them, have the file's mass, CG and
    inertia about the CG (parallel-axis theorem; 1e-12 relative: rounding of sums of ~1e3)."""
    v = Vehicle.load(EXAMPLE)
    mass, cg, inertia = composite(v.model)
    d = v.definition
    assert mass == pytest.approx(d.mass_kg, rel=1e-12)
    np.testing.assert_allclose(cg, d.cg_m, rtol=0, atol=1e-12)
    np.testing.assert_allclose(inertia, d.inertia_kg_m2, rtol=0, atol=1e-12 * d.mass_kg)
    # the flight model flies the same bodies
    mass_f, cg_f, inertia_f = composite(v.flight_model)
    assert mass_f == mass
    np.testing.assert_array_equal(cg_f, cg)
    np.testing.assert_allclose(inertia_f, inertia, rtol=0, atol=1e-12 * d.mass_kg)


def test_springs_and_dampers_from_the_frequencies():
    """k = m (2 pi f)^2, c = 2 zeta sqrt(k m) (slosh); k = I_h (2 pi f)^2, c = 2 zeta sqrt(k
    I_h) with I_h = I_xx + m (1.6 m)^2 about the wing's x hinge (its CG 1.6 m out along y):
    the example's numbers by hand, against the compiled joints (1e-12)."""
    v = Vehicle.load(EXAMPLE)
    m = v.model
    k_s = 12.0 * (2 * math.pi * 0.35) ** 2
    c_s = 2 * 0.005 * math.sqrt(k_s * 12.0)
    i_h = 15.0 + 30.0 * 1.6**2
    k_p = i_h * (2 * math.pi * 0.4) ** 2
    c_p = 2 * 0.005 * math.sqrt(k_p * i_h)
    for name, k, c in [
        ("tank_lateral_1", k_s, c_s),
        ("tank_lateral_2", k_s, c_s),
        ("wing_plus_y_hinge", k_p, c_p),
        ("wing_minus_y_hinge", k_p, c_p),
    ]:
        j = m.joint(name)
        assert j.stiffness[0] == pytest.approx(k, rel=1e-12)
        assert m.dof_damping[j.dofadr[0]] == pytest.approx(c, rel=1e-12)
    table = mode_table(m)
    # clamped: sqrt(K_ii / M_ii) with MuJoCo's mass matrix, the file's frequency (1e-12)
    np.testing.assert_allclose(table.clamped_hz, [0.35, 0.35, 0.4, 0.4], rtol=1e-12)
    np.testing.assert_allclose(table.mass, [12.0, 12.0, i_h, i_h], rtol=1e-12)
    assert (table.coupled_hz > table.clamped_hz.min()).all()


def test_a_rigid_vehicle_builds_the_model_it_always_did():
    """No modes: the MJCF has no child body and keeps the spring and damper stages off, and
    the flight model is one body (the packaged vehicle's MJCF bit for bit is
    tests/spacecraft/vehicle/test_paper_vehicle.py's)."""
    v = Vehicle.load("canted16")
    assert v.definition.modes is None
    assert v.model.nbody == 2 and v.model.nq == 7
    assert v.flight_model.nbody == 2 and v.flight_model.nq == 7
    off = mujoco.mjtDisableBit
    assert (
        v.model.opt.disableflags & off.mjDSBL_SPRING
        and v.model.opt.disableflags & off.mjDSBL_DAMPER
    )
    modes = Vehicle.load(EXAMPLE).model
    assert not modes.opt.disableflags & (off.mjDSBL_SPRING | off.mjDSBL_DAMPER)
    assert (modes.nq, modes.nv) == (11, 10)


def test_slosh_mass_is_part_of_the_propellant(tmp_path):
    """The slosh masses must not exceed [propellant] mass_kg (one line, naming both)."""
    text = EXAMPLE.read_text(encoding="utf-8").replace("mass_kg = 12.0 ", "mass_kg = 41.0 ")
    path = tmp_path / "v.toml"
    path.write_text(text, encoding="utf-8")
    from rcsim.models.errors import InputError

    with pytest.raises(InputError, match=r"slosh.mass_kg.*41.*propellant.mass_kg = 40"):
        Vehicle.load(path)


def test_history_memory_counts_the_modes():
    """A vehicle with modes records a coordinate and a rate (two float64) per mode coordinate
    per run per cycle beside the rigid record (rcsim.spacecraft.guards.history_bytes, which
    sizes campaign chunks and refuses flights too long to record)."""
    from rcsim.spacecraft.guards import history_bytes

    rigid = history_bytes(3, 10, n_jets=16)
    assert history_bytes(3, 10, n_jets=16, n_modes=4) - rigid == 3 * 10 * 4 * 16
