"""Multi-IMU fusion pieces: CRLB (Sun 2022 eqs. 5.12-5.13, T14), SMC variance (5.14), SIR sensor weighting
(Algorithm 1) against its expectation, the virtual IMU."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import norm

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.fusion import (
    crlb_variance,
    draw_sensors,
    fisher_information_iid,
    gaussian_chi2_moment,
    mean_fuse,
    sensor_log_weights,
    sir_fuse,
    smc_variance,
    virtual_imu,
)
from sarnav.sensors.lever_arm import lever_arm_specific_force, rate_derivative
from helpers import spawn_rngs


def test_mean_of_iid_sensors_attains_the_crlb_T14():
    """Var(mean of N sensors) = sigma^2/N = 1/Fisher (eqs. 5.12-5.13) within Monte Carlo error."""
    rng = np.random.default_rng(0)
    sigma2, trials = 0.7, 40000
    for n in (1, 2, 3, 5, 10):
        est = rng.normal(0.0, np.sqrt(sigma2), (trials, n, 3))
        var = mean_fuse(est).var(axis=0)
        bound = crlb_variance(sigma2, n)
        assert bound == pytest.approx(1.0 / fisher_information_iid(sigma2, n))
        assert np.all(np.abs(var / bound - 1.0) < 4.0 * np.sqrt(2.0 / trials))  # chi2 sampling error
    with pytest.raises(ConfigError, match="fusion.n_sensors"):
        crlb_variance(1.0, 0)


def test_chi2_moment_closed_form_against_quadrature():
    for mp, vp, mq, vq in [(0.0, 1.0, 0.0, 1.0), (0.3, 0.5, -0.2, 1.2), (1.0, 2.0, 0.0, 1.5)]:
        want = quad(lambda x: norm.pdf(x, mp, np.sqrt(vp)) ** 2 / norm.pdf(x, mq, np.sqrt(vq)), -30, 30)[0]
        assert gaussian_chi2_moment(mp, vp, mq, vq) == pytest.approx(want, rel=1e-8)
    assert gaussian_chi2_moment(0.0, 1.0, 0.0, 1.0) == pytest.approx(1.0)
    assert np.isinf(gaussian_chi2_moment(0.0, 2.0, 0.0, 1.0))  # q too narrow: infinite variance


def test_smc_variance_predicts_importance_sampling_variance():
    """One step of eq. 5.14: Var(Z_hat / Z) = (int pi^2/q - 1)/N for N samples from q weighted by pi/q."""
    n, reps = 200, 4000
    mp, vp, mq, vq = 0.5, 0.6, 0.0, 1.0
    rng = np.random.default_rng(1)
    x = rng.normal(mq, np.sqrt(vq), (reps, n))
    z = (norm.pdf(x, mp, np.sqrt(vp)) / norm.pdf(x, mq, np.sqrt(vq))).mean(axis=1)
    pred = smc_variance([gaussian_chi2_moment(mp, vp, mq, vq)], n)
    assert z.var() == pytest.approx(pred, rel=4.0 * np.sqrt(2.0 / reps) + 0.05)
    assert smc_variance([1.2, 1.5, 1.1], 10) == pytest.approx(0.08)


def test_sir_draws_follow_the_sensor_weights():
    """E[fused] = sum_s w_s p_s (Algorithm 1); the draw frequencies follow w (5.3); weights from the fix's pdf."""
    est = np.array([[[0.0, 0.0, 0.0], [1.0, 2.0, -1.0], [3.0, -1.0, 0.5]]])
    fix = np.array([[0.8, 0.0, 0.0]])
    sigma = np.array([1.0, 2.0, 0.5])
    lw = sensor_log_weights(est, fix, sigma)
    w = np.exp(-0.5 * ((fix[:, None] - est) / sigma) ** 2)
    np.testing.assert_allclose(np.exp(lw), w / w.sum(axis=1, keepdims=True), rtol=1e-12)
    reps = 3000
    res = sir_fuse(np.repeat(est, reps, 0), np.repeat(fix, reps, 0), sigma, 50, spawn_rngs(reps, 2))
    expect = np.sum(np.exp(lw) * est, axis=1)[0]
    se = np.sqrt(np.sum(np.exp(lw) * (est - expect) ** 2, axis=1)[0] / 50 / reps)
    assert np.all(np.abs(res.estimate.mean(0) - expect) < 4.5 * se)
    joint = sensor_log_weights(est, fix, sigma, per_axis=False)
    assert joint.shape == (1, 3) and np.exp(joint).sum() == pytest.approx(1.0)
    idx = draw_sensors(joint, 20, spawn_rngs(1, 3))
    assert np.all(idx[..., 0] == idx[..., 1])  # joint: one sensor per cloud member
    with pytest.raises(InputDataError, match="fusion.estimates"):
        sensor_log_weights(est[0], fix, sigma)


def test_virtual_imu_removes_lever_arms_and_averages_noise():
    rng = np.random.default_rng(5)
    m, dt = 400, 0.01
    t = np.arange(m) * dt
    w = np.stack([0.1 * np.sin(t), 0.05 * np.cos(2 * t), 0.3 + 0.2 * np.sin(0.5 * t)], -1)[None]
    f_ref = np.stack([0.2 + 0 * t, -0.1 * t, -9.8 + 0 * t], -1)[None]
    arms = np.array([[0.2, 0.1, 0.0], [-0.2, 0.1, 0.0], [0.0, -0.3, 0.1]])
    wdot = rate_derivative(w, dt)
    f = np.stack([lever_arm_specific_force(f_ref, w, wdot, a) for a in arms])
    noise = 0.01 * rng.standard_normal(f.shape)
    fv, wv = virtual_imu(f + noise, np.repeat(w[None], 3, 0), arms, dt)
    np.testing.assert_allclose(wv, w)
    err = fv - f_ref
    assert np.std(err) == pytest.approx(0.01 / np.sqrt(3), rel=0.1)
    assert abs(np.mean(err)) < 1e-3


def test_per_axis_sir_over_the_mean_has_a_ceiling_of_1_315_for_identical_sensors():
    """T22's ceiling (docs/particles.md): three identical sensors with i.i.d. errors, weighted per axis by an exact
    fix (sigma 1e-4 of theirs), make SIR pick the sensor nearest the truth on each axis; its RMS over the mean's is
    sqrt(1/3) / sqrt(E[min of 3 chi2_1]) = 1.3149 (the integral of erfc(sqrt(x/2))^3), the most per-axis SIR can gain
    over the mean; a fix as noisy as the sensors gains nothing (about 1), the source's further 2x is out of reach."""
    from scipy import integrate, special

    from sarnav.filters.fusion import mean_fuse, sir_fuse

    e_min, _ = integrate.quad(lambda x: special.erfc(np.sqrt(x / 2.0)) ** 3, 0.0, np.inf)
    ceiling = np.sqrt(1.0 / 3.0) / np.sqrt(e_min)
    assert ceiling == pytest.approx(1.3149, abs=1e-4)
    runs = 4000
    rng = np.random.default_rng(22)
    est = rng.standard_normal((runs, 3, 3))  # sensors' errors about the truth at 0 (sigma 1 per axis)
    rngs = [np.random.default_rng(s) for s in range(runs)]
    rms_mean = np.sqrt(np.mean(mean_fuse(est) ** 2))
    exact = sir_fuse(est, np.zeros((runs, 3)), 1e-4, 20, rngs)
    assert rms_mean / np.sqrt(np.mean(exact.estimate ** 2)) == pytest.approx(ceiling, rel=0.03)
    noisy = sir_fuse(est, rng.standard_normal((runs, 3)), 1.0, 20, [np.random.default_rng(s) for s in range(runs)])
    assert rms_mean / np.sqrt(np.mean(noisy.estimate ** 2)) < 1.1
