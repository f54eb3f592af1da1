"""IMU presets of Sun (2022) Tables 5.2 and 5.4 with the unit decisions of gap G23, and the gnss-ins-sim
bias-stability semantics (white noise per sample) reproduced by a very short FOGM correlation time."""

import numpy as np
import pytest

from sarnav.sensors import imu_grade
from sarnav.simulation.multi_imu import WHITE_BIAS_TAU, gnss_ins_sim_imu


def test_novatel_isa_100c_preset():
    g = imu_grade("novatel-isa-100c")
    assert g.vrw * 60.0 == pytest.approx(100e-6 * 9.81 * 60.0)  # "100 ug/sqrt(hr)" read as 100 ug/sqrt(Hz)
    assert g.accel_bias == pytest.approx(1250e-6 * 9.81)  # 1250 ug, as printed
    assert np.degrees(g.arw) * 60.0 == pytest.approx(0.012)
    assert np.degrees(g.gyro_bias) * 3600.0 == pytest.approx(0.5)


def test_adis16465_preset():
    g = imu_grade("adis16465")
    assert g.vrw * 60.0 == pytest.approx(0.012)
    assert g.accel_bias == pytest.approx(3.6e-3)  # as printed (m/s^2)
    assert np.degrees(g.arw) * 60.0 == pytest.approx(0.15)
    assert np.degrees(g.gyro_bias) * 3600.0 == pytest.approx(2.0)


def test_gnss_ins_sim_bias_stability_is_white_per_sample():
    """gnss-ins-sim draws a bias stability with infinite correlation time as N(0, sigma_b^2) at every sample:
    sample variance of the error = sigma_b^2 + VRW^2 / dt, no correlation between samples."""
    model = gnss_ins_sim_imu("adis16465", 100.0)
    assert WHITE_BIAS_TAU < 1e-6
    rngs = [np.random.default_rng(s) for s in range(20)]
    ba, bg = model.initial_biases(rngs)
    nu, *_ = model.measure(np.zeros((5000, 3)), np.zeros((5000, 3)), ba, bg, rngs)
    g = imu_grade("adis16465")
    var = g.accel_bias**2 + g.vrw**2 * 100.0
    assert nu.var() == pytest.approx(var, rel=0.02)
    lag1 = np.mean(nu[:, 1:] * nu[:, :-1]) / nu.var()
    assert abs(lag1) < 0.01
