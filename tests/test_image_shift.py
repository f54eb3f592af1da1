import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.measurements import image_shift as ims

S = 18  # paper layout: p v th ba bg b_alt b_range b_cross
B_RANGE, B_CROSS = 16, 17
P_TARG = np.array([120.0, 1850.0, 0.0])  # target 1.85 km east of the track, on the ground
P_HAT = np.array([118.0, 3.0, -1000.0])  # vehicle at 1 km altitude
V_HAT = np.array([10.0, 0.07, -0.02])


def _fd_jacobian(meas, p, v, b, phi=None, step=1e-3):
    """Central finite differences of h(x_hat (+) phi dx) w.r.t. the error state dx (truth = est + error)."""
    phi = np.eye(S) if phi is None else phi
    J = np.zeros((1, S))
    for j in range(S):
        rows = []
        for sgn in (+1, -1):
            dx = phi @ (sgn * step * np.eye(S)[j])
            rows.append(meas.model(p + dx[0:3], v + dx[3:6], b + dx[meas.bias_index]))
        J[0, j] = (rows[0] - rows[1]) / (2 * step)
    return J


def _assert_jac(H, J):
    scale = np.max(np.abs(J))
    np.testing.assert_allclose(H, J, rtol=0, atol=1e-6 * scale)


def test_range_jacobian_matches_central_differences():
    m = ims.RangeMeasurement(P_TARG, 0.25, S, B_RANGE)
    z, H, R = m.predict(P_HAT, V_HAT, 0.1)
    assert z[0] == pytest.approx(np.linalg.norm(P_TARG - P_HAT) + 0.1, rel=1e-15)
    _assert_jac(H, _fd_jacobian(m, P_HAT, V_HAT, 0.1))
    assert R[0, 0] == pytest.approx(0.0625)
    assert H[0, B_RANGE] == 1.0 and np.all(H[0, 3:16] == 0)


@pytest.mark.parametrize("model", ["zero-doppler", "paper"])
def test_cross_range_jacobian_matches_central_differences(model):
    kw = {}
    if model == "paper":
        kw = dict(u_c=V_HAT, r_orig=P_HAT - [5.0, 0, 0])
    m = ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS, model_name=model, **kw)
    z, H, R = m.predict(P_HAT, V_HAT, -0.05)
    _assert_jac(H, _fd_jacobian(m, P_HAT, V_HAT, -0.05))
    assert H[0, B_CROSS] == 1.0
    if model == "paper":  # eq. 56: position row and bias only
        assert np.all(H[0, 3:17] == 0)
    else:  # the velocity lever: (p - p_targ)_perp / V, ~ -185 s in the east column here
        assert H[0, 4] == pytest.approx(-1847.0 / np.linalg.norm(V_HAT), rel=2e-2)


@pytest.mark.parametrize("cls", ["range", "cross"])
def test_jacobian_with_back_propagation(cls):
    rng = np.random.default_rng(5)
    phi = np.eye(S) + 0.05 * rng.standard_normal((S, S))
    if cls == "range":
        m = ims.RangeMeasurement(P_TARG, 0.25, S, B_RANGE, phi_back=phi)
    else:
        m = ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS, phi_back=phi)
    _, H, _ = m.predict(P_HAT, V_HAT, 0.0)
    _assert_jac(H, _fd_jacobian(m, P_HAT, V_HAT, 0.0, phi=phi))


def test_zero_doppler_truth_is_zero_at_toc_and_residual_is_azimuth_geolocation_shift():
    # truth flies north at 10 m/s; estimated velocity has a cross-track error dv_E
    times = np.linspace(0.0, 30.0, 3001)
    p_true = np.stack([10.0 * times, np.zeros_like(times), -1000.0 * np.ones_like(times)], 1)
    eta0, r0, p0 = ims.closest_approach(P_TARG, times, p_true)
    assert eta0 == pytest.approx(12.0, abs=1e-9)  # 120 m / 10 m/s
    assert r0 == pytest.approx(np.hypot(1850.0, 1000.0), rel=1e-12)
    m = ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS)
    assert m.model(p0, [10.0, 0, 0]) == pytest.approx(0.0, abs=1e-9)
    dv = 0.05
    z_hat, H, _ = m.predict(p0, [10.0, -dv, 0.0], 0.0)
    # thesis §4.3.2 / extraction §11.5: a cross-track velocity error moves the target by y_t dv / V
    assert z_hat[0] == pytest.approx(1850.0 * dv / np.hypot(10.0, dv), rel=1e-12)
    # truth z = 0, so the residual -z_hat must equal H dx with dx = truth - estimate (dv_E = +dv)
    assert (H @ np.r_[0, 0, 0, 0, dv, 0, np.zeros(12)])[0] == pytest.approx(0.0 - z_hat[0], rel=2e-3)


def test_closest_approach_parabola_is_exact_for_constant_velocity_between_samples():
    times = np.arange(0.0, 1.0, 0.01)
    v = np.array([9.0, 1.5, -0.3])
    pos = np.array([0.0, 0.0, -1000.0]) + times[:, None] * v
    t_true = 0.4237
    # target orthogonal to v at t_true
    perp = np.cross(v, [0, 0, 1.0])
    targ = pos[0] + v * t_true + 2000.0 * perp / np.linalg.norm(perp)
    eta0, r0, _ = ims.closest_approach(targ, times, pos)
    assert eta0 == pytest.approx(t_true, abs=1e-9)
    assert r0 == pytest.approx(2000.0, rel=1e-12)


def test_oracle_statistics_and_reproducibility():
    rm = ims.RangeMeasurement(P_TARG, 0.25, S, B_RANGE)
    cm = ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS)
    p0, v0 = np.array([120.0, 0.0, -1000.0]), np.array([10.0, 0.0, 0.0])
    rng = np.random.default_rng(np.random.SeedSequence(7))
    z = np.array([ims.synthesize_oracle(rm, cm, p0, v0, 0.1, -0.2, rng) for _ in range(4000)])
    se = 0.25 / np.sqrt(4000)
    assert np.mean(z[:, 0]) == pytest.approx(np.hypot(1850.0, 1000.0) + 0.1, abs=4 * se)
    assert np.mean(z[:, 1]) == pytest.approx(-0.2, abs=4 * se)
    assert np.std(z, axis=0) == pytest.approx([0.25, 0.25], rel=0.05)
    rng2 = np.random.default_rng(np.random.SeedSequence(7))
    assert np.array_equal(z[0], ims.synthesize_oracle(rm, cm, p0, v0, 0.1, -0.2, rng2))


def test_stack_is_block_diagonal():
    rm = ims.RangeMeasurement(P_TARG, 0.25, S, B_RANGE)
    cm = ims.CrossRangeMeasurement(P_TARG, 0.5, S, B_CROSS)
    z, H, R = ims.stack([rm.predict(P_HAT, V_HAT), cm.predict(P_HAT, V_HAT)])
    assert z.shape == (2,) and H.shape == (2, S)
    np.testing.assert_array_equal(R, np.diag([0.0625, 0.25]))


def test_bad_input_names_the_field():
    with pytest.raises(ConfigError, match="sar.range_sigma"):
        ims.RangeMeasurement(P_TARG, -1.0, S, B_RANGE)
    with pytest.raises(ConfigError, match="bias_index"):
        ims.RangeMeasurement(P_TARG, 0.25, S, 18)
    with pytest.raises(ConfigError, match="sar.cross_range_model"):
        ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS, model_name="doppler")
    with pytest.raises(InputDataError, match="p_targ"):
        ims.RangeMeasurement([1.0, np.nan, 0.0], 0.25, S, B_RANGE)
    with pytest.raises(InputDataError, match="phi_back"):
        ims.RangeMeasurement(P_TARG, 0.25, S, B_RANGE, phi_back=np.eye(3))
    with pytest.raises(InputDataError, match="v_hat"):
        ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS).predict(P_HAT, [0.0, 0.0, 0.0])


def _fd_hessian(meas, p, v, step=1e-2):
    """Central second differences of h(x_hat + dx) w.r.t. the position and velocity errors (6 x 6)."""
    def h(dx):
        return meas.model(p + dx[0:3], v + dx[3:6], 0.0)
    A = np.zeros((6, 6))
    E = step * np.eye(6)
    for i in range(6):
        for j in range(6):
            A[i, j] = (h(E[i] + E[j]) - h(E[i] - E[j]) - h(-E[i] + E[j]) + h(-E[i] - E[j])) / (4 * step**2)
    return A


@pytest.mark.parametrize("cls", ["range", "cross"])
def test_hessian_matches_second_differences(cls):
    if cls == "range":
        m = ims.RangeMeasurement(P_TARG, 0.25, S, B_RANGE)
    else:
        m = ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS)
    A = m.hessian(P_HAT, V_HAT)
    assert A.shape == (S, S) and np.allclose(A, A.T)
    assert np.all(A[6:] == 0) and np.all(A[:, 6:] == 0)
    J = _fd_hessian(m, P_HAT, V_HAT)
    np.testing.assert_allclose(A[:6, :6], J, rtol=0, atol=1e-4 * np.max(np.abs(J)))
    paper = ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS, model_name="paper", u_c=V_HAT, r_orig=P_HAT)
    assert np.all(paper.hessian(P_HAT, V_HAT) == 0)


def test_zero_doppler_remainder_is_the_speed_scaled_lever_and_second_order_terms_predict_it():
    """h(x) - h(x_hat) - H dx = -(l_perp . dv)(u . dv) / V^2 to leading order: an along-track speed error
    scales the 185-s lever. The Gaussian second-order terms give its mean and variance (Monte Carlo)."""
    m = ims.CrossRangeMeasurement(P_TARG, 0.25, S, B_CROSS)
    z0, H, _ = m.predict(P_HAT, V_HAT, 0.0)
    dv = np.array([0.3, 0.05, 0.0])
    exact = m.model(P_HAT, V_HAT + dv) - z0[0] - H[0, 3:6] @ dv
    l = P_HAT - P_TARG
    u = V_HAT / np.linalg.norm(V_HAT)
    lp = l - u * (u @ l)
    assert exact == pytest.approx(-(lp @ dv) * (u @ dv) / np.linalg.norm(V_HAT) ** 2, rel=0.1)
    rng = np.random.default_rng(11)
    sd = np.array([2.0, 0.3, 0.5, 0.2, 0.04, 0.07])
    Cc = 0.6 ** np.abs(np.subtract.outer(np.arange(6), np.arange(6)))  # correlated p and v errors
    P6 = Cc * np.outer(sd, sd)
    P = np.zeros((S, S))
    P[:6, :6] = P6
    dz, var = m.second_order(P_HAT, V_HAT, P)
    dx = rng.multivariate_normal(np.zeros(6), P6, 20000)
    h = np.array([m.model(P_HAT + d[:3], V_HAT + d[3:], 0.0) for d in dx])
    rem = h - z0[0] - dx @ H[0, :6]
    assert abs(rem.mean() - dz) < 4 * rem.std() / np.sqrt(rem.size) + 0.02 * abs(dz)
    assert rem.var() == pytest.approx(var, rel=0.1)
    # stacked terms: the diagonal reproduces the single-measurement ones
    r = ims.RangeMeasurement(P_TARG, 0.25, S, B_RANGE)
    dzs, C = ims.second_order_terms([r.hessian(P_HAT), m.hessian(P_HAT, V_HAT)], P)
    assert dzs[1] == pytest.approx(dz) and C[1, 1] == pytest.approx(var)
    assert dzs[0] == pytest.approx(r.second_order(P_HAT, V_HAT, P)[0]) and np.allclose(C, C.T)
    with pytest.raises(InputDataError, match="P_toc"):
        m.second_order(P_HAT, V_HAT, np.eye(3))
