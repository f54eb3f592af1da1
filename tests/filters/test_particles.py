"""Particle-filter library: SIR against Stone Soup, log-weights, N_eff, resamplers, collapse without diversity
(Sun 2022 T9), named errors, batch independence."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.particles import (
    RESAMPLING_METHODS,
    ParticleCloud,
    check_particle_count,
    effective_sample_size,
    kernel_shrinkage,
    gaussian_log_likelihood,
    normalize_log_weights,
    resample,
    resampling_indices,
    roughen,
    sir_update,
    unique_count,
)
from helpers import spawn_rngs


def test_one_sir_step_matches_stone_soup_particle_updater():
    """Same particles, prior weights and measurement: Stone Soup's ParticleUpdater (no resampler) gives the
    same posterior log-weights and mean to 1e-12."""
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.prediction import ParticleStatePrediction
    from stonesoup.types.state import StateVectors
    from stonesoup.updater.particle import ParticleUpdater

    rng = np.random.default_rng(7)
    n, d = 400, 4
    parts = rng.normal(size=(n, d)) * [3.0, 1.0, 2.0, 0.5]
    prior_lw, _ = normalize_log_weights(rng.normal(size=n)[None])
    cov = np.array([[0.8, 0.2], [0.2, 0.5]])
    z = np.array([1.3, -0.4])

    model = LinearGaussian(ndim_state=d, mapping=(0, 2), noise_covar=cov)
    pred = ParticleStatePrediction(StateVectors(parts.T), log_weight=prior_lw[0].copy())
    post = ParticleUpdater(measurement_model=model).update(
        SingleHypothesis(pred, Detection(z.reshape(2, 1), measurement_model=model)))

    ll = gaussian_log_likelihood(parts[None][:, :, [0, 2]], z[None], cov)
    lw, _, _ = sir_update(prior_lw, ll)
    np.testing.assert_allclose(lw[0], np.asarray(post.log_weight, dtype=float), rtol=0, atol=1e-12)
    mean = ParticleCloud(parts[None], lw).mean()[0]
    np.testing.assert_allclose(mean, np.asarray(post.mean, dtype=float).ravel(), rtol=0, atol=1e-12)


def test_gaussian_log_likelihood_matches_scipy():
    rng = np.random.default_rng(1)
    pred = rng.normal(size=(2, 50, 3))
    z = rng.normal(size=(2, 3))
    A = rng.normal(size=(3, 3))
    cov = A @ A.T + np.eye(3)
    got = gaussian_log_likelihood(pred, z, cov)
    want = np.stack([multivariate_normal(mean=z[r], cov=cov).logpdf(pred[r]) for r in range(2)])
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_log_weights_do_not_underflow():
    """Log-likelihoods around -1e5 (exp underflows to 0): the posterior equals the softmax of the shifted values."""
    ll = np.array([[-1.0e5, -1.0e5 - 1.0, -1.0e5 - 2.0, -np.inf]])
    lw, lse, collapsed = sir_update(np.full((1, 4), -np.log(4)), ll)
    e = np.exp([0.0, -1.0, -2.0])
    # the -1e5 offset costs ~1e5 eps of relative precision in the differences, hence 1e-10
    np.testing.assert_allclose(np.exp(lw[0, :3]), e / e.sum(), rtol=1e-10)
    assert np.exp(lw[0, 3]) == 0.0 and not collapsed[0]
    assert np.isfinite(lse).all()


def test_all_minus_inf_raises_named_error_or_keeps_prior():
    prior = np.log(np.array([[0.5, 0.5], [0.25, 0.75]]))
    ll = np.array([[-np.inf, -np.inf], [0.0, -1.0]])
    with pytest.raises(InputDataError, match=r"log_likelihood: .*runs \[0\]"):
        sir_update(prior, ll)
    lw, lse, collapsed = sir_update(prior, ll, on_collapse="keep-prior")
    assert collapsed.tolist() == [True, False]
    np.testing.assert_array_equal(lw[0], prior[0])
    assert not np.isnan(lw).any() and np.isneginf(lse[0])
    with pytest.raises(InputDataError, match="NaN"):
        sir_update(prior, np.array([[np.nan, 0.0], [0.0, 0.0]]))


@pytest.mark.parametrize("bad", [0, -5, 2.5, True, None])
def test_particle_count_must_be_positive_integer(bad):
    with pytest.raises(ConfigError, match="particles.count"):
        check_particle_count(bad)
    with pytest.raises(ConfigError):
        ParticleCloud.from_gaussian(np.zeros((1, 2)), np.eye(2), bad, spawn_rngs(1))


def test_unknown_resampler_is_named():
    with pytest.raises(ConfigError, match="particles.resampling"):
        resampling_indices(np.zeros((1, 3)), spawn_rngs(1), "bogus")


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-50, 50), min_size=1, max_size=40))
def test_effective_sample_size_in_one_to_n(logits):
    lw, _ = normalize_log_weights(np.array([logits]))
    ess = effective_sample_size(lw)[0]
    assert 1.0 - 1e-9 <= ess <= len(logits) + 1e-9


def test_effective_sample_size_limits():
    n = 10
    assert effective_sample_size(np.full((1, n), -np.log(n)))[0] == pytest.approx(n)
    one = np.full((1, n), -np.inf)
    one[0, 3] = 0.0
    assert effective_sample_size(one)[0] == 1.0


@pytest.mark.parametrize("method", RESAMPLING_METHODS)
def test_resamplers_are_unbiased(method):
    """E[number of copies of particle i] = N w_i, checked over 4000 resamplings (z-score < 4.5)."""
    w = np.array([0.02, 0.3, 0.005, 0.175, 0.5])
    n, reps = w.size, 4000
    lw = np.log(np.tile(w, (reps, 1)))
    idx = resampling_indices(lw, spawn_rngs(reps, 3), method)
    counts = np.stack([np.bincount(i, minlength=n) for i in idx])
    se = np.sqrt(n * w * (1 - w) / reps)  # multinomial standard error: an upper bound for the others
    assert np.all(np.abs(counts.mean(0) - n * w) < 4.5 * se + 1e-12)
    if method in ("systematic", "residual"):
        assert np.all(counts >= np.floor(n * w) - (method == "systematic"))
    if method != "multinomial":  # Douc et al. (2005): a resampled average has at most the multinomial variance
        f = np.array([3.0, -1.0, 7.0, 0.5, 2.0])
        var_multinomial = np.sum(w * (f - w @ f) ** 2) / n
        assert (counts @ f / n).var() <= 1.1 * var_multinomial


def test_one_multinomial_resampling_keeps_the_expected_number_of_distinct_particles():
    """E[distinct] = sum_i 1 - (1 - w_i)^N for N i.i.d. categorical draws."""
    rng = np.random.default_rng(5)
    n, reps = 200, 400
    lw, _ = normalize_log_weights(rng.normal(scale=1.5, size=(1, n)))
    expected = np.sum(1.0 - (1.0 - np.exp(lw[0])) ** n)
    idx = resampling_indices(np.repeat(lw, reps, 0), spawn_rngs(reps, 9), "multinomial")
    got = np.array([np.unique(i).size for i in idx])
    assert abs(got.mean() - expected) < 4.0 * got.std() / np.sqrt(reps)


def _static_sir(k, iters=6, n=1000, d=2, sigma_z=0.2, seed=0):
    rngs = spawn_rngs(1, seed)
    cloud = ParticleCloud.from_gaussian(np.zeros((1, d)), np.eye(d), n, rngs)
    out = []
    for it in range(iters):
        z = sigma_z * rngs[0].standard_normal(d)[None]
        lw, _, _ = sir_update(cloud.log_weights, gaussian_log_likelihood(cloud.particles, z, sigma_z**2 * np.eye(d)))
        cloud, _ = resample(ParticleCloud(cloud.particles, lw), rngs)
        if k:
            cloud.particles = roughen(cloud.particles, rngs, k)
        exact_var = 1.0 / (1.0 + (it + 1) / sigma_z**2)  # Kalman posterior of a static state
        out.append((unique_count(cloud.particles)[0] / n, np.trace(cloud.covariance()[0]) / d / exact_var))
    return np.array(out)


def test_cloud_collapses_within_six_resamplings_without_diversity_T9():
    """Sun 2022 Fig. 3.4 / L704: without diversity-preserving noise the cloud is reduced to a few distinct
    particles by iteration 6; roughening (Gordon et al. 1993) keeps every particle distinct and the cloud
    variance at the exact posterior's."""
    ratios = []
    for seed in range(4):
        bare = _static_sir(0.0, seed=seed)
        assert np.all(np.diff(bare[:, 0]) < 0)  # impoverishment with every resampling
        assert bare[5, 0] < 0.05  # < 5 % distinct after 6 resamplings (measured 3.6-4.8 %)
        rough = _static_sir(0.2, seed=seed)
        assert np.all(rough[:, 0] == 1.0)
        ratios.append(rough[:, 1])
    # cloud variance / exact posterior variance, averaged over seeds, per iteration
    assert np.all(np.abs(np.mean(ratios, axis=0) - 1.0) < 0.2)


def test_runs_are_batch_independent_bit_for_bit():
    seeds = np.random.SeedSequence(11).spawn(4)
    mean = np.arange(12.0).reshape(4, 3)

    def go(idx):
        rngs = [np.random.default_rng(seeds[i]) for i in idx]
        c = ParticleCloud.from_gaussian(mean[idx], np.eye(3), 300, rngs)
        ll = gaussian_log_likelihood(c.particles, mean[idx] + 0.5, 0.3 * np.eye(3))
        lw, _, _ = sir_update(c.log_weights, ll)
        out = []
        for m in RESAMPLING_METHODS:
            c2, _ = resample(ParticleCloud(c.particles, lw), rngs, m, threshold=1.0)
            out.append(roughen(c2.particles, rngs))
        return np.stack(out, 1)

    batch = go([0, 1, 2, 3])
    alone = go([2])
    np.testing.assert_array_equal(batch[2], alone[0])


def test_resample_threshold_draws_only_for_degenerate_runs():
    lw = np.log(np.array([[0.25, 0.25, 0.25, 0.25], [0.97, 0.01, 0.01, 0.01]]))
    cloud = ParticleCloud(np.arange(8.0).reshape(2, 4, 1), lw)
    rngs = spawn_rngs(2)
    state0 = rngs[0].bit_generator.state
    out, mask = resample(cloud, rngs, "systematic", threshold=0.5)
    assert mask.tolist() == [False, True]
    assert rngs[0].bit_generator.state == state0
    np.testing.assert_array_equal(out.particles[0], cloud.particles[0])
    np.testing.assert_allclose(np.exp(out.log_weights[1]), 0.25)


def test_kernel_shrinkage_keeps_mean_and_covariance_and_restores_diversity():
    rng = np.random.default_rng(2)
    base = rng.multivariate_normal([1.0, -2.0, 0.5], [[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 0.5]], 50)
    parts = np.repeat(base[None], 400, axis=0)[:, rng.integers(0, 50, 1000)]  # 400 impoverished clouds
    out = kernel_shrinkage(parts, spawn_rngs(400, 4), h=0.3)
    assert np.all(unique_count(out) == 1000)
    m_in, m_out = parts.mean(1), out.mean(1)
    c_in = np.einsum("rni,rnj->rij", parts - m_in[:, None], parts - m_in[:, None]) / 1000
    c_out = np.einsum("rni,rnj->rij", out - m_out[:, None], out - m_out[:, None]) / 1000
    np.testing.assert_allclose(m_out.mean(0), m_in.mean(0), atol=0.01)
    np.testing.assert_allclose(c_out.mean(0), c_in.mean(0), atol=0.01)
    with pytest.raises(ConfigError, match="particles.kernel_h"):
        kernel_shrinkage(parts[:1], spawn_rngs(1), h=1.0)


def test_tempering_exponent_keeps_the_target_effective_sample_size():
    from sarnav.filters.particles import tempering_exponent

    rng = np.random.default_rng(4)
    n = 1000
    lw, _ = normalize_log_weights(np.zeros((3, n)))
    ll = -0.5 * (rng.normal(size=(3, n)) / np.array([[1e-3], [1.0], [1e3]])) ** 2
    lam = tempering_exponent(lw, ll, np.ones(3), 0.5)
    assert lam[2] == 1.0 and 0 < lam[0] < lam[1] <= 1.0  # a flat likelihood is applied at once
    post, _ = normalize_log_weights(lw + lam[:, None] * ll)
    ess = effective_sample_size(post)
    assert ess[0] == pytest.approx(0.5 * n, rel=1e-3)
    assert np.all(ess >= 0.5 * n - 1e-6)
    assert tempering_exponent(lw, ll, np.zeros(3), 0.5).tolist() == [0.0, 0.0, 0.0]


def _static_pf(n, runs, seed):
    from sarnav.filters.grid_particle import GridParticleFilter
    from sarnav.filters.pulse_grid import NavFrame

    cov = np.eye(6)
    cov[0, 3] = cov[3, 0] = 0.8  # p_N and v_N correlated a priori
    pf = GridParticleFilter(NavFrame(), n, 0.0, ess_threshold=0.5, kernel_h=0.3)
    return pf.initialize(0.0, np.zeros((runs, 3)), np.zeros((runs, 3)), [1.0, 0, 0, 0], cov, spawn_rngs(runs, seed))


def test_tempered_update_matches_the_kalman_posterior_where_one_sir_step_collapses():
    """Prior N(0, [[1, 0.8], [0.8, 1]]) on (p_N, v_N), a measurement of p_N with sigma 1e-3 (the SAR range against a
    cloud of decimetres, multi-imu-sar-fix): the Kalman posterior is p_N ~ N(z, 1e-6), v_N ~ N(0.8 z, 0.36). One SIR
    step rests on a handful of ancestors (posterior variances off by factors 0.05-1.5 from run to run); the tempered
    update (adaptive progressive correction with Liu-West moves) gets every run's within 20 % (p_N)."""
    runs, n, sig, z = 16, 2000, 1e-3, 0.7
    P, R = 1.0, sig**2
    post_p, post_var_p = z * P / (P + R), P * R / (P + R)
    post_v, post_var_v = 0.8 * post_p, 1.0 - 0.64 * P / (P + R)
    ll = lambda p, v: -0.5 * ((z - p[..., 0]) / sig) ** 2  # noqa: E731

    def moments(pf):
        pos, vel = pf.particle_states()
        w = np.exp(pf.logw)
        mp, mv = np.sum(w * pos[..., 0], 1), np.sum(w * vel[..., 0], 1)
        return mp, mv, np.sum(w * (pos[..., 0] - mp[:, None]) ** 2, 1), np.sum(w * (vel[..., 0] - mv[:, None]) ** 2, 1)

    pf = _static_pf(n, runs, 1)
    assert pf.update_tempered(ll) > 5  # stages
    mp, mv, vp, vv = moments(pf)
    assert np.all(np.abs(mp - post_p) < 4 * np.sqrt(post_var_p))
    assert np.mean(mv) == pytest.approx(post_v, abs=4 * np.sqrt(post_var_v / runs))
    assert np.all(np.abs(vp / post_var_p - 1.0) < 0.2)
    assert np.mean(vv) / post_var_v == pytest.approx(1.0, abs=0.15)
    plain = _static_pf(n, runs, 1)
    plain.update_log_likelihood(ll(*plain.particle_states()))
    _, _, vp0, vv0 = moments(plain)
    assert np.max(np.abs(vp0 / post_var_p - 1.0)) > 0.4 and np.min(vv0 / post_var_v) < 0.2


def test_tempered_update_with_zero_likelihood_everywhere_is_named_or_rejected():
    """All log-likelihoods -inf (a measurement no particle can have made): the named error, or with
    on_collapse='keep-prior' the measurement is rejected for that run and nothing becomes NaN."""
    from sarnav.filters.grid_particle import GridParticleFilter
    from sarnav.filters.pulse_grid import NavFrame

    def make(mode):
        pf = GridParticleFilter(NavFrame(), 200, 0.0, on_collapse=mode)
        return pf.initialize(0.0, np.zeros((2, 3)), np.zeros((2, 3)), [1.0, 0, 0, 0], np.eye(6), spawn_rngs(2, 3))

    dead = lambda p, v: np.where(np.arange(2)[:, None] == 0, -np.inf, -0.5 * p[..., 0] ** 2)  # noqa: E731
    with pytest.raises(InputDataError, match=r"log_likelihood: .*runs \[0\]"):
        make("raise").update_tempered(dead)
    pf = make("keep-prior")
    pf.update_tempered(dead)
    assert pf.collapsed.tolist() == [True, False]
    assert np.all(np.isfinite(pf.particle_states()[0])) and np.all(np.isfinite(pf.position_covariance()))
    with pytest.raises(InputDataError, match="log_likelihood"):
        pf.update_log_likelihood(np.zeros((2, 7)))


def test_gaussian_pf_update_is_the_kalman_update_for_a_linear_measurement():
    """The same problem through ``update_gaussian`` (Kotecha & Djuric 2003): for a linear measurement the importance
    weights are equal (N_eff = N) and the new cloud has the Kalman posterior's mean and covariance (the cloud's own
    prior moments, updated)."""
    runs, n, sig, z = 16, 2000, 1e-3, 0.7
    pf = _static_pf(n, runs, 2)
    pos, vel = pf.particle_states()
    w = np.exp(pf.logw)
    x = np.concatenate([pos, vel], -1)
    m = np.einsum("rn,rnd->rd", w, x)
    P = np.einsum("rn,rni,rnj->rij", w, x - m[:, None], x - m[:, None])
    H = np.zeros((runs, 1, 6))
    H[:, 0, 0] = 1.0
    lin = lambda p, v: (p[:, :1], H)  # noqa: E731
    ll = lambda p, v: -0.5 * ((z - p[..., 0]) / sig) ** 2  # noqa: E731
    ess = pf.update_gaussian(lin, ll, np.full((runs, 1), z), [[sig**2]])
    np.testing.assert_allclose(ess, 1.0, atol=1e-9)
    K = P[:, :, 0] / (P[:, 0, 0] + sig**2)[:, None]  # Kalman gain of the cloud's prior moments
    m1 = m + K * (z - m[:, :1])
    P1 = P - K[:, :, None] * P[:, None, 0, :]
    pos, vel = pf.particle_states()
    x = np.concatenate([pos, vel], -1)
    w = np.exp(pf.logw)
    got_m = np.einsum("rn,rnd->rd", w, x)
    got_P = np.einsum("rn,rni,rnj->rij", w, x - got_m[:, None], x - got_m[:, None])
    se = np.sqrt(np.diagonal(P1, axis1=1, axis2=2) / n)
    assert np.all(np.abs(got_m - m1) < 5 * se)
    np.testing.assert_allclose(np.diagonal(got_P, axis1=1, axis2=2) / np.diagonal(P1, axis1=1, axis2=2), 1.0,
                               atol=5 * np.sqrt(2 / n))
    with pytest.raises(ConfigError, match="pf.model"):
        from sarnav.filters.grid_particle import GridParticleFilter
        from sarnav.filters.pulse_grid import NavFrame

        geo = GridParticleFilter(NavFrame(geodetic=True, origin=(0.6, -1.7, 1000.0)), 10, model="geodetic")
        geo.update_gaussian(lin, ll, np.zeros((1, 1)), [[1.0]])


def test_a_fix_sharper_than_the_cloud_is_tempered_not_collapsed():
    """A position fix of sigma 1e-3 m on a cloud of 1 m (a low fix rate; multi-imu-path1 at 1 Hz with 50 particles
    collapsed to one particle, NEES 1e12): one SIR step would leave N_eff < 7, so the filter tempers it. Every run's
    posterior position covariance is then the Kalman one (sigma^2 I) within a factor 2 and full rank, its mean
    within 4 sigma of the fix; a fix the cloud can absorb (sigma 2 m) is the plain SIR step bit for bit; a run's
    numbers do not depend on the batch."""
    from sarnav.filters.grid_particle import DEGENERATE_ESS

    runs, n, sig = 6, 200, 1e-3
    z = np.array([0.3, -0.2, 0.1]) + np.zeros((runs, 3))
    pf = _static_pf(n, runs, 5)
    post, _ = normalize_log_weights(pf.logw + pf._fix_log_likelihood(z, np.full(3, sig)))
    assert np.all(effective_sample_size(post) < DEGENERATE_ESS)  # the case the recovery is for
    pf._update(z, np.full(3, sig))
    cov = pf.position_covariance()
    eig = np.linalg.eigvalsh(cov)
    assert np.all(eig > 0.5 * sig**2) and np.all(eig < 2.0 * sig**2)
    mean = np.einsum("rn,rnd->rd", np.exp(pf.logw), pf.particle_states()[0])
    assert np.all(np.abs(mean - z) < 4 * sig)
    one = _static_pf(n, 1, 5)  # run 0 alone (the same child seed): the same numbers
    one._update(z[:1], np.full(3, sig))
    np.testing.assert_array_equal(one.parts[0], pf.parts[0])
    loose, plain = _static_pf(n, runs, 7), _static_pf(n, runs, 7)
    loose._update(z, np.full(3, 2.0))
    plain.update_log_likelihood(plain._fix_log_likelihood(z, np.full(3, 2.0)))
    np.testing.assert_array_equal(loose.parts, plain.parts)
    np.testing.assert_array_equal(loose.logw, plain.logw)
