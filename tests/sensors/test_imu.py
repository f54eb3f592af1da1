"""IMU error model: presets, white-noise and Gauss-Markov statistics against theory (seeded)."""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.sensors import IMU_GRADES, ImuGrade, ImuModel, fogm_coefficients, fogm_path, imu_grade
from helpers import spawn_rngs


def test_tactical_preset_in_si():
    # extraction seed-000 §12.2: 1-sigma SI of thesis Table 3.2 tactical row (g = 9.81)
    g = IMU_GRADES["tactical"]
    assert g.vrw == pytest.approx(0.02 / 60.0, rel=1e-12)  # 0.06/3 m/s/sqrt(hr)
    assert g.accel_bias == pytest.approx(3.27e-3, rel=1e-12)
    assert g.arw == pytest.approx(np.radians(0.07 / 3) / 60.0, rel=1e-12)
    assert g.gyro_bias == pytest.approx(np.radians(1.0 / 3) / 3600.0, rel=1e-12)
    c, n = IMU_GRADES["consumer"], IMU_GRADES["navigation"]
    for f in ("vrw", "accel_bias", "arw", "gyro_bias"):
        assert getattr(c, f) == pytest.approx(10 * getattr(g, f), rel=1e-12)
        assert getattr(n, f) == pytest.approx(0.1 * getattr(g, f), rel=1e-12)
    p = IMU_GRADES["nav-paper-tactical"]
    assert p.vrw == pytest.approx(0.1 / 3 / 60.0, rel=1e-12)  # NAVIGATION paper Table 2
    with pytest.raises(ConfigError, match="imu.grade"):
        imu_grade("military")


def test_white_noise_std_matches_sigma_over_root_dt():
    grade = ImuGrade("t", vrw=1e-3, accel_bias=0.0, arw=2e-5, gyro_bias=0.0)
    imu = ImuModel(grade, rate_hz=200.0, tau_accel=100.0, tau_gyro=100.0)
    n = 20000
    rngs = spawn_rngs(4, 1)
    z = np.zeros((n, 3))
    nu, om, *_ = imu.measure(z, z, np.zeros((4, 3)), np.zeros((4, 3)), rngs)
    N = nu.size
    for x, sig in ((nu, 1e-3), (om, 2e-5)):
        expected = sig * np.sqrt(200.0)
        s = x.std()
        # standard error of a sample std: sigma / sqrt(2 N); allow 4 standard errors
        assert abs(s - expected) < 4 * expected / np.sqrt(2 * N)
        assert abs(x.mean()) < 4 * expected / np.sqrt(N)


def test_gauss_markov_steady_state_and_autocorrelation():
    sigma, tau, dt = 0.5, 2.0, 0.1
    phi, drive = fogm_coefficients(sigma, tau, dt)
    assert phi == pytest.approx(np.exp(-0.05)) and drive == pytest.approx(sigma * np.sqrt(1 - np.exp(-0.1)))
    rng = np.random.default_rng(7)
    runs, n = 400, 400
    b0 = sigma * rng.standard_normal((runs, 1))  # started from N(0, sigma^2): stationary from k = 0
    path, _ = fogm_path(b0, rng.standard_normal((runs, n, 1)), phi, drive)
    x = path[..., 0]
    var = x.var(axis=0).mean()
    # each column's variance has standard error sigma^2 sqrt(2/runs); the mean over n correlated
    # columns is no better than about sigma^2 sqrt(2/runs) * sqrt(2 tau/(n dt)) -> use that bound x 4
    se = sigma**2 * np.sqrt(2.0 / runs) * np.sqrt(2 * tau / (n * dt))
    assert abs(var - sigma**2) < 4 * se
    for lag in (1, 5, 20):
        r = np.mean(x[:, lag:] * x[:, :-lag]) / sigma**2
        theory = np.exp(-lag * dt / tau)
        se_r = np.sqrt((1 + theory**2) / runs) * np.sqrt(2 * tau / ((n - lag) * dt))
        assert abs(r - theory) < 4 * se_r


def test_gauss_markov_recursion_matches_explicit_loop():
    rng = np.random.default_rng(3)
    w = rng.standard_normal((2, 50, 3))
    b0 = rng.standard_normal((2, 3))
    phi, drive = np.array([0.9, 0.5, 0.99]), np.array([0.1, 0.2, 0.3])
    path, nxt = fogm_path(b0, w, phi, drive)
    b = b0.copy()
    for k in range(50):
        np.testing.assert_allclose(path[:, k], b, rtol=1e-13, atol=1e-15)
        b = phi * b + drive * w[:, k]
    np.testing.assert_allclose(nxt, b, rtol=1e-13)


def test_initial_biases_have_steady_state_sigma_and_runs_are_independent():
    imu = ImuModel(IMU_GRADES["consumer"], 100.0, 3600.0, 3600.0)
    ba, bg = imu.initial_biases(spawn_rngs(3000, 11))
    g = IMU_GRADES["consumer"]
    n = ba.size
    assert abs(ba.std() - g.accel_bias) < 4 * g.accel_bias / np.sqrt(2 * n)
    assert abs(bg.std() - g.gyro_bias) < 4 * g.gyro_bias / np.sqrt(2 * n)
    # a run's draws depend only on its own generator
    ba1, _ = imu.initial_biases(spawn_rngs(3000, 11)[5:6])
    np.testing.assert_array_equal(ba1[0], ba[5])


def test_measure_is_reproducible_and_adds_biases():
    imu = ImuModel(IMU_GRADES["tactical"], 100.0, 50.0, 60.0)
    nu = np.tile([0.0, 0.0, -9.81], (10, 1))
    om = np.zeros((10, 3))
    out1 = imu.measure(nu, om, np.ones((2, 3)), np.zeros((2, 3)), spawn_rngs(2, 5))
    out2 = imu.measure(nu, om, np.ones((2, 3)), np.zeros((2, 3)), spawn_rngs(2, 5))
    for a, b in zip(out1, out2):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(out1[2][:, 0], np.ones((2, 3)))  # bias at sample 0 = given


def test_validation_names_field():
    g = IMU_GRADES["tactical"]
    with pytest.raises(ConfigError, match="imu.tau_accel"):
        ImuModel(g, 100.0, 0.0, 1.0)
    with pytest.raises(ConfigError, match="imu.tau_gyro"):
        ImuModel(g, 100.0, 1.0, -3.0)
    with pytest.raises(ConfigError, match="imu.rate_hz"):
        ImuModel(g, np.nan, 1.0, 1.0)
    with pytest.raises(ConfigError, match="imu.vrw"):
        ImuModel(ImuGrade("x", np.nan, 0.0, 0.0, 0.0), 100.0, 1.0, 1.0)
    imu = ImuModel(g, 100.0, 1.0, 1.0)
    bad = np.zeros((5, 3))
    bad[2, 1] = np.nan
    with pytest.raises(InputDataError, match="imu.samples"):
        imu.measure(bad, np.zeros((5, 3)), np.zeros((1, 3)), np.zeros((1, 3)), spawn_rngs(1, 1))
