"""CG y/z and products of inertia (issue 18): their physics, their draws and the inertia rule.

Oracles
-------
* A CG offset ``d`` from the line of a pure force ``F`` gives a torque ``F d`` about the CG
  (``tau = (p - c) x F``); from rest about a principal axis it spins the vehicle up at
  ``F d / I`` about that axis only (no gyroscopic term), so after a firing of ``t`` seconds the
  rate is ``F d t / I`` exactly (RK4 integrates a constant acceleration exactly).
* Euler's equation about the CG, ``I w' = -w x I w`` (no torque): with a spin ``w0`` about x,
  ``I w' = (0, Ixz w0^2, -Ixy w0^2)`` for the tensor entries ``Ixy``, ``Ixz`` (MuJoCo's
  ``fullinertia`` convention).  Over a flight, SciPy's DOP853 at rtol 1e-12 on the same
  equation is the reference.
* The draws: normal with sigma = 3-sigma / 3 (4 standard errors, as tests/spacecraft/
  test_dispersions.py), and a tensor's second moments ``S = tr(I)/2 E - I`` (the
  ``rcsim.spacecraft.dispersions`` docstring).
* Inertia in B (a vehicle file whose moments MuJoCo sorts otherwise, with products: the
  ``unsorted_vehicle`` fixture): a run's tensor in B is the file's tensor, written out by the
  test, plus ``diag(sigma_xx z_2, sigma_yy z_3, sigma_zz z_4)`` with ``z`` the run's standard
  normals rebuilt from its dispersion stream (``rcsim.spacecraft.dispersions`` layout), and Euler's
  equation ``I_B w' = tau - w x I_B w`` with that tensor.
"""

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rcsim.lookup.open_loop import OpenLoopController
from rcsim.models.tables import PAPER_CYCLE_S, load_dispersions
from rcsim.spacecraft.dispersions import (
    DispersionSigmas,
    draw_runs,
    inertia_scale_limit,
    inertia_spread,
    mass_extra_draws,
    mass_extra_stream,
    n_normals,
    run_streams,
    second_moment_slack,
)
from rcsim.spacecraft.navigation import Guidance
from rcsim.spacecraft.propellant import full_inertia, principal
from rcsim.spacecraft.simulation import BatchSimulation, invalid_runs
from rcsim.spacecraft.vehicle import Vehicle
from rcsim.spacecraft.vehicle.model import jet_geometry_B
from rcsim.spacecraft.vehicle.run_parameters import RunParameters

N_RUNS = 3000
K_SE = 4.0  # standard errors, as test_dispersions.py
CYCLE_S = 0.04


@pytest.fixture(scope="module")
def nominal(paper):
    return paper.nominal(1)


def _check_normal(samples, mean, sigma):
    n = samples.size
    assert abs(samples.mean() - mean) < K_SE * sigma / np.sqrt(n)
    assert abs(samples.std(ddof=1) - sigma) < K_SE * sigma / np.sqrt(2 * (n - 1))


def _tensor(params: RunParameters) -> np.ndarray:
    return full_inertia(
        params.inertia_B, params.iquat if params.iquat is not None else [1, 0, 0, 0]
    )


# ------------------------------------------------------------------------------ physics --
def test_cg_offset_in_y_and_z_gives_the_torque_f_d(paper, nominal):
    """Jet 5 pushes along +x from (0.41, 0, 0), through the nominal CG (1.41, 0, 0)
    (rcsim/models/vehicle/README.md).  A CG moved by d along y makes the arm (-1, -d, 0) and the
    torque (0, 0, F d); along z, the arm (-1, 0, -d) and the torque (0, -F d, 0).  One whole
    40 ms cycle of firing from rest: w_z = F d t / Izz and w_y = -F d t / Iyy.  Tolerance 1e-9
    relative: the physics is exact, the rest is rounding (1e-16); the other axes stay below
    1e-12 of it (the site frame leaves 2e-16 of the jet's force off x)."""
    pos, direction = jet_geometry_B(paper.model)
    np.testing.assert_array_equal(pos[4], [0.41, 0.0, 0.0])
    np.testing.assert_allclose(direction[4], [1.0, 0.0, 0.0], rtol=0, atol=1e-15)
    d = 0.05
    params = nominal.take(np.zeros(3, int))
    cg = params.cg_B.copy()
    cg[1, 1] += d  # run 1: CG y
    cg[2, 2] += d  # run 2: CG z
    params = replace(params, cg_B=cg)
    on = np.zeros(16)
    on[4] = CYCLE_S
    sim = BatchSimulation(params, vehicle=paper, nthread=1)
    np.testing.assert_array_equal(sim.flown_params().cg_B, cg)  # body_ipos per run
    hist = sim.run(OpenLoopController(on, PAPER_CYCLE_S), Guidance.rate(np.zeros((3, 3))), CYCLE_S)
    w = hist.final.omega_B
    force = float(nominal.thrust_n[0, 4])
    ixx, iyy, izz = nominal.inertia_B[0]
    np.testing.assert_allclose(w[0], 0.0, atol=1e-15)  # through the CG: no torque
    expect_z = force * d * CYCLE_S / izz
    assert w[1, 2] == pytest.approx(expect_z, rel=1e-9)
    np.testing.assert_allclose(w[1, :2], 0.0, atol=1e-12 * abs(expect_z))
    expect_y = -force * d * CYCLE_S / iyy
    assert w[2, 1] == pytest.approx(expect_y, rel=1e-9)
    np.testing.assert_allclose(w[2, [0, 2]], 0.0, atol=1e-12 * abs(expect_y))


def _with_products(nominal: RunParameters, products) -> tuple[RunParameters, np.ndarray]:
    tensor = np.diag(nominal.inertia_B[0])
    for (a, b), p in zip(((0, 1), (0, 2), (1, 2)), products):
        tensor[a, b] = tensor[b, a] = p
    moments, iquat = principal(tensor[None])
    return replace(nominal, inertia_B=moments, iquat=iquat), tensor


def test_a_product_of_inertia_gives_eulers_cross_axis_acceleration(paper, nominal):
    """Spin 0.5 rad/s about x, no torque, Ixy = 50, Ixz = -30, Iyz = 20 kg m^2 on the paper's
    moments: MuJoCo's angular acceleration at t = 0 (qacc of the free joint's rotational dofs,
    body frame) equals I^-1 (0, Ixz w0^2, -Ixy w0^2) to 1e-12 relative (two 3x3 solves of the
    same equation, rounding only).  Without the products it is zero."""
    params, tensor = _with_products(nominal, (50.0, -30.0, 20.0))
    w0 = 0.5
    expect = np.linalg.solve(tensor, np.array([0.0, -30.0 * w0**2, -50.0 * w0**2]))
    # The cross-axis terms as a GN&C analyst writes them: about Ixz w0^2 / Iyy and
    # -Ixy w0^2 / Izz (to the products' share of the moments, ~2 %).
    assert expect[1] == pytest.approx(-30.0 * w0**2 / tensor[1, 1], rel=0.02)
    assert expect[2] == pytest.approx(-50.0 * w0**2 / tensor[2, 2], rel=0.02)
    for p, want in ((params, expect), (nominal, np.zeros(3))):
        sim = BatchSimulation(p, vehicle=paper, nthread=1)
        qacc = sim.physics.batch.bind("qacc")  # registered before the reset's forward pass fills it
        sim.physics.reset(None, np.array([[w0, 0.0, 0.0]]))
        np.testing.assert_allclose(qacc[0, 3:6], want, rtol=0, atol=1e-12 * np.abs(expect).max())


def test_a_flight_with_products_follows_eulers_equation(paper, nominal):
    """The per-run principal frame flies the tensor: 2 s of torque-free spin about x at
    0.3 rad/s against DOP853 (rtol 1e-12) on I w' = -w x I w.  Tolerance 1e-9 rad/s: RK4 at
    40 ms errs by (w h)^5 ~ 2e-10 relative a step here; a frame written transposed, or products
    lost, is off by ~1e-3 rad/s."""
    params, tensor = _with_products(nominal, (50.0, -30.0, 20.0))
    w0 = np.array([0.3, 0.0, 0.0])
    hist = BatchSimulation(params, vehicle=paper, nthread=1).run(
        OpenLoopController(np.zeros(16), PAPER_CYCLE_S),
        Guidance.rate(np.zeros((1, 3))),
        2.0,
        omega0_B=w0[None],
    )
    ref = solve_ivp(
        lambda _t, w: np.linalg.solve(tensor, -np.cross(w, tensor @ w)),
        (0.0, 2.0),
        w0,
        method="DOP853",
        rtol=1e-12,
        atol=1e-15,
    ).y[:, -1]
    assert np.abs(ref[1:]).max() > 1e-3  # the cross-axis motion is there to be checked
    np.testing.assert_allclose(hist.final.omega_B[0], ref, rtol=0, atol=1e-9)


# -------------------------------------------------------------------------------- draws --
@pytest.fixture(scope="module")
def extras():
    return DispersionSigmas(cg_y_m=0.02 / 3, cg_z_m=0.03 / 3, products_kg_m2=(30.0, 45.0, 60.0))


def test_extras_are_normal_with_their_sigmas(nominal, extras):
    """cg_y, cg_z about the nominal CG, each product about the nominal's (0): normal with
    their sigmas; the tensor's diagonal is the nominal moments (no moment dispersed here) to
    1e-12 relative (the eigen round trip of the flown principal frame)."""
    runs = draw_runs(nominal, extras, 12345, np.arange(N_RUNS))
    p = runs.params
    _check_normal(p.cg_B[:, 1], nominal.cg_B[0, 1], extras.cg_y_m)
    _check_normal(p.cg_B[:, 2], nominal.cg_B[0, 2], extras.cg_z_m)
    tensor = _tensor(p)
    for (a, b), sigma in zip(((0, 1), (0, 2), (1, 2)), extras.products_kg_m2):
        _check_normal(tensor[:, a, b], 0.0, sigma)
        # Symmetric to rounding of the rebuilt tensor (1e-12 of the largest moment).
        np.testing.assert_allclose(tensor[:, a, b], tensor[:, b, a], rtol=0, atol=4e-9)
    np.testing.assert_allclose(
        np.diagonal(tensor, axis1=1, axis2=2),
        np.repeat(nominal.inertia_B, N_RUNS, axis=0),
        rtol=1e-12,
    )
    # Independent: the products' pairwise correlation within 4 SE (SE = 1 / sqrt(n)).
    corr = np.corrcoef(tensor[:, 0, 1], tensor[:, 1, 2])[0, 1]
    assert abs(corr) < K_SE / np.sqrt(N_RUNS)


def test_extras_leave_every_table5_draw_unchanged(nominal, extras):
    """The extras come from a child of the dispersion stream: adding them to Table 5 changes
    no Table 5 draw (mass, CG x, thrust, pointing bit for bit; the moments as the tensor's
    diagonal to rounding), and one extra's sigma moves no other extra."""
    table5 = DispersionSigmas.from_table(load_dispersions())
    both = replace(
        table5,
        cg_y_m=extras.cg_y_m,
        cg_z_m=extras.cg_z_m,
        products_kg_m2=extras.products_kg_m2,
    )
    ids = np.arange(200)
    a = draw_runs(nominal, table5, 7, ids)
    b = draw_runs(nominal, both, 7, ids)
    assert a.params.iquat is None and b.params.iquat is not None
    for name in ("mass_kg", "thrust_n", "jet_dir_S"):
        np.testing.assert_array_equal(getattr(a.params, name), getattr(b.params, name))
    np.testing.assert_array_equal(a.params.cg_B[:, 0], b.params.cg_B[:, 0])
    np.testing.assert_array_equal(a.tilt_rad, b.tilt_rad)
    np.testing.assert_array_equal(a.azimuth_rad, b.azimuth_rad)
    np.testing.assert_allclose(
        np.diagonal(_tensor(b.params), axis1=1, axis2=2), a.params.inertia_B, rtol=1e-12
    )
    only_cg = draw_runs(nominal, replace(both, products_kg_m2=(0.0, 0.0, 0.0)), 7, ids)
    np.testing.assert_array_equal(only_cg.params.cg_B, b.params.cg_B)
    no_y = draw_runs(nominal, replace(both, cg_y_m=0.0), 7, ids)
    np.testing.assert_array_equal(no_y.params.cg_B[:, 2], b.params.cg_B[:, 2])
    np.testing.assert_array_equal(no_y.params.inertia_B, b.params.inertia_B)


def test_mass_extra_stream_is_the_first_child_of_the_dispersion_stream():
    """The seeding rule: run i's extras come from SeedSequence(seed, spawn_key=(i,))'s first
    spawned child's first child, the spawn key (i, 0, 0); five normals whatever the sigmas."""
    for seed, run_id in ((0, 0), (5, 9), (2**40, 123456)):
        expected = run_streams(seed, run_id)[0].spawn(1)[0]
        got = mass_extra_stream(seed, run_id)
        assert got.spawn_key == (run_id, 0, 0) == expected.spawn_key
        np.testing.assert_array_equal(
            mass_extra_draws(seed, [run_id])[0],
            np.random.default_rng(expected).standard_normal(5),
        )


def test_draws_with_extras_depend_only_on_seed_and_run_id(nominal, extras):
    all_runs = draw_runs(nominal, extras, 3, np.arange(10))
    some = draw_runs(nominal, extras, 3, [8, 3, 5])
    for name in ("cg_B", "inertia_B", "iquat"):
        np.testing.assert_array_equal(
            getattr(some.params, name), getattr(all_runs.params, name)[[8, 3, 5]]
        )


def test_draws_in_blocks_are_the_draws_at_once(nominal, extras, monkeypatch):
    """Issue 19: draw_runs disperses DRAW_BLOCK_RUNS runs at a time to bound its temporaries;
    every run's arithmetic is its own, so blocks of 7 (and a short last block) give the same
    vehicles, principal frames (products of inertia) and tilts to the last bit."""
    from rcsim.spacecraft import dispersions

    ids = np.arange(40, 0, -1)
    whole = draw_runs(nominal, extras, 6, ids)
    monkeypatch.setattr(dispersions, "DRAW_BLOCK_RUNS", 7)
    blocks = draw_runs(nominal, extras, 6, ids)
    assert whole.params.iquat is not None
    for name in ("mass_kg", "cg_B", "inertia_B", "thrust_n", "jet_dir_S", "iquat"):
        np.testing.assert_array_equal(getattr(blocks.params, name), getattr(whole.params, name))
    np.testing.assert_array_equal(blocks.tilt_rad, whole.tilt_rad)
    np.testing.assert_array_equal(blocks.azimuth_rad, whole.azimuth_rad)
    np.testing.assert_array_equal(blocks.run_ids, ids)
    with pytest.raises(ValueError, match="principal frames"):  # no frame cannot be invented
        RunParameters.concat([nominal, whole.params])


# ---------------------------------------------------------------------- physical tensors --
def test_the_second_moment_slack_is_the_triangle_inequalitys(nominal):
    """Table 1: (Iyy + Izz - Ixx) / 2 = (3160.22 + 2457.06 - 3583.09) / 2 = 1017.095 kg m^2 is
    the paper vehicle's smallest second moment of mass (sum m x^2 about its thinnest axis)."""
    tensor = np.diag(nominal.inertia_B[0])
    assert second_moment_slack(tensor) == pytest.approx(1017.095, rel=1e-12)
    assert second_moment_slack(np.diag([1.0, 1.0, 2.0])) == 0.0  # a flat plate: the edge
    three = {"ixx": 322.48, "iyy": 284.42, "izz": 221.13, "ixy": 30.0}
    assert inertia_spread(three) == pytest.approx(
        np.sqrt((322.48**2 + 284.42**2 + 221.13**2) / 4 + 30.0**2), rel=1e-15
    )
    assert inertia_scale_limit(tensor, {}) == np.inf


def test_the_rules_standard_deviation_is_the_draws(nominal):
    """Along x the paper vehicle's second moment S_xx = (-Ixx + Iyy + Izz)/2 is normal with
    mean 1017.095 kg m^2 and sd inertia_spread / 3 = 241.757 / 3 kg m^2 under Table 5's
    moments (the bound |v^T A v| <= ||A|| is attained there): sample mean and sd within 4 SE."""
    sig = DispersionSigmas.from_table(load_dispersions())
    p = draw_runs(nominal, sig, 99, np.arange(N_RUNS)).params
    s_xx = (-p.inertia_B[:, 0] + p.inertia_B[:, 1] + p.inertia_B[:, 2]) / 2
    spread = inertia_spread({"ixx": 322.48, "iyy": 284.42, "izz": 221.13})
    _check_normal(s_xx, 1017.095, spread / 3)


def test_a_run_that_is_no_rigid_body_is_not_flown(paper, nominal):
    """Positive moments that break the triangle inequality (1 + 1 < 5) are no body: the run is
    failed with that reason and flown with the nominal vehicle, as any invalid parameter;
    the moments of a real body (the nominal, and a body at the edge, 1 + 1 = 2) pass."""
    params = nominal.take(np.zeros(3, int))
    inertia = params.inertia_B.copy()
    inertia[1] = (1000.0, 1000.0, 5000.0)
    inertia[2] = (1000.0, 1000.0, 2000.0)
    params = replace(params, inertia_B=inertia)
    reasons = invalid_runs(params)
    assert reasons[0] == "" and reasons[2] == ""
    assert "triangle inequality" in reasons[1] and "inertia_B" in reasons[1]
    hist = BatchSimulation(params, vehicle=paper, nthread=1).run(
        OpenLoopController(np.zeros(16), PAPER_CYCLE_S), Guidance.rate(np.zeros((3, 3))), CYCLE_S
    )
    assert hist.failed.tolist() == [False, True, False]
    np.testing.assert_array_equal(hist.flown_params.inertia_B[1], nominal.inertia_B[0])


# ------------------------------------------------------------------------- inertia in B --
@pytest.fixture(scope="module")
def unsorted(unsorted_vehicle) -> tuple[Vehicle, np.ndarray]:
    return Vehicle.load(unsorted_vehicle.path), unsorted_vehicle.tensor_B


def _inertia_normals(seed: int, run_ids, n_jets: int) -> np.ndarray:
    """Each run's Ixx, Iyy, Izz standard normals (n, 3): normals 2..4 of its dispersion
    stream (the layout of rcsim.spacecraft.dispersions.standard_draws)."""
    return np.array(
        [
            np.random.default_rng(run_streams(seed, i)[0]).standard_normal(n_normals(n_jets))[2:5]
            for i in run_ids
        ]
    )


def test_mujoco_sorts_the_unsorted_vehicles_moments(unsorted):
    """The premise: MuJoCo holds the file's tensor as its principal moments in descending order
    (numpy's eigenvalues of the file's tensor, 1e-12 relative) in a frame that is not B, so its
    moments are not Ixx, Iyy, Izz (here the file's Ixx is the smallest, MuJoCo's first the
    largest)."""
    flying, tensor = unsorted
    nominal = flying.nominal(1)
    assert nominal.iquat is not None
    np.testing.assert_allclose(
        nominal.inertia_B[0], np.linalg.eigvalsh(tensor)[::-1], rtol=1e-12, atol=0
    )
    assert nominal.inertia_B[0, 0] > tensor[1, 1] > tensor[0, 0]


@pytest.mark.parametrize("product_sigma", [0.0, 1e-9])
def test_ixx_disperses_the_tensors_xx_entry_in_b(unsorted, product_sigma):
    """Only Ixx dispersed (3-sigma 21 kg m^2), with no product dispersed or a negligible one
    (the path through the products' draws): every run's tensor in B, rebuilt from the principal
    moments and frame it is flown with, is the file's tensor plus ``diag(sigma z_2, 0, 0)`` (and
    the product's draw on xy) to 1e-9 kg m^2 (the eigen round trip's rounding, ~1e-12 of the
    moments).  So the xx entry is normal with that sigma (mean and sd within 4 SE) and the other
    diagonal entries do not spread beyond rounding (1e-9 kg m^2); before the fix the draw went
    to MuJoCo's first principal moment, here about y: a yy spread of sigma."""
    flying, tensor = unsorted
    sigma = 21.0 / 3
    sigmas = DispersionSigmas(inertia_kg_m2=(sigma, 0.0, 0.0), products_kg_m2=(product_sigma, 0, 0))
    ids = np.arange(N_RUNS)
    got = _tensor(draw_runs(flying.nominal(1), sigmas, 11, ids).params)
    expect = np.repeat(tensor[None], N_RUNS, axis=0)
    expect[:, 0, 0] += sigma * _inertia_normals(11, ids, flying.n_jets)[:, 0]
    if product_sigma:
        xy = product_sigma * mass_extra_draws(11, ids)[:, 2]
        expect[:, 0, 1] += xy
        expect[:, 1, 0] += xy
    np.testing.assert_allclose(got, expect, rtol=0, atol=1e-9)
    _check_normal(got[:, 0, 0], tensor[0, 0], sigma)
    for a in (1, 2):
        assert np.ptp(got[:, a, a]) < 1e-9


def test_a_flight_follows_euler_with_the_files_tensor(unsorted):
    """Spin w0 = (0.1, 0.2, -0.3) rad/s under a body torque tau = (5, -8, 3) N m: MuJoCo's
    angular acceleration at t = 0 (free joint's rotational dofs, body frame) equals
    I_B^-1 (tau - w0 x I_B w0), I_B the file's tensor for the nominal run and the file's tensor
    plus the run's diagonal draw for two runs with Ixx and Izz dispersed, to 1e-12 of the
    largest component (two solves of one equation: rounding, and MuJoCo's compiled tensor is
    the file's to 1e-15).  The draws on MuJoCo's sorted moments instead (before the fix)
    were off by up to 28 %."""
    flying, tensor = unsorted
    sigmas = DispersionSigmas(inertia_kg_m2=(300.0 / 3, 0.0, 200.0 / 3))
    dispersed = draw_runs(flying.nominal(1), sigmas, 5, [0, 1]).params
    z = _inertia_normals(5, [0, 1], flying.n_jets)
    w0, tau = np.array([0.1, 0.2, -0.3]), np.array([5.0, -8.0, 3.0])
    for params, tensors in (
        (flying.nominal(1), tensor[None]),
        (
            dispersed,
            tensor + np.einsum("ni,ij->nij", np.asarray(sigmas.inertia_kg_m2) * z, np.eye(3)),
        ),
    ):
        n = params.n_runs
        sim = BatchSimulation(params, flying, nthread=1)
        qacc, ctrl = sim.physics.batch.bind("qacc"), sim.physics.batch.bind("ctrl")
        sim.physics.reset(None, np.repeat(w0[None], n, axis=0))
        ctrl[:, 3:6] = tau  # the flight model's body torques (rcsim.spacecraft.flight_model)
        sim.physics.batch.forward()
        for k in range(n):
            i_b = tensors[k]
            expect = np.linalg.solve(i_b, tau - np.cross(w0, i_b @ w0))
            np.testing.assert_allclose(
                qacc[k, 3:6], expect, rtol=0, atol=1e-12 * np.abs(expect).max()
            )
