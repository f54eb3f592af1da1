"""Error-state model against thesis Appendix A (Tables A.1-A.5), finite differences and Van Loan."""

import numpy as np
import pytest

from sarnav.filters import (
    ErrorStateLayout,
    ErrorStateModel,
    apply_feedback,
    corrupt_state,
    error_state,
    fogm_kernels,
    van_loan,
)
from sarnav.ins import NavState, mechanize
from sarnav.rotations import quat_normalize, quat_to_dcm
from sarnav.trajectory import Maneuvering, StraightLevel

L18 = ErrorStateLayout(("b_alt", "b_range", "b_rate"))


def _one(p, v, q, ba, bg, bm):
    return NavState(*(np.atleast_2d(np.asarray(a, dtype=float)) for a in (p, v, q, ba, bg, bm)))


# --- Tables A.1-A.4: the state maps m, n, l ------------------------------------------------
TRUTH_A1 = _one([1000, 0, -500], [50, 0, 0], [1, 0, 0, 0], [0.228, 0.436, 0.311], [0.923, 0.430, 0.184], [0.905, 0.980, 0.221])
DX_A1 = np.array([[0.379, 0.812, 0.533, 0.351, 0.939, 0.876, 0.018, 0.021, 0.020,
                   0.208, 0.301, 0.471, 0.230, 0.844, 0.195, 0.226, 0.171, 0.101]])


def test_table_a2_estimate_from_truth_and_error():
    est = corrupt_state(TRUTH_A1, DX_A1, L18)  # x_hat' = m(x, dx)
    # Table A.2, printed to 3 decimals (b_g z prints -0.010; exact -0.011, extraction T1)
    tol = 1.5e-3
    np.testing.assert_allclose(est.p[0], [999.621, -0.812, -500.533], atol=tol)
    np.testing.assert_allclose(est.v[0], [49.649, -0.939, -0.876], atol=tol)
    np.testing.assert_allclose(est.q[0], [0.999, 0.009, 0.010, 0.010], atol=tol)
    np.testing.assert_allclose(est.ba[0], [0.020, 0.135, -0.160], atol=tol)
    np.testing.assert_allclose(est.bg[0], [0.693, -0.414, -0.010], atol=tol)
    np.testing.assert_allclose(est.bm[0], [0.679, 0.809, 0.120], atol=tol)


def test_table_a3_a4_round_trips():
    est = corrupt_state(TRUTH_A1, DX_A1, L18)
    d = DX_A1 - error_state(TRUTH_A1, est, L18)  # Table A.3: dx - n(x_hat', x)
    th = L18.slice("th")
    np.testing.assert_allclose(np.delete(d[0], np.r_[6:9]), 0.0, atol=1e-12)
    # second-order small-angle effect of the normalisation in m(): with rotations.py's maps
    # n(m(x, dth)) = dth / sqrt(1 + |dth|^2/4) exactly
    dth = DX_A1[0, th]
    np.testing.assert_allclose(d[0, th], dth * (1 - 1 / np.sqrt(1 + dth @ dth / 4)), rtol=1e-9)
    # Table A.3 prints (-0.264e-5, -0.298e-5, -0.281e-5): same size (their dth was rounded for
    # printing), opposite sign -- the thesis' maps normalise differently at second order
    np.testing.assert_allclose(np.abs(d[0, th]), [0.264e-5, 0.298e-5, 0.281e-5], rtol=0.05)
    back = apply_feedback(est, DX_A1, L18)  # Table A.4: x - l(x_hat', dx) = 0
    for f in ("p", "v", "q", "ba", "bg", "bm"):
        np.testing.assert_allclose(getattr(back, f), getattr(TRUTH_A1, f), atol=1e-12)


# --- Table A.5: linear vs nonlinear error propagation ----------------------------------------
G = 9.81
TAU = 5.0  # t/tau = 0.2 reproduces Table A.5's bias rows (extraction §12.9)
DX_123 = np.concatenate([
    [1.0, 2.0, 3.0], [0.1, 0.2, 0.3], [0.01, 0.02, 0.03],
    1e-3 * G * np.array([1.0, 2.0, 3.0]), np.radians([1.0, 2.0, 3.0]) / 3600.0, [1.0, 2.0, 1.5],
])[None]


def _propagate(traj, dx0, horizon, rate=1000.0, sub=10, layout=L18, tau=TAU, earth_rate=None):
    """Nonlinear error (truth vs INS from m(x, dx0), noise-free IMU with truth biases) and the
    linear prediction Phi dx0 with Phi from F along the estimate (closed-form steps of sub samples; with
    ``earth_rate`` the truth IMU, the INS and F all see the rotating tangent frame)."""
    runs = dx0.shape[0]
    t = np.arange(int(round(horizon * rate)) + 1) / rate
    s = traj.state(t)
    b_truth = np.tile(np.concatenate([1e-3 * G * np.array([0.5, -0.3, 0.2]), [2e-6, -1e-6, 3e-6]]), (runs, 1))
    truth0 = NavState(np.repeat(s.position[:1], runs, 0), np.repeat(s.velocity[:1], runs, 0),
                      np.repeat(s.quaternion[:1], runs, 0), b_truth[:, :3], b_truth[:, 3:], np.zeros((runs, 3)))
    nav = corrupt_state(truth0, dx0, layout)
    decay = np.exp(-t / tau)[None, :, None]
    nu = traj.specific_force(t, earth_rate)[None] + truth0.ba[:, None] * decay
    om = traj.angular_rate(t, earth_rate)[None] + truth0.bg[:, None] * decay
    model = ErrorStateModel(layout, 0.0, 0.0, 0.0, 0.0, tau, tau, (0.0,) * 3, (tau,) * 3, earth_rate=earth_rate)
    Phi = np.broadcast_to(np.eye(layout.n), (runs, layout.n, layout.n)).copy()
    hist = None
    for k0 in range(0, t.size - 1, sub):
        q_start = nav.q
        nav, f_mean, hist = mechanize(nav, t[k0:k0 + sub + 1], nu[:, k0:k0 + sub + 1], om[:, k0:k0 + sub + 1],
                                      tau, tau, (tau,) * 3, hist, earth_rate=earth_rate)
        T = quat_to_dcm(quat_normalize(q_start + nav.q))  # attitude at mid-step
        step, _ = model.discretize(T, f_mean, sub / rate)
        Phi = step @ Phi
    e = np.exp(-horizon / tau)
    truth = NavState(np.repeat(s.position[-1:], runs, 0), np.repeat(s.velocity[-1:], runs, 0),
                     np.repeat(s.quaternion[-1:], runs, 0), truth0.ba * e, truth0.bg * e, truth0.bm * e)
    nonlinear = error_state(truth, nav, layout)
    linear = (Phi @ dx0[..., None])[..., 0]
    return linear, nonlinear, Phi


def test_table_a5_linear_vs_nonlinear_propagation():
    traj = StraightLevel([1000.0, 0.0, -500.0], 50.0, 0.0, 1.0)  # Table A.1 truth p, v, q
    lin, nl, _ = _propagate(traj, DX_123, 1.0)
    lin, nl = lin[0], nl[0]
    # bias rows: Table A.5, identical linear and nonlinear
    table_bias = [0.0080317, 0.016063, 0.024095, 3.9693e-6, 7.9386e-6, 1.1908e-5, 0.81873, 1.6375, 1.2281]
    np.testing.assert_allclose(lin[9:], table_bias, rtol=5e-5)
    np.testing.assert_allclose(nl[9:], lin[9:], rtol=1e-12, atol=1e-18)
    # p, v, th: linear-vs-nonlinear mismatch no larger than Table A.5's (1.7e-3 m, 3.4e-3 m/s, 5.3e-6 rad)
    assert np.all(np.abs(lin[0:3] - nl[0:3]) < 2e-3)
    assert np.all(np.abs(lin[3:6] - nl[3:6]) < 3.5e-3)
    assert np.all(np.abs(lin[6:9] - nl[6:9]) < 6e-6)
    # and close to Table A.5's linear column (theirs flew the maneuvering path of Fig. A.1)
    table_lin = [1.2027, 2.1446, 3.2835, 0.30566, 0.089675, 0.26791, 0.0099969, 0.020009, 0.030013]
    np.testing.assert_allclose(lin[:9], table_lin, atol=0.03)


#: a planet spinning 100x faster than the Earth (at 40 deg latitude): its terms in Phi over 0.2 s (~1e-3) stand far
#: above the finite-difference tolerance, so a wrong sign or a missing factor 2 fails; the real Earth's would not
FAST_SPIN = 100.0 * 7.292115e-5 * np.array([np.cos(0.7), 0.0, -np.sin(0.7)])


@pytest.mark.parametrize("kind,earth", [("straight", None), ("maneuver", None), ("straight", FAST_SPIN),
                                        ("maneuver", FAST_SPIN)])
def test_F_matches_finite_differences_of_nonlinear_propagation(kind, earth):
    if kind == "straight":
        traj = StraightLevel([1000.0, 0.0, -500.0], 50.0, 0.4, 3.0)
    else:
        traj = None  # set below: the maneuver seen from its turn entry
    horizon = 0.2
    n = L18.n
    # central-difference steps: large enough that rounding of ~1e3 m positions stays below 1e-7
    steps = np.concatenate([[1e-2] * 3, [1e-3] * 3, [1e-5] * 3, [1e-3] * 3, [1e-5] * 3, [1e-2] * 3])
    dx = np.concatenate([np.diag(steps), -np.diag(steps), np.zeros((1, n))])
    if kind == "maneuver":
        offset = Maneuvering.s_turn_climb([0.0, 0.0, -500.0], 50.0, 0.0, 60.0)

        class Shifted(StraightLevel):  # the maneuver seen from t0 = 11 s (turn entry, climb ahead)
            def __init__(self):
                self.duration = 1.0

            def state(self, t):
                return offset.state(np.asarray(t) + 11.0)

            def specific_force(self, t, earth_rate=None):
                return offset.specific_force(np.asarray(t) + 11.0, earth_rate)

            def angular_rate(self, t, earth_rate=None):
                return offset.angular_rate(np.asarray(t) + 11.0, earth_rate)

        traj = Shifted()
    lin, nl, Phi = _propagate(traj, dx, horizon, rate=1000.0, sub=1, earth_rate=earth)
    J = (nl[:n] - nl[n:2 * n]).T / (2 * steps)
    scale = np.maximum(1.0, np.abs(Phi[-1]))
    np.testing.assert_allclose(J / scale, Phi[-1] / scale, atol=2e-6)
    assert np.abs(nl[-1]).max() < 1e-9  # zero error stays zero


def test_closed_form_discretisation_equals_van_loan():
    rng = np.random.default_rng(4)
    T = quat_to_dcm(quat_normalize(rng.standard_normal((5, 4))))
    f = rng.standard_normal((5, 3)) * 3 + [0, 0, -9.81]
    cases = [
        (L18, dict(tau_accel=3600.0, tau_gyro=3600.0, scalar_tau=(300.0, 300.0, 300.0))),
        (L18, dict(tau_accel=0.05, tau_gyro=2.0, scalar_tau=(0.3, 30.0, 1e4))),
        (ErrorStateLayout(), dict(tau_accel=100.0, tau_gyro=50.0, scalar_tau=())),
        (ErrorStateLayout(blocks=("p", "v", "th")), dict(scalar_tau=())),
        (ErrorStateLayout(("b_alt",), blocks=("p", "v", "th", "bg")), dict(tau_gyro=10.0, scalar_tau=(60.0,))),
    ]
    for layout, kw in cases:
        k = len(layout.scalar_biases)
        model = ErrorStateModel(layout, 3e-4, 7e-6, 3e-3, 1.6e-6, scalar_sigma=(0.03,) * k, **kw)
        B = model.B(T)
        taus = [kw.get("tau_accel", 1.0), kw.get("tau_gyro", 1.0), *kw["scalar_tau"]]
        for dt in (0.01, 0.1, 1.0, 10.0):
            if dt / min(taus) > 10:  # the Van Loan reference itself loses accuracy (exp(+dt/tau) terms)
                continue
            P1, Q1 = model.discretize(T, f, dt)
            P2, Q2 = van_loan(model.F(T, f), B @ model.Q() @ np.swapaxes(B, 1, 2), dt)
            np.testing.assert_allclose(P1, P2, rtol=1e-10, atol=1e-12 * max(1.0, dt**3 * 10))
            d = np.sqrt(np.einsum("rii->ri", Q2))
            d = np.where(d > 0, d, 1.0)
            np.testing.assert_allclose(Q1 / (d[:, :, None] * d[:, None, :]), Q2 / (d[:, :, None] * d[:, None, :]), atol=1e-9)


def test_van_loan_phi_is_expm_and_qd_matches_integral():
    from scipy.integrate import quad_vec
    from scipy.linalg import expm

    F = np.array([[0.0, 1.0], [-2.0, -0.3]])
    BQBt = np.array([[0.0, 0.0], [0.0, 0.5]])
    Phi, Qd = van_loan(F, BQBt, 0.7)
    np.testing.assert_allclose(Phi, expm(0.7 * F), rtol=1e-13)
    ref = quad_vec(lambda s: expm(F * s) @ BQBt @ expm(F * s).T, 0.0, 0.7, epsabs=1e-14)[0]
    np.testing.assert_allclose(Qd, ref, rtol=1e-10, atol=1e-15)


def test_fogm_kernels_closed_forms():
    tau, dt = 2.0, 1.5
    x = dt / tau
    phi, G = fogm_kernels(tau, dt)
    np.testing.assert_allclose(phi[0], np.exp(-x), rtol=1e-14)
    np.testing.assert_allclose(phi[1], tau * (1 - np.exp(-x)), rtol=1e-13)
    np.testing.assert_allclose(phi[2], tau * dt - tau**2 * (1 - np.exp(-x)), rtol=1e-12)
    np.testing.assert_allclose(phi[3], tau * dt**2 / 2 - tau**2 * dt + tau**3 * (1 - np.exp(-x)), rtol=1e-11)
    np.testing.assert_allclose(G[0, 0], tau / 2 * (1 - np.exp(-2 * x)), rtol=1e-13)
    # large tau (3600 s, 0.1 s): phi_k -> dt^k/k!, no cancellation
    phi, G = fogm_kernels(3600.0, 0.1)
    np.testing.assert_allclose(phi[3], 0.1**3 / 6 * (1 - 0.1 / 3600 / 4), rtol=1e-9)
    np.testing.assert_allclose(G[3, 3], 0.1**7 / 252, rtol=1e-4)


def test_Q_and_B_follow_eq_3_19_and_3_11():
    model = ErrorStateModel(L18, 3e-4, 7e-6, 3e-3, 1.6e-6, 3600.0, 1800.0, (0.1, 0.2, 0.3), (10.0, 20.0, 30.0))
    q = np.diag(model.Q())
    np.testing.assert_allclose(q[:3], 9e-8)
    np.testing.assert_allclose(q[3:6], 4.9e-11)
    np.testing.assert_allclose(q[6:9], 2 * 9e-6 / 3600.0)
    np.testing.assert_allclose(q[9:12], 2 * 1.6e-6**2 / 1800.0)
    np.testing.assert_allclose(q[12:], [2 * 0.01 / 10, 2 * 0.04 / 20, 2 * 0.09 / 30])
    T = quat_to_dcm(quat_normalize(np.array([[0.9, 0.1, -0.2, 0.3]])))
    B = model.B(T)[0]
    np.testing.assert_allclose(B[3:6, 0:3], -T[0])
    np.testing.assert_allclose(B[6:9, 3:6], T[0])
    np.testing.assert_allclose(B[9:, 6:], np.eye(9))
    assert model.noise_names()[-1] == "w_b_rate"


@pytest.mark.parametrize("tau", [1e-300, 1e-9, 1e-4, 0.01])
def test_fogm_kernels_short_tau_is_fast_and_exact(tau):
    """tau << dt (nearly white bias): bounded cost, and the Gram entries equal their closed forms
    G00 = tau/2 (1 - e^-2x), G01 = tau^2 (e1 - e2/2), G11 = tau^2 (dt - 2 tau e1 + tau e2/2),
    e1 = 1 - e^-x, e2 = 1 - e^-2x, x = dt/tau (integrals of phi0 = e^-s/tau, phi1 = tau(1 - e^-s/tau))."""
    import time

    dt = 0.1
    fogm_kernels.cache_clear()
    t0 = time.perf_counter()
    phi, G = fogm_kernels(tau, dt)
    assert time.perf_counter() - t0 < 1.0
    x = dt / tau
    e1, e2 = -np.expm1(-x), -np.expm1(-2 * x)
    np.testing.assert_allclose(G[0, 0], tau / 2 * e2, rtol=1e-12)
    np.testing.assert_allclose(G[0, 1], tau**2 * (e1 - e2 / 2), rtol=1e-12)
    np.testing.assert_allclose(G[1, 1], tau**2 * (dt - 2 * tau * e1 + tau * e2 / 2), rtol=1e-12)
    np.testing.assert_allclose(phi[2], tau * dt - tau**2 * e1, rtol=1e-12)
    assert np.all(np.isfinite(G))
