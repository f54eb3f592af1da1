"""Telemetry measurements (thesis eqs. 3.13-3.17): H against central differences, linear vs
nonlinear residuals (Table A.6), simulated noise statistics, validation."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.filters import ErrorStateLayout, apply_feedback
from sarnav.ins import NavState
from sarnav.measurements.base import stack_predictions
from sarnav.measurements.telemetry import AltimeterMeasurement, RangeMeasurement, RangeRateMeasurement
from sarnav.rotations import quat_normalize

L = ErrorStateLayout(("b_alt", "b_range", "b_rate"))
TARGET = np.array([1000.0, 0.0, 0.0])


def _meas():
    return [AltimeterMeasurement(0.0667, L), RangeMeasurement(TARGET, 0.0667, L), RangeRateMeasurement(TARGET, 0.0667, L)]


def _nav(rng, runs=4):
    p = np.array([0.0, -200.0, -500.0]) + rng.uniform(-300, 300, (runs, 3))
    v = np.array([50.0, 0.0, 0.0]) + rng.uniform(-10, 10, (runs, 3))
    return NavState(p, v, quat_normalize(rng.standard_normal((runs, 4))), 0.01 * rng.standard_normal((runs, 3)),
                    1e-5 * rng.standard_normal((runs, 3)), 0.1 * rng.standard_normal((runs, 3)))


@pytest.mark.parametrize("i", [0, 1, 2], ids=["alt", "range", "rate"])
def test_H_matches_central_differences(i):
    rng = np.random.default_rng(i)
    nav = _nav(rng)
    m = _meas()[i]
    _, H, _ = m.predict(nav)
    eps = 1e-4
    J = np.empty_like(H)
    for j in range(L.n):
        e = np.zeros((nav.runs, L.n))
        e[:, j] = eps
        zp = m.predict(apply_feedback(nav, e, L))[0]  # truth = l(x_hat, dx): z(truth) - z_hat ~ H dx
        zm = m.predict(apply_feedback(nav, -e, L))[0]
        J[:, :, j] = (zp - zm) / (2 * eps)
    scale = np.linalg.norm(H, axis=-1, keepdims=True)
    np.testing.assert_allclose(J / scale, H / scale, atol=1e-6)
    assert np.all(H[:, 0, L.index(m.bias)] == 1.0)


def test_table_a6_linear_vs_nonlinear_residuals():
    """The "1,2,3" error of Table A.5/A.6: altitude residual exactly linear (-2), range and range
    rate within their second-order bounds (Table A.6: 2.5e-3 m and 5.7e-4 m/s at ~1 km)."""
    nav = NavState(np.array([[0.0, -200.0, -500.0]]), np.array([[50.0, 0.0, 0.0]]), np.array([[1.0, 0, 0, 0]]),
                   np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)))
    dx = np.zeros((1, L.n))
    dx[0, 0:6] = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]
    dx[0, 15:18] = [1.0, 2.0, 1.5]
    truth = apply_feedback(nav, dx, L)
    z_hat, H, _ = stack_predictions(_meas(), nav)
    z_true, _, _ = stack_predictions(_meas(), truth)
    nonlinear = (z_true - z_hat)[0]
    linear = (H @ dx[..., None])[0, :, 0]
    assert nonlinear[0] == pytest.approx(-2.0, abs=1e-12) and linear[0] == pytest.approx(-2.0, abs=1e-15)
    d = np.linalg.norm(TARGET - nav.p[0])
    dp, dv, v = np.linalg.norm(dx[0, :3]), np.linalg.norm(dx[0, 3:6]), 50.0
    assert abs(nonlinear[1] - linear[1]) <= dp**2 / d  # |second derivative of |d|| <= 1/|d|
    assert abs(nonlinear[2] - linear[2]) <= (dp * dv + 3 * v * dp**2 / d) / d
    assert abs(nonlinear[1] - linear[1]) > 1e-5  # really nonlinear: the bound is not vacuous


def test_range_rate_sign_and_values():
    nav = NavState(np.array([[0.0, 0.0, 0.0], [2000.0, 0.0, 0.0]]), np.array([[50.0, 0.0, 0.0]] * 2),
                   np.array([[1.0, 0, 0, 0]] * 2), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
    z, _, _ = RangeRateMeasurement(TARGET, 0.1, L).predict(nav)
    np.testing.assert_allclose(z[:, 0], [-50.0, 50.0])  # closing, then opening
    z, _, _ = RangeMeasurement(TARGET, 0.1, L).predict(nav)
    np.testing.assert_allclose(z[:, 0], [1000.0, 1000.0])


def test_simulated_measurements_have_the_stated_noise_and_bias():
    runs = 4000
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(9).spawn(runs)]
    truth = NavState(np.tile([0.0, -200.0, -500.0], (runs, 1)), np.tile([50.0, 0.0, 0.0], (runs, 1)),
                     np.tile([1.0, 0, 0, 0], (runs, 1)), np.zeros((runs, 3)), np.zeros((runs, 3)), np.zeros((runs, 3)))
    sigma = 0.2 / 3
    for m, h in zip(_meas(), [500.0, np.sqrt(1000**2 + 200**2 + 500**2), -50.0 * 1000 / np.sqrt(1000**2 + 200**2 + 500**2)]):
        z = m.simulate(truth, np.full(runs, 0.05), rngs)[:, 0]
        e = z - h - 0.05
        assert abs(e.mean()) < 4 * sigma / np.sqrt(runs)
        assert abs(e.std() - sigma) < 4 * sigma / np.sqrt(2 * runs)


def test_stack_and_validation():
    rng = np.random.default_rng(5)
    nav = _nav(rng, runs=2)
    z, H, R = stack_predictions(_meas(), nav)
    assert z.shape == (2, 3) and H.shape == (2, 3, 18)
    np.testing.assert_allclose(R[0], np.eye(3) * 0.0667**2)
    with pytest.raises(ConfigError, match="target.position_ned"):
        RangeMeasurement([1.0, np.nan, 0.0], 0.1, L)
    with pytest.raises(ConfigError, match="sigma"):
        RangeRateMeasurement(TARGET, 0.0, L)
    with pytest.raises(KeyError):
        AltimeterMeasurement(0.1, ErrorStateLayout())
