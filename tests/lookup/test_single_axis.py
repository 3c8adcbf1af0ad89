"""Control laws of Pittella & Sands (2023) checked against the paper's equations.

Everything is nondimensional (unit rotation in unit time), as in the paper.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rcsim.lookup import single_axis as sa

# Times strictly before the default RTOC switch (|det A| < 1e-5 at t ~= 0.8953).
BEFORE_SWITCH = st.floats(min_value=0.0, max_value=0.89, allow_nan=False)


def _gauss_integral(f, order=8):
    """Integral of f over [0, 1] by Gauss-Legendre: exact for polynomials of degree <= 15."""
    x, w = np.polynomial.legendre.leggauss(order)
    t = 0.5 * (x + 1.0)
    return 0.5 * np.sum(w * f(t))


# ------------------------------------------------------------------ open-loop optimal --
def test_eq11_solution_is_eq12():
    # Oracle: paper Eq. 11 (= Eq. 13 at t0 = 0) solves to a = -12, b = 6 (Eq. 12), c = d = 0
    # for theta_d = 1.  The system is well conditioned (cond ~ 45), so 1e-12 is round-off.
    coeffs = np.linalg.solve(sa.rtoc_matrix(0.0), [0.0, 0.0, 1.0, 0.0])
    np.testing.assert_allclose(coeffs, [-12.0, 6.0, 0.0, 0.0], atol=1e-12)


def test_optimal_trajectory_meets_boundary_conditions_and_cost():
    # Oracle: paper Eqs. 1-3 (rest to rest, theta(1) = 1) and J* = 6 (Section 2.3).
    # Gauss-Legendre of order 8 integrates the quartic u*^2 exactly, so only round-off.
    assert sa.optimal_angle(0.0) == 0.0 and sa.optimal_rate(0.0) == 0.0
    assert sa.optimal_angle(1.0) == pytest.approx(1.0, abs=1e-15)
    assert sa.optimal_rate(1.0) == pytest.approx(0.0, abs=1e-15)
    cost = _gauss_integral(lambda t: 0.5 * sa.optimal_control(t) ** 2)
    assert cost == pytest.approx(6.0, rel=1e-14)


def test_optimal_rate_and_angle_integrate_the_control():
    # Oracle: Eqs. 5-6 with I = 1: omega* = int u*, theta* = int omega* (exact quadrature).
    for t1 in (0.25, 0.5, 0.9):
        rate = _gauss_integral(lambda t, t1=t1: t1 * sa.optimal_control(t1 * t))
        angle = _gauss_integral(lambda t, t1=t1: t1 * sa.optimal_rate(t1 * t))
        assert rate == pytest.approx(float(sa.optimal_rate(t1)), rel=1e-13)
        assert angle == pytest.approx(float(sa.optimal_angle(t1)), rel=1e-13)


# -------------------------------------------------------------------------------- P+V --
def test_pv_gains_round_to_the_papers():
    # Oracle: Section 2.2, "for a settling time <= 1 s and a damping ratio of 0.7, the gains
    # are K_P = 37 and K_V = 8.5" from Eqs. 7-9.  Rounding: K_P to an integer, K_V to 0.5.
    kp, kv = sa.pv_gains(settling_time=1.0, zeta=0.7)
    assert round(kp) == 37
    assert round(2 * kv) / 2 == 8.5
    # K_V from the rounded K_P (Eq. 9) rounds the same way.
    assert round(2 * 2 * 0.7 * np.sqrt(37.0)) / 2 == 8.5


def test_paper_pv_gains_give_zeta_07_and_settle_within_1s():
    params = sa.PVParams()
    # Oracle: Eq. 9.  Rounding K_V to 8.5 moves zeta from 0.7 to 0.6987, hence 2e-3.
    assert sa.pv_damping(params.kp, params.kv) == pytest.approx(0.7, abs=2e-3)
    # Oracle: Eq. 7 (the 2 % envelope bound) with the rounded gains.
    assert sa.pv_settling_time(params.kp, params.kv) <= 1.0


def test_paper_pv_gains_true_2pct_settling_time_within_1s():
    # Oracle: the analytic step response of theta'' + K_V theta' + K_P theta = K_P (Eq. 14,
    # I = 1): theta = 1 - exp(-zeta w t) (cos wd t + zeta w / wd sin wd t).  The last time
    # it leaves the 2 % band must be <= 1 s; grid spacing 1e-5 bounds the timing error.
    kp, kv = sa.PVParams().kp, sa.PVParams().kv
    wn = np.sqrt(kp)
    zeta = kv / (2.0 * wn)
    wd = wn * np.sqrt(1.0 - zeta**2)
    t = np.arange(0.0, 5.0, 1e-5)
    theta = 1.0 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    outside = np.nonzero(np.abs(theta - 1.0) > 0.02)[0]
    assert t[outside[-1]] <= 1.0


def test_pv_law_is_eq14_on_measurements():
    # Oracle: Eq. 14, u = K_P (theta_d - theta) - K_V omega (rate, not rate error).
    theta = np.array([0.0, 0.5, 1.2])
    omega = np.array([0.0, 1.0, -0.3])
    u, state_dot = sa.pv_law(0.3, theta, omega, np.empty((3, 0)), sa.PVParams())
    np.testing.assert_allclose(u, 37.0 * (1.0 - theta) - 8.5 * omega, rtol=1e-15)
    assert state_dot.shape == (3, 0)


# ------------------------------------------------------------------------------- RTOC --
@given(BEFORE_SWITCH)
def test_rtoc_determinant_closed_form(t0):
    # Oracle: cofactor expansion of Eq. 13 gives det A(t0) = (1 - t0)^4 / 12, which is what
    # makes the switch a function of time only.  Relative 1e-9: LU round-off times cond(A).
    assert np.linalg.det(sa.rtoc_matrix(t0)) == pytest.approx((1 - t0) ** 4 / 12, rel=1e-9)


def test_rtoc_switch_time_is_between_stage_times():
    # The threshold is documented as T_switch = (12 det_min)^(1/4) ~= 0.105, strictly
    # between the RK4 stage times 0.895 and 0.9 (multiples of dt / 2 = 0.005).
    t_switch = 1.0 - (12.0 * sa.RTOC_DET_MIN) ** 0.25
    assert 0.895 < t_switch < 0.9


@settings(max_examples=50)
@given(BEFORE_SWITCH)
def test_rtoc_matches_pontryagin_feedback(t0):
    # Oracle: minimum-energy control of a double integrator from (theta, omega) to (1, 0)
    # in time T = 1 - t0 (Pontryagin): u = 6 (1 - theta) / T^2 - 4 omega / T.  rtol 1e-8
    # covers cond(A(t0)) <= 1e6 before the switch times machine epsilon.
    rng = np.random.default_rng(7)
    theta = rng.uniform(-0.5, 1.5, 16)
    omega = rng.uniform(-2.0, 2.0, 16)
    u, _ = sa.rtoc_law(t0, theta, omega, np.empty((16, 0)), sa.RTOCParams())
    remaining = 1.0 - t0
    expected = 6.0 * (1.0 - theta) / remaining**2 - 4.0 * omega / remaining
    np.testing.assert_allclose(u, expected, rtol=1e-8, atol=1e-8)


def test_rtoc_on_optimal_trajectory_is_optimal_control():
    # Oracle: Bellman optimality of Eq. 12 - re-solving Eq. 13 from a point of the optimal
    # trajectory returns the same line u*(t).  Tolerance as above (conditioning).
    t = np.linspace(0.0, 0.89, 90)
    for ti in t:
        th = np.array([sa.optimal_angle(ti)])
        om = np.array([sa.optimal_rate(ti)])
        u, _ = sa.rtoc_law(ti, th, om, np.empty((1, 0)), sa.RTOCParams())
        assert u[0] == pytest.approx(float(sa.optimal_control(ti)), abs=1e-8)


@pytest.mark.parametrize("t0", [0.9, 0.95, 0.995, 1.0])
def test_rtoc_switches_to_open_loop_near_singularity(t0):
    # Oracle: Section 2.4 - past the determinant threshold the command is u*(t), whatever
    # is measured; t0 = 1 (A exactly singular) must not raise or warn.
    theta = np.array([0.0, 2.0])
    omega = np.array([5.0, -5.0])
    u, _ = sa.rtoc_law(t0, theta, omega, np.empty((2, 0)), sa.RTOCParams())
    np.testing.assert_array_equal(u, sa.optimal_control(t0))


# ------------------------------------------------------------------ patching filters --
def _optimal_filter_state(t, n):
    return np.column_stack([np.full(n, sa.optimal_rate(t)), np.full(n, sa.optimal_angle(t))])


def test_double_integrator_filter_integrates_u_star():
    # Oracle: Section 2.5, the filter state (omega*, theta*) has derivative (u*, omega*), and
    # theta* replaces theta_d in Eq. 14.
    t, n = 0.4, 3
    state = _optimal_filter_state(t, n)
    theta = np.array([0.1, 0.3, 0.5])
    omega = np.array([1.0, 1.5, 0.0])
    u, state_dot = sa.double_integrator_law(t, theta, omega, state, sa.TUNED_GAINS)
    np.testing.assert_allclose(state_dot[:, 0], sa.optimal_control(t), rtol=1e-15)
    np.testing.assert_allclose(state_dot[:, 1], state[:, 0], rtol=1e-15)
    np.testing.assert_allclose(u, 78.0 * (sa.optimal_angle(t) - theta) - 0.65 * omega, rtol=1e-13)


def test_control_inversion_is_optimal_control_plus_tracking_error():
    # Oracle: Eq. 15 with optimal (u*, omega*, theta*) substituted into Eq. 14 gives
    # u = u* + K_P (theta* - theta) + K_V (omega* - omega); on the optimal trajectory u = u*.
    t, n = 0.37, 4
    state = _optimal_filter_state(t, n)
    theta = sa.optimal_angle(t) + np.array([0.0, 0.01, -0.02, 0.0])
    omega = sa.optimal_rate(t) + np.array([0.0, 0.0, 0.03, -0.01])
    u, _ = sa.control_inversion_law(t, theta, omega, state, sa.PVParams())
    expected = (
        sa.optimal_control(t)
        + 37.0 * (sa.optimal_angle(t) - theta)
        + 8.5 * (sa.optimal_rate(t) - omega)
    )
    np.testing.assert_allclose(u, expected, rtol=1e-12)
    assert u[0] == pytest.approx(float(sa.optimal_control(t)), abs=1e-12)


def test_control_inversion_reference_is_eq16_filter_output():
    # Oracle: inverse Laplace transform of Eq. 16 for the input u*(t) = 6 - 12 t:
    # theta_ref = u*/K_P + (K_V/K_P) int u* + int int u*.
    kp, kv = 37.0, 8.5
    t = 0.61
    theta_ref = sa.optimal_control(t) / kp + kv / kp * sa.optimal_rate(t) + sa.optimal_angle(t)
    # Recover theta_ref from the law: u = K_P (theta_ref - theta) - K_V omega at theta = omega = 0.
    u, _ = sa.control_inversion_law(
        t, np.zeros(1), np.zeros(1), _optimal_filter_state(t, 1), sa.PVParams()
    )
    assert u[0] / kp == pytest.approx(float(theta_ref), rel=1e-13)


# --------------------------------------------------------------------- batched shape --
@pytest.mark.parametrize("arch", sa.ARCHITECTURES, ids=lambda a: a.key)
def test_laws_are_batched_and_runs_independent(arch):
    # Each run's command depends on its own measurement only: the batch equals the runs
    # evaluated one by one, and the inputs are not modified.
    rng = np.random.default_rng(3)
    n = 9
    theta = rng.uniform(0.0, 1.0, n)
    omega = rng.uniform(-1.0, 1.0, n)
    state = rng.normal(size=(n, arch.n_states))
    before = (theta.copy(), omega.copy(), state.copy())
    u, state_dot = arch(0.42, theta, omega, state)
    assert u.shape == (n,) and state_dot.shape == state.shape
    for i in range(n):
        ui, di = arch(0.42, theta[i : i + 1], omega[i : i + 1], state[i : i + 1])
        np.testing.assert_allclose(ui, u[i : i + 1], rtol=1e-12)
        np.testing.assert_allclose(di, state_dot[i : i + 1], rtol=1e-12)
    for a, b in zip(before, (theta, omega, state)):
        np.testing.assert_array_equal(a, b)


def test_six_architectures_in_paper_order():
    # Oracle: the rows of the paper's Table 1 and its footnote gains.
    labels = [a.label for a in sa.ARCHITECTURES]
    assert labels == [
        "P+V",
        "Open-loop optimal",
        "RTOC",
        "Double integrator",
        "Double int., tuned",
        "Control inversion",
    ]
    gains = {a.key: (a.params.kp, a.params.kv) for a in sa.ARCHITECTURES if hasattr(a.params, "kp")}
    assert gains == {
        "pv": (37.0, 8.5),
        "double_integrator": (37.0, 8.5),
        "double_integrator_tuned": (78.0, 0.65),
        "control_inversion": (37.0, 8.5),
    }
