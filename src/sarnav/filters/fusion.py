"""Fusion of several IMU navigation solutions: the SIR sensor weighting of Sun (2022) Algorithm 1, the plain mean,
the virtual-IMU baseline, and the design formulas (CRLB eqs. 5.5-5.13, sequential Monte Carlo variance 5.14).

SIR sensor weighting (Algorithm 1 lines 13-17, eqs. 5.3, 3.22-3.24; extraction seed-003 §2.14):

1. each of S IMUs has its own aided particle filter giving an estimate p_s at the fix epoch;
2. sensor weight = likelihood of the fix g given the sensor's estimate, ``w_s = N(g; p_s, Sigma_fix)`` (gap G13),
   in log form (tight fixes underflow otherwise);
3. normalised, ``w_s / sum w_s`` (eq. 5.3); N_s = 1/sum w^2 (eq. 5.4) as a diagnostic;
4. a combined cloud of ``n_draws`` (N = 50, L908) copies of sensor estimates drawn in proportion to the
   weights (gap G14, option A: the sensor estimates, rebuilt at each fix);
5. the fused estimate is the mean of the combined cloud (eq. 3.23); its expectation is sum w_s p_s.

``per_axis=True`` (default) weights and draws each NED axis on its own with the 1-D pdf of eq. 3.24 (the
source's weighting function is 1-D and its clouds are per component, Fig. 5.26); ``False`` uses the 3-D
Gaussian. Between fixes the drawn indices are held (gap G15), see ``sarnav.simulation.multi_imu``.

Baselines: the arithmetic mean of the sensor estimates (the "traditional" fusion, L1161, gap G17) and a
virtual IMU (Bancroft & Lachapelle 2011: the lever-arm-compensated average of the raw IMU samples, fed to one
filter).

Design formulas: for N i.i.d. sensors ``x_n = x + w_n``, ``w_n ~ N(0, sigma^2)``, the Fisher information is
N/sigma^2 (eq. 5.12) and ``Var >= sigma^2 / N`` (eq. 5.13), attained by the sample mean. Eq. 5.14 is taken in
the form of Doucet & Johansen (2009) that it transcribes (extraction §2.15): the asymptotic relative variance
of the SMC normalising-constant estimate, ``(1/N) sum_k (int pi_k^2 / q_k dx - 1)``; for one step it is the
relative variance of an importance-sampling estimate with N samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.particles import check_particle_count, effective_sample_size, normalize_log_weights
from sarnav.sensors.lever_arm import lever_arm_specific_force, rate_derivative


def fisher_information_iid(sigma2, n):
    """N / sigma^2 (eq. 5.12): Fisher information of N i.i.d. Gaussian sensors about the common position."""
    n = check_particle_count(n, "fusion.n_sensors")
    return n / np.asarray(sigma2, dtype=float)


def crlb_variance(sigma2, n):
    """sigma^2 / N (eq. 5.13): the Cramer-Rao bound on the variance of any unbiased fused estimate."""
    return 1.0 / fisher_information_iid(sigma2, n)


def gaussian_chi2_moment(mu_pi, var_pi, mu_q, var_q):
    """int pi(x)^2 / q(x) dx for 1-D Gaussians pi = N(mu_pi, var_pi), q = N(mu_q, var_q) (closed form; +inf when
    2 var_q <= var_pi, where the integral diverges). Equals 1 when pi = q (chi-square divergence + 1)."""
    mu_pi, var_pi, mu_q, var_q = (np.asarray(a, dtype=float) for a in (mu_pi, var_pi, mu_q, var_q))
    c = 2.0 / var_pi - 1.0 / var_q
    ok = c > 0
    cs = np.where(ok, c, 1.0)
    b = 2.0 * mu_pi / var_pi - mu_q / var_q
    expo = b * b / (2.0 * cs) - mu_pi**2 / var_pi + mu_q**2 / (2.0 * var_q)
    return np.where(ok, np.sqrt(var_q / cs) / var_pi * np.exp(expo), np.inf)


def smc_variance(chi2_moments, n):
    """(1/N) sum_k (int pi_k^2/q_k - 1) (eq. 5.14, Doucet & Johansen form): asymptotic relative variance of the
    SMC normalising-constant estimate after K steps; ``chi2_moments`` (..., K)."""
    n = check_particle_count(n, "fusion.n_samples")
    m = np.asarray(chi2_moments, dtype=float)
    return np.sum(m - 1.0, axis=-1) / n


def mean_fuse(estimates) -> np.ndarray:
    """The traditional fusion: arithmetic mean over the sensor axis of ``estimates`` (R, S, m)."""
    return np.asarray(estimates, dtype=float).mean(axis=1)


def sensor_log_weights(estimates, fix, sigma, per_axis: bool = True):
    """Normalised log sensor weights log N(fix; p_s, diag sigma^2) (eqs. 3.24, 5.3).

    estimates : (R, S, 3) sensor estimates as offsets in metres (any common origin); fix : (R, 3) same origin;
    sigma : (3,) fix standard deviation [m]. Returns (R, S, 3) per axis, or (R, S) joint.
    """
    est = np.asarray(estimates, dtype=float)
    fix = np.asarray(fix, dtype=float)
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (3,))
    if est.ndim != 3 or est.shape[-1] != 3 or fix.shape != (est.shape[0], 3):
        raise InputDataError("fusion.estimates", f"need (runs, sensors, 3) and (runs, 3), got {est.shape}, {fix.shape}")
    if np.any(sigma <= 0):
        raise ConfigError("fusion.fix_sigma", f"must be > 0 m, got {sigma!r}")
    ll = -0.5 * ((fix[:, None, :] - est) / sigma) ** 2
    if per_axis:
        lw, _ = normalize_log_weights(np.moveaxis(ll, 1, -1))
        return np.moveaxis(lw, -1, 1)
    lw, _ = normalize_log_weights(ll.sum(-1))
    return lw


@dataclass
class SirFusion:
    """Result of :func:`sir_fuse`: ``estimate`` (R, 3) mean of the combined cloud; ``indices`` (R, n_draws, 3)
    sensor drawn for each cloud member and axis (the same index on all axes when joint); ``log_weights``
    (R, S, 3) or (R, S); ``sensor_ess`` (R,) or (R, 3) N_s of eq. 5.4."""

    estimate: np.ndarray
    indices: np.ndarray
    log_weights: np.ndarray
    sensor_ess: np.ndarray


def draw_sensors(log_weights, n_draws: int, rngs) -> np.ndarray:
    """Combined-cloud sensor indices (R, n_draws, 3) drawn i.i.d. from the sensor weights (per axis or joint);
    each run draws from its own generator (uniforms (n_draws, 3) per run)."""
    n_draws = check_particle_count(n_draws, "fusion.n_draws")
    lw = np.asarray(log_weights, dtype=float)
    runs = lw.shape[0]
    if len(rngs) != runs:
        raise InputDataError("rngs", f"need one Generator per run ({runs}), got {len(rngs)}")
    w3 = np.exp(lw) if lw.ndim == 3 else np.repeat(np.exp(lw)[..., None], 3, -1)
    cdf = np.cumsum(w3, axis=1)
    cdf /= cdf[:, -1:, :]
    out = np.empty((runs, n_draws, 3), dtype=np.int64)
    for r, g in enumerate(rngs):
        u = g.random((n_draws, 3)) if lw.ndim == 3 else np.repeat(g.random((n_draws, 1)), 3, -1)
        for a in range(3):
            out[r, :, a] = np.minimum(np.searchsorted(cdf[r, :, a], u[:, a], side="right"), lw.shape[1] - 1)
    return out


def cloud_mean(estimates, indices) -> np.ndarray:
    """Mean of the combined cloud: estimates (R, S, 3) picked by indices (R, n_draws, 3) -> (R, 3)."""
    est = np.asarray(estimates, dtype=float)
    return np.take_along_axis(est, indices, axis=1).mean(axis=1)


def sir_fuse(estimates, fix, sigma, n_draws: int, rngs, per_axis: bool = True) -> SirFusion:
    """Algorithm 1 lines 13-17 at one fix epoch (module docstring)."""
    lw = sensor_log_weights(estimates, fix, sigma, per_axis)
    idx = draw_sensors(lw, n_draws, rngs)
    ess = effective_sample_size(np.moveaxis(lw, 1, -1)) if per_axis else effective_sample_size(lw)
    return SirFusion(cloud_mean(estimates, idx), idx, lw, ess)


def virtual_imu(specific_force, angular_rate, lever_arms, dt: float):
    """Virtual IMU: the mean of S IMUs' samples after moving each to the reference point.

    specific_force, angular_rate : (S, R, M, 3) samples of IMUs aligned with the body, at body offsets
    ``lever_arms`` (S, 3) [m]; the rate used for the lever-arm terms is the mean gyro and its derivative
    (central differences). Returns (f (R, M, 3), omega (R, M, 3)).
    """
    f = np.asarray(specific_force, dtype=float)
    w = np.asarray(angular_rate, dtype=float)
    r = np.asarray(lever_arms, dtype=float)
    if f.shape != w.shape or f.ndim != 4 or r.shape != (f.shape[0], 3):
        raise InputDataError("fusion.imus", f"need (S, R, M, 3) samples and (S, 3) lever arms, got {f.shape}, {r.shape}")
    w_mean = w.mean(axis=0)
    w_dot = rate_derivative(w_mean, dt)
    f_ref = [f[s] - (lever_arm_specific_force(np.zeros(3), w_mean, w_dot, r[s])) for s in range(f.shape[0])]
    return np.mean(f_ref, axis=0), w_mean
