"""Dispersions of the modes (rcsim.spacecraft.modes.draws): each run's draws are a function of
(seed, run id) alone, the modes without a dispersion keep their compiled values bit for bit,
and each run flies its drawn values: the per-run springs are the definitions' by hand, the
per-run model's clamped frequency is the draw, and a dispersed panel's free response rings
at the coupled frequency its drawn clamped frequency makes."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rcsim.spacecraft.batch_physics import BatchPhysics
from rcsim.spacecraft.modes.definition import ModeSigmas
from rcsim.spacecraft.modes.draws import draw_modes
from rcsim.spacecraft.modes.linear import mode_table
from rcsim.spacecraft.vehicle import Vehicle
from tests.spacecraft.modes.test_modes_oracles import DT, free_response_hz, load, whole_vehicle

EXAMPLE = Path("docs/examples/canted16_modes.toml")


def dispersed_example(tmp_path) -> Vehicle:
    text = EXAMPLE.read_text(encoding="utf-8")
    tank = "frequency_hz = 0.35       # clamped (tank held still)\ndamping_ratio = 0.005\n"
    text = text.replace(
        tank,
        tank + "mass_kg_3sigma = 3.0\nfrequency_hz_3sigma = 0.06\ndamping_ratio_3sigma = 0.003\n",
    )
    wing = "cg_offset_m = [0.0, 1.6, 0.0]\nfrequency_hz = 0.4        # clamped (hub held still)\n"
    assert wing in text
    text = text.replace(wing, wing + "frequency_hz_3sigma = 0.09\ndamping_ratio_3sigma = 0.004\n")
    path = tmp_path / "v.toml"
    path.write_text(text, encoding="utf-8")
    return Vehicle.load(path)


def test_draws_are_per_run_whatever_the_batch(tmp_path):
    """A run's modes are the same drawn alone, in a batch or in another order; another seed
    draws others; the wing without dispersions keeps its nominal values in every run."""
    modes = dispersed_example(tmp_path).definition.modes
    ids = np.arange(40)
    every = draw_modes(modes, 11, ids)
    alone = draw_modes(modes, 11, [17])
    backwards = draw_modes(modes, 11, ids[::-1])
    for name in ("mass_kg", "frequency_hz", "damping_ratio"):
        a = getattr(every, name)
        np.testing.assert_array_equal(getattr(alone, name)[0], a[17])
        np.testing.assert_array_equal(getattr(backwards, name)[::-1], a)
        assert not np.array_equal(getattr(draw_modes(modes, 12, ids), name)[:, :2], a[:, :2])
    np.testing.assert_array_equal(every.frequency_hz[:, 2], 0.4)
    np.testing.assert_array_equal(every.damping_ratio[:, 2], 0.005)
    assert np.std(every.frequency_hz[:, 1]) > 0 and np.std(every.mass_kg[:, 0]) > 0
    np.testing.assert_array_equal(every.mass_kg[:, 1:], 30.0)  # a panel's mass is its own


def test_draws_follow_their_sigmas():
    """400 runs: each dispersed quantity's sample mean and standard deviation are its nominal
    and 3-sigma / 3 (the standard error of a mean is sigma / 20; of a standard deviation
    sigma / sqrt(2 * 399) = sigma / 28: 4 standard errors allowed)."""
    modes = Vehicle.load(EXAMPLE).definition.modes
    sig = (ModeSigmas(1.0, 0.02, 0.001), ModeSigmas(0.0, 0.03, 0.0013), ModeSigmas())
    runs = draw_modes(replace(modes, sigmas=sig), 3, np.arange(400))
    for values, nominal, sigma in [
        (runs.mass_kg[:, 0], 12.0, 1.0),
        (runs.frequency_hz[:, 0], 0.35, 0.02),
        (runs.damping_ratio[:, 0], 0.005, 0.001),
        (runs.frequency_hz[:, 1], 0.4, 0.03),
        (runs.damping_ratio[:, 1], 0.005, 0.0013),
    ]:
        assert abs(values.mean() - nominal) < 4 * sigma / 20
        assert abs(values.std(ddof=1) - sigma) < 4 * sigma / 28


def flown(vehicle: Vehicle, modes, n: int) -> BatchPhysics:
    params = vehicle.nominal(n)
    return BatchPhysics(
        vehicle.model,
        params,
        [""] * n,
        nthread=1,
        level=np.ones((n, params.n_jets)),
        n_sub=1,
        flight=vehicle.flight_model,
        modes=modes,
    )


def test_each_run_flies_its_drawn_springs(tmp_path):
    """The batch's per-run joints: the wing's k = I_h (2 pi f)^2 with I_h = 15 + 30 x 1.6^2 =
    91.8 kg m^2 (its own I_xx plus its mass 1.6 m off the x hinge), c = 2 zeta sqrt(k I_h);
    the tank's k = m (2 pi f)^2, c = 2 zeta sqrt(k m) with its drawn mass, which is also its
    body's mass (by hand, 1e-12: rounding); the undispersed wing's values are its compiled
    ones bit for bit; MuJoCo's clamped frequency of each run's model, sqrt(K_ii / M_ii) from
    its own mass matrix, is the drawn frequency (1e-12)."""
    v = dispersed_example(tmp_path)
    n = 5
    runs = draw_modes(v.definition.modes, 7, np.arange(n))
    physics = flown(v, runs, n)
    f = v.flight_model
    stiffness = physics.batch.expanded("jnt_stiffness")
    damping = physics.batch.expanded("dof_damping")
    mass = physics.batch.expanded("body_mass")
    i_h = 15.0 + 30.0 * 1.6**2
    for i in range(n):
        m, fs, zs = runs.mass_kg[i, 0], runs.frequency_hz[i, 0], runs.damping_ratio[i, 0]
        fw, zw = runs.frequency_hz[i, 1], runs.damping_ratio[i, 1]
        k_s, k_w = m * (2 * math.pi * fs) ** 2, i_h * (2 * math.pi * fw) ** 2
        for joint in ("tank_lateral_1", "tank_lateral_2"):
            j = f.joint(joint).id
            assert stiffness[i, j] == pytest.approx(k_s, rel=1e-12)
            assert damping[i, f.jnt_dofadr[j]] == pytest.approx(2 * zs * math.sqrt(k_s * m))
        j = f.joint("wing_plus_y_hinge").id
        assert stiffness[i, j] == pytest.approx(k_w, rel=1e-12)
        assert damping[i, f.jnt_dofadr[j]] == pytest.approx(2 * zw * math.sqrt(k_w * i_h))
        assert mass[i, f.body("tank_lateral").id] == m
        j = f.joint("wing_minus_y_hinge").id
        assert stiffness[i, j] == f.jnt_stiffness[j]
        assert damping[i, f.jnt_dofadr[j]] == f.dof_damping[f.jnt_dofadr[j]]
        table = mode_table(physics.batch.get_model(i))
        np.testing.assert_allclose(table.clamped_hz, [fs, fs, fw, 0.4], rtol=1e-12)


def test_a_dispersed_panel_rings_at_its_drawn_coupled_frequency(tmp_path):
    """A panel hinged through the hub's CG, its CG on the hinge line, its clamped frequency
    dispersed: each run's free response in MuJoCo (the batch's own per-run model) rings at
    f_drawn sqrt(I_total / I_hub) (test_modes_oracles' closed form, there at the nominal;
    1e-6 relative: that test's tolerance budget, RK4 at 10 ms over ~50 periods)."""
    m_hub, m_p = 400.0, 20.0
    hub_i = np.diag([120.0, 150.0, 130.0])
    panel_i = np.diag([5.0, 4.5, 9.0])
    mass, cg, inertia = whole_vehicle(m_hub, hub_i, [(m_p, (0.0, 0.0, 0.0), panel_i)])
    blocks = (
        '[[appendage]]\nname = "p"\n'
        f"mass_kg = {m_p}\ninertia_kg_m2 = [5.0, 4.5, 9.0]\nhinge_m = [0.0, 0.0, 0.0]\n"
        "axis = [0, 0, 1]\ncg_offset_m = [0.0, 0.0, 0.0]\nfrequency_hz = 0.5\n"
        "damping_ratio = 0.0\nfrequency_hz_3sigma = 0.3\n"
    )
    v = load(tmp_path, mass, cg, inertia, blocks, timestep_s=DT)
    runs = draw_modes(v.definition.modes, 2, np.arange(2))
    physics = flown(v, runs, 2)
    ratio = math.sqrt((hub_i[2, 2] + panel_i[2, 2]) / hub_i[2, 2])
    for i in range(2):
        f_drawn = runs.frequency_hz[i, 0]
        assert abs(f_drawn - 0.5) > 1e-3  # a draw away from the nominal
        measured = free_response_hz(physics.batch.get_model(i), 7, 1e-3, 100.0)
        assert measured == pytest.approx(f_drawn * ratio, rel=1e-6)


def test_recorded_coupled_frequency_follows_the_runs_hub(tmp_path):
    """flown_values' coupled frequency of a panel hinged through the hub's CG about z, its CG
    on the hinge line, is f_drawn sqrt((J + I_p) / J) with J the *run's* hub Izz (the closed
    form of test_modes_oracles; 1e-9: an eigenvalue of a 7 x 7 mass matrix); a hub whose
    parameters are invalid (recorded failed, flown on the nominal hub) records the nominal
    hub's, J = 130 kg m^2; clamped frequency and damping are the draws, the inertia about the
    hinge 9 kg m^2."""
    from rcsim.spacecraft.modes.draws import flown_values

    m_hub, m_p = 400.0, 20.0
    hub_i = np.diag([120.0, 150.0, 130.0])
    panel_i = np.diag([5.0, 4.5, 9.0])
    mass, cg, inertia = whole_vehicle(m_hub, hub_i, [(m_p, (0.0, 0.0, 0.0), panel_i)])
    blocks = (
        '[[appendage]]\nname = "p"\n'
        f"mass_kg = {m_p}\ninertia_kg_m2 = [5.0, 4.5, 9.0]\nhinge_m = [0.0, 0.0, 0.0]\n"
        "axis = [0, 0, 1]\ncg_offset_m = [0.0, 0.0, 0.0]\nfrequency_hz = 0.5\n"
        "damping_ratio = 0.01\nfrequency_hz_3sigma = 0.3\ndamping_ratio_3sigma = 0.006\n"
    )
    v = load(tmp_path, mass, cg, inertia, blocks, timestep_s=DT)
    runs = draw_modes(v.definition.modes, 4, np.arange(3))
    hub = v.nominal(3)
    izz = np.array([130.0, 100.0, 170.0])
    hub = replace(hub, inertia_B=hub.inertia_B.copy(), mass_kg=hub.mass_kg.copy())
    hub.inertia_B[:, 2] = izz
    hub.mass_kg[2] = -1.0  # invalid: not flown
    values = flown_values(v.flight_model, hub, runs)
    f = runs.frequency_hz[:, 0]
    expected = f * np.sqrt((izz + 9.0) / izz)
    np.testing.assert_allclose(values["mode_p_coupled_freq_hz"][:2], expected[:2], rtol=1e-9)
    nominal = f[2] * np.sqrt((130.0 + 9.0) / 130.0)
    assert values["mode_p_coupled_freq_hz"][2] == pytest.approx(nominal, rel=1e-9)
    np.testing.assert_array_equal(values["mode_p_freq_hz"], f)
    np.testing.assert_array_equal(values["mode_p_damping"], runs.damping_ratio[:, 0])
    np.testing.assert_allclose(values["mode_p_inertia_kg_m2"], 9.0, rtol=1e-12)


def test_a_pendulums_mass_is_dispersed_alone(tmp_path):
    """A pendulum disperses its mass only: each run's bob is its draw (with the 1 mm point
    gyration, m 1e-6 kg m^2, as compiled), its swing dampers stay the file's 0.2 N m s/rad, no
    spring; runs.parquet gets its mass alone."""
    from rcsim.spacecraft.modes.draws import flown_values

    blocks = (
        '[[slosh]]\nname = "bob"\nmodel = "pendulum"\nmass_kg = 5.0\npivot_m = [0.0, 0.0, 0.0]\n'
        "direction = [-1, 0, 0]\nlength_m = 0.3\ndamping_n_m_s = 0.2\nmass_kg_3sigma = 1.5\n"
    )
    v = load(
        tmp_path, 400.0, (0.0, 0.0, 0.0), np.diag([120.0, 150.0, 130.0]), blocks, timestep_s=DT
    )
    runs = draw_modes(v.definition.modes, 1, np.arange(4))
    physics = flown(v, runs, 4)
    f = v.flight_model
    body = f.body("bob").id
    np.testing.assert_array_equal(physics.batch.expanded("body_mass")[:, body], runs.mass_kg[:, 0])
    np.testing.assert_allclose(
        physics.batch.expanded("body_inertia")[:, body],
        np.repeat(runs.mass_kg[:, :1] * 1e-6, 3, 1),
        rtol=1e-12,
    )
    for joint in ("bob_swing_1", "bob_swing_2"):
        j = f.joint(joint).id
        np.testing.assert_array_equal(physics.batch.expanded("jnt_stiffness")[:, j], 0.0)
        np.testing.assert_array_equal(
            physics.batch.expanded("dof_damping")[:, f.jnt_dofadr[j]], 0.2
        )
    assert np.std(runs.mass_kg[:, 0]) > 0
    values = flown_values(f, v.nominal(4), runs)
    assert list(values) == ["mode_bob_mass_kg"]
    # The whole vehicle each run flies is its hub plus its own drawn bob (History.delta_v_B
    # divides the jets' impulse by it): the per-run mass, not the compiled nominal 5 kg.
    np.testing.assert_array_equal(physics.mode_mass_kg, runs.mass_kg[:, 0])
