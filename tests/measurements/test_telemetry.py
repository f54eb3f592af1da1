"""Telemetry measurements (thesis eqs. 3.13-3.17): linear vs nonlinear residuals (Table A.6), values, stacking and
validation. Jacobians, Hessians and noise statistics: tests/measurements/test_contract.py."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.filters import ErrorStateLayout, apply_feedback
from sarnav.ins import NavState
from sarnav.filters import stack_predictions
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


def test_table_a6_linear_vs_nonlinear_residuals():
    """The "1,2,3" error of Table A.5/A.6: altitude residual exactly linear (-2), range and range
    rate within their second-order bounds (Table A.6: 2.5e-3 m and 5.7e-4 m/s at ~1 km)."""
    nav = NavState(np.array([[0.0, -200.0, -500.0]]), np.array([[50.0, 0.0, 0.0]]), np.array([[1.0, 0, 0, 0]]),
                   np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)))
    dx = np.zeros((1, L.n))
    dx[0, 0:6] = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3]
    dx[0, 15:18] = [1.0, 2.0, 1.5]
    truth = apply_feedback(nav, dx, L)
    pred = stack_predictions([m.predict(nav) for m in _meas()])
    z_hat, H = pred.z_hat, pred.H
    z_true = stack_predictions([m.predict(truth) for m in _meas()]).z_hat
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
    z = RangeRateMeasurement(TARGET, 0.1, L).predict(nav).z_hat
    np.testing.assert_allclose(z[:, 0], [-50.0, 50.0])  # closing, then opening
    z = RangeMeasurement(TARGET, 0.1, L).predict(nav).z_hat
    np.testing.assert_allclose(z[:, 0], [1000.0, 1000.0])


def test_stack_and_validation():
    rng = np.random.default_rng(5)
    nav = _nav(rng, runs=2)
    pred = stack_predictions([m.predict(nav) for m in _meas()])
    assert pred.z_hat.shape == (2, 3) and pred.H.shape == (2, 3, 18) and pred.names == ("alt", "range", "rate")
    np.testing.assert_allclose(pred.R[0], np.eye(3) * 0.0667**2)
    with pytest.raises(ConfigError, match="target.position_ned"):
        RangeMeasurement([1.0, np.nan, 0.0], 0.1, L)
    with pytest.raises(ConfigError, match="sigma"):
        RangeRateMeasurement(TARGET, 0.0, L)
    with pytest.raises(KeyError):
        AltimeterMeasurement(0.1, ErrorStateLayout())
