"""SAR image-shift measurements (paper eqs. 47-56): zero-Doppler semantics, the second-order remainder of the
cross-range lever, the delayed-state mapping through filters.delayed, validation. Jacobians, Hessians and noise
statistics of every model: tests/measurements/test_contract.py."""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters import ErrorStateLayout, apply_feedback, delayed, second_order, stack_predictions
from sarnav.measurements.sar import SarCrossRangeMeasurement, SarRangeMeasurement
from sarnav.trajectory.sampled import closest_approach
from helpers import level_nav

L = ErrorStateLayout(("b_alt", "b_range", "b_cross"))
S = L.n
P_TARG = np.array([120.0, 1850.0, 0.0])  # target 1.85 km east of the track, on the ground
P_HAT = np.array([118.0, 3.0, -1000.0])  # vehicle at 1 km altitude
V_HAT = np.array([10.0, 0.07, -0.02])


def test_range_value_bias_and_noise():
    pred = SarRangeMeasurement(P_TARG, 0.25, L).predict(level_nav(P_HAT, V_HAT, [0.0, 0.1, 0.1]))
    assert pred.z_hat[0, 0] == pytest.approx(np.linalg.norm(P_TARG - P_HAT) + 0.1, rel=1e-15)
    assert pred.R[0, 0, 0] == pytest.approx(0.0625)
    assert pred.H[0, 0, L.index("b_range")] == 1.0 and np.all(pred.H[0, 0, 3:16] == 0)


@pytest.mark.parametrize("model", ["zero-doppler", "paper"])
def test_cross_range_rows(model):
    kw = dict(u_c=V_HAT[None], r_orig=(P_HAT - [5.0, 0, 0])[None]) if model == "paper" else {}
    H = SarCrossRangeMeasurement(P_TARG, 0.25, L, model=model, **kw).predict(level_nav(P_HAT, V_HAT)).H[0, 0]
    assert H[L.index("b_cross")] == 1.0
    if model == "paper":  # eq. 56: position row and bias only
        assert np.all(H[3:17] == 0)
    else:  # the velocity lever: (p - p_targ)_perp / V, ~ -185 s in the east column here
        assert H[4] == pytest.approx(-1847.0 / np.linalg.norm(V_HAT), rel=2e-2)


def test_zero_doppler_truth_is_zero_at_toc_and_residual_is_azimuth_geolocation_shift():
    # truth flies north at 10 m/s; the estimated velocity has a cross-track error dv_E
    times = np.linspace(0.0, 30.0, 3001)
    p_true = np.stack([10.0 * times, np.zeros_like(times), -1000.0 * np.ones_like(times)], 1)
    eta0, r0, p0 = closest_approach(P_TARG, times, p_true)
    assert eta0 == pytest.approx(12.0, abs=1e-9)  # 120 m / 10 m/s
    m = SarCrossRangeMeasurement(P_TARG, 0.25, L)
    assert m.value(0, p0, [10.0, 0, 0]) == pytest.approx(0.0, abs=1e-9)
    dv = 0.05
    pred = m.predict(level_nav(p0, [10.0, -dv, 0.0]))
    # thesis §4.3.2 / extraction §11.5: a cross-track velocity error moves the target by y_t dv / V
    assert pred.z_hat[0, 0] == pytest.approx(1850.0 * dv / np.hypot(10.0, dv), rel=1e-12)
    # truth z = 0, so the residual -z_hat must equal H dx with dx = truth - estimate (dv_E = +dv)
    assert (pred.H[0] @ np.r_[0, 0, 0, 0, dv, 0, np.zeros(12)])[0] == pytest.approx(-pred.z_hat[0, 0], rel=2e-3)


def test_delayed_state_jacobian_is_the_toc_jacobian_through_the_back_transition():
    """z = h(x(t_c)) with dx(t_c) = Phi^-1 dx(t_k) (no process noise): H Phi^-1 against central differences."""
    rng = np.random.default_rng(5)
    phi_inv = np.eye(S) + 0.05 * rng.standard_normal((S, S))
    nav = level_nav(P_HAT, V_HAT)
    for m in (SarRangeMeasurement(P_TARG, 0.25, L), SarCrossRangeMeasurement(P_TARG, 0.25, L)):
        H = delayed.map_to_update_epoch(m.predict(nav), phi_inv[None], np.zeros((1, S, S))).H[0, 0]
        J, step = np.zeros(S), 1e-3
        for j in range(S):
            zs = [m.predict(apply_feedback(nav, (phi_inv @ (sgn * step * np.eye(S)[j]))[None], L)).z_hat[0, 0]
                  for sgn in (1, -1)]
            J[j] = (zs[0] - zs[1]) / (2 * step)
        np.testing.assert_allclose(H, J, rtol=0, atol=1e-6 * np.max(np.abs(J)))


def test_zero_doppler_remainder_is_the_speed_scaled_lever_and_second_order_terms_predict_it():
    """h(x) - h(x_hat) - H dx = -(l_perp . dv)(u . dv) / V^2 to leading order: an along-track speed error
    scales the 185-s lever. The Gaussian second-order terms give its mean and variance (Monte Carlo)."""
    m = SarCrossRangeMeasurement(P_TARG, 0.25, L)
    pred = m.predict(level_nav(P_HAT, V_HAT))
    z0, H = pred.z_hat[0, 0], pred.H[0, 0]
    dv = np.array([0.3, 0.05, 0.0])
    exact = m.value(0, P_HAT, V_HAT + dv) - z0 - H[3:6] @ dv
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
    corrected = second_order.with_second_order(pred, P[None])
    dz, var = corrected.z_hat[0, 0] - z0, corrected.R[0, 0, 0] - pred.R[0, 0, 0]
    dx = rng.multivariate_normal(np.zeros(6), P6, 20000)
    h = np.array([m.value(0, P_HAT + d[:3], V_HAT + d[3:]) for d in dx])
    rem = h - z0 - dx @ H[:6]
    assert abs(rem.mean() - dz) < 4 * rem.std() / np.sqrt(rem.size) + 0.02 * abs(dz)
    assert rem.var() == pytest.approx(var, rel=0.1)
    # stacked with the range: the cross-range terms are unchanged, the covariance block is symmetric
    both = stack_predictions([SarRangeMeasurement(P_TARG, 0.25, L).predict(level_nav(P_HAT, V_HAT)), pred])
    stacked = second_order.with_second_order(both, P[None])
    assert stacked.z_hat[0, 1] - z0 == pytest.approx(dz) and stacked.R[0, 1, 1] - 0.0625 == pytest.approx(var)
    np.testing.assert_allclose(stacked.R[0], stacked.R[0].T)
    with pytest.raises(InputDataError, match="^P"):
        second_order.with_second_order(pred, np.eye(3)[None])


def test_bad_input_names_the_field():
    with pytest.raises(ConfigError, match="sar.range_sigma"):
        SarRangeMeasurement(P_TARG, -1.0, L)
    with pytest.raises(KeyError):
        SarRangeMeasurement(P_TARG, 0.25, ErrorStateLayout(("b_alt",)))
    with pytest.raises(ConfigError, match="sar.cross_range_model"):
        SarCrossRangeMeasurement(P_TARG, 0.25, L, model="doppler")
    with pytest.raises(ConfigError, match="sar.cross_range_model"):
        SarCrossRangeMeasurement(P_TARG, 0.25, L, model="paper")
    with pytest.raises(InputDataError, match="p_targ"):
        SarRangeMeasurement([1.0, np.nan, 0.0], 0.25, L)
    with pytest.raises(InputDataError, match="v_hat"):
        SarCrossRangeMeasurement(P_TARG, 0.25, L).predict(level_nav(P_HAT, [0.0, 0.0, 0.0]))
