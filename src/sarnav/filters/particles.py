"""Particle-filter building blocks batched over runs and particles: clouds of shape (R, N, d).

Sun (2022) eqs. 3.16-3.24 and 5.3-5.4 (extraction seed-003 §2.10, §2.14):

* SIR update with the bootstrap proposal, ``w_k^i ∝ w_{k-1}^i p(y_k | x_k^i)`` (eq. 3.22 with the transition
  prior as proposal), carried as **log-weights** normalised with log-sum-exp so that tight likelihoods never
  underflow (extraction §2.14 item 2);
* effective sample size ``N_eff = 1 / sum w^2`` in [1, N] (eq. 5.4) and resampling when
  ``N_eff < threshold N`` (Algorithm 1 line 10; the threshold is a free choice, gap G8);
* multinomial (the source's "cumulative sum" resampling, L761), systematic, stratified and residual
  resampling (Douc, Cappé & Moulines 2005), all returning ancestor indices so that particles and weights
  are permuted together;
* roughening (Gordon, Salmond & Smith 1993: jitter of std ``K E_j N^(-1/d)`` per dimension, E_j the cloud's
  extent) and Gaussian process noise, which keep the cloud from collapsing onto a few copies (T9, Fig. 3.4);
* the estimate is the weighted mean of the cloud (eq. 3.23).

Random numbers: ``rngs`` is one ``numpy.random.Generator`` per run and each run draws only from its own
generator, in an order that does not depend on the other runs, so a run gives the same numbers alone or
inside a batch. Python loops run over runs (R), never over particles.

Degenerate updates: when every particle of a run has zero likelihood (all log-likelihoods -inf, or a
likelihood so narrow that nothing is near the measurement in floating point) the posterior is undefined.
``on_collapse="raise"`` (default) raises :class:`~sarnav.errors.InputDataError` naming the runs;
``"keep-prior"`` keeps the prior weights for those runs (the measurement is rejected) and reports them in the
returned mask. NaN never reaches the weights.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from sarnav.errors import ConfigError, InputDataError

RESAMPLING_METHODS = ("multinomial", "systematic", "stratified", "residual")


def check_particle_count(n, field: str = "particles.count") -> int:
    """Return ``int(n)`` or raise ConfigError unless it is a whole number >= 1."""
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or int(n) < 1:
        raise ConfigError(field, f"must be a whole number of particles >= 1, got {n!r}")
    return int(n)


def _check_rngs(rngs, runs):
    if len(rngs) != runs:
        raise InputDataError("rngs", f"need one Generator per run ({runs}), got {len(rngs)}")
    return rngs


@dataclass
class ParticleCloud:
    """Particles (R, N, d) and their normalised log-weights (R, N) (logsumexp over N = 0 per run)."""

    particles: np.ndarray
    log_weights: np.ndarray

    @classmethod
    def from_gaussian(cls, mean, cov, n, rngs: Sequence[np.random.Generator]) -> "ParticleCloud":
        """N particles per run drawn from N(mean[r], cov), equal weights; ``mean`` (R, d), ``cov`` (d, d) or
        (R, d, d). Each run draws an (N, d) standard-normal block from its own generator."""
        n = check_particle_count(n)
        mean = np.atleast_2d(np.asarray(mean, dtype=float))
        runs, d = mean.shape
        _check_rngs(rngs, runs)
        L = np.linalg.cholesky(np.broadcast_to(np.asarray(cov, dtype=float), (runs, d, d)))
        z = np.stack([g.standard_normal((n, d)) for g in rngs])
        parts = mean[:, None, :] + np.einsum("rij,rnj->rni", L, z)
        return cls(parts, np.full((runs, n), -np.log(n)))

    @property
    def runs(self) -> int:
        return self.particles.shape[0]

    @property
    def size(self) -> int:
        return self.particles.shape[1]

    def weights(self) -> np.ndarray:
        """Normalised weights (R, N)."""
        return np.exp(self.log_weights)

    def mean(self) -> np.ndarray:
        """Weighted mean (R, d) (eq. 3.23)."""
        return weighted_mean(self.particles, self.log_weights)

    def covariance(self) -> np.ndarray:
        """Weighted sample covariance (R, d, d)."""
        return weighted_covariance(self.particles, self.log_weights)

    def ess(self) -> np.ndarray:
        """Effective sample size (R,) (eq. 5.4)."""
        return effective_sample_size(self.log_weights)

    def copy(self) -> "ParticleCloud":
        return replace(self, particles=self.particles.copy(), log_weights=self.log_weights.copy())


def normalize_log_weights(log_w):
    """(log_w - logsumexp(log_w), logsumexp(log_w)) along the particle axis (max-shifted, so no underflow);
    all -inf rows give -inf sums and -inf weights, never NaN."""
    log_w = np.asarray(log_w, dtype=float)
    m = np.max(log_w, axis=-1)
    mf = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        lse = mf + np.log(np.sum(np.exp(log_w - mf[..., None]), axis=-1))
    lse = np.where(np.isneginf(m), -np.inf, lse)
    finite = np.isfinite(lse)
    out = np.where(finite[..., None], log_w - np.where(finite, lse, 0.0)[..., None], -np.inf)
    return out, lse


def sir_update(log_weights, log_likelihood, on_collapse: str = "raise"):
    """Bootstrap SIR weight update (eq. 3.22): log w_k = log w_{k-1} + log p(y | x), renormalised.

    Parameters
    ----------
    log_weights : (R, N) normalised prior log-weights.
    log_likelihood : (R, N) log p(y_k | x_k^i); -inf allowed, NaN and +inf are not.
    on_collapse : ``"raise"`` or ``"keep-prior"`` for runs whose posterior weights are all zero (module doc).

    Returns
    -------
    log_weights : (R, N) normalised posterior log-weights.
    log_evidence : (R,) log p(y_k | y_{1:k-1}) = logsumexp(log w_{k-1} + log p) (-inf for collapsed runs).
    collapsed : (R,) bool, runs whose update was rejected (always False with "raise").
    """
    if on_collapse not in ("raise", "keep-prior"):
        raise ConfigError("particles.on_collapse", f"must be 'raise' or 'keep-prior', got {on_collapse!r}")
    log_weights = np.asarray(log_weights, dtype=float)
    ll = np.asarray(log_likelihood, dtype=float)
    if ll.shape != log_weights.shape:
        raise InputDataError("log_likelihood", f"must have the weights' shape {log_weights.shape}, got {ll.shape}")
    if np.isnan(ll).any() or np.isposinf(ll).any():
        raise InputDataError("log_likelihood", "must not contain NaN or +inf (use -inf for zero likelihood)")
    post, lse = normalize_log_weights(log_weights + ll)
    collapsed = ~np.isfinite(lse)
    if collapsed.any():
        if on_collapse == "raise":
            runs = np.flatnonzero(collapsed).tolist()
            raise InputDataError("log_likelihood", f"every particle has zero likelihood in runs {runs} "
                                 "(measurement far outside the cloud or noise too small); pass "
                                 "on_collapse='keep-prior' to reject the measurement instead")
        post[collapsed] = log_weights[collapsed]
    return post, lse, collapsed


def gaussian_log_likelihood(predicted, z, cov):
    """log N(z; predicted, cov) per particle (eq. 3.24 generalised to m dimensions).

    predicted : (R, N, m) predicted measurement of every particle; z : (R, m); cov : (m, m) or (R, m, m).
    Returns (R, N).
    """
    predicted = np.asarray(predicted, dtype=float)
    z = np.asarray(z, dtype=float)
    runs, _, m = predicted.shape
    cov = np.broadcast_to(np.asarray(cov, dtype=float), (runs, m, m))
    r = z[:, None, :] - predicted
    var = np.diagonal(cov, axis1=-2, axis2=-1)
    if np.all(cov == var[..., None] * np.eye(m)):  # diagonal: no factorisation
        u = r / np.sqrt(var)[:, None, :]
        logdet = np.sum(np.log(var), axis=-1)
    else:
        L = np.linalg.cholesky(cov)
        u = np.einsum("rij,rnj->rni", np.linalg.inv(L), r)
        logdet = 2.0 * np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
    with np.errstate(over="ignore"):  # a residual beyond ~1e154 sigma: log-likelihood -inf, as it should
        return -0.5 * (np.sum(u * u, axis=-1) + logdet[:, None] + m * np.log(2.0 * np.pi))


def effective_sample_size(log_weights) -> np.ndarray:
    """N_eff = 1 / sum_i w_i^2 (eq. 5.4) of normalised log-weights (R, N); in [1, N]."""
    w = np.exp(np.asarray(log_weights, dtype=float))
    return 1.0 / np.sum(w * w, axis=-1)


def weighted_mean(particles, log_weights) -> np.ndarray:
    """sum_i w_i x_i (R, d) (eq. 3.23)."""
    w = np.exp(np.asarray(log_weights, dtype=float))
    return np.einsum("rn,rnd->rd", w, particles)


def weighted_covariance(particles, log_weights) -> np.ndarray:
    """sum_i w_i (x_i - m)(x_i - m)^T (R, d, d) (biased, like Stone Soup's ParticleState.covar)."""
    w = np.exp(np.asarray(log_weights, dtype=float))
    dx = particles - np.einsum("rn,rnd->rd", w, particles)[:, None, :]
    return np.einsum("rn,rni,rnj->rij", w, dx, dx)


def _search(cdf, u):
    """Ancestor indices: the first i with cdf[i] > u, per run (exact; a loop over runs only)."""
    out = np.empty(u.shape, dtype=np.int64)
    n = cdf.shape[1]
    for r in range(cdf.shape[0]):
        out[r] = np.minimum(np.searchsorted(cdf[r], u[r], side="right"), n - 1)
    return out


def _cdf(log_weights):
    c = np.cumsum(np.exp(log_weights), axis=-1)
    return c / c[:, -1:]


def multinomial_indices(log_weights, rngs) -> np.ndarray:
    """N i.i.d. draws from Categorical(w) per run by inverting the cumulative sum (L761). (R, N) int."""
    log_weights = np.asarray(log_weights, dtype=float)
    runs, n = log_weights.shape
    u = np.stack([g.random(n) for g in _check_rngs(rngs, runs)])
    return _search(_cdf(log_weights), u)


def stratified_indices(log_weights, rngs) -> np.ndarray:
    """One uniform draw in each stratum [(i + U_i)/N] per run. (R, N) int."""
    log_weights = np.asarray(log_weights, dtype=float)
    runs, n = log_weights.shape
    u = (np.arange(n) + np.stack([g.random(n) for g in _check_rngs(rngs, runs)])) / n
    return _search(_cdf(log_weights), u)


def systematic_indices(log_weights, rngs) -> np.ndarray:
    """A single uniform offset shared by all strata, (i + U)/N, per run. (R, N) int."""
    log_weights = np.asarray(log_weights, dtype=float)
    runs, n = log_weights.shape
    u = (np.arange(n) + np.array([g.random() for g in _check_rngs(rngs, runs)])[:, None]) / n
    return _search(_cdf(log_weights), u)


def residual_indices(log_weights, rngs) -> np.ndarray:
    """floor(N w_i) deterministic copies of each particle, the rest multinomial on the residual weights
    N w_i - floor(N w_i). (R, N) int."""
    log_weights = np.asarray(log_weights, dtype=float)
    runs, n = log_weights.shape
    _check_rngs(rngs, runs)
    nw = n * np.exp(log_weights)
    copies = np.floor(nw).astype(np.int64)
    out = np.empty((runs, n), dtype=np.int64)
    for r in range(runs):
        det = np.repeat(np.arange(n), copies[r])
        rest = n - det.size
        if rest:
            res = nw[r] - copies[r]
            c = np.cumsum(res)
            extra = np.minimum(np.searchsorted(c / c[-1], rngs[r].random(rest), side="right"), n - 1)
            det = np.concatenate([det, extra])
        out[r] = det
    return out


_RESAMPLERS = {"multinomial": multinomial_indices, "systematic": systematic_indices,
               "stratified": stratified_indices, "residual": residual_indices}


def resampling_indices(log_weights, rngs, method: str = "multinomial") -> np.ndarray:
    """Ancestor indices (R, N) by ``method`` (one of :data:`RESAMPLING_METHODS`)."""
    try:
        fn = _RESAMPLERS[method]
    except KeyError:
        raise ConfigError("particles.resampling", f"must be one of {list(RESAMPLING_METHODS)}, got {method!r}") from None
    return fn(log_weights, rngs)


def resample(cloud: ParticleCloud, rngs, method: str = "multinomial", threshold: float = 1.0):
    """Resample the runs whose N_eff < threshold N (threshold 1.0 + 1e-12: always); returns (cloud, mask).

    Only the resampled runs draw random numbers. Particles and weights are permuted together; resampled
    runs get equal weights.
    """
    if not 0.0 <= threshold <= 1.0:
        raise ConfigError("particles.ess_threshold", f"must be in [0, 1], got {threshold!r}")
    mask = cloud.ess() < threshold * cloud.size + (1e-9 if threshold >= 1.0 else 0.0)
    out = cloud.copy()
    rows = np.flatnonzero(mask)
    if rows.size:
        idx = resampling_indices(cloud.log_weights[rows], [rngs[r] for r in rows], method)
        out.particles[rows] = np.take_along_axis(cloud.particles[rows], idx[..., None], axis=1)
        out.log_weights[rows] = -np.log(cloud.size)
    return out, mask


def roughen(particles, rngs, k: float = 0.2, mask=None) -> np.ndarray:
    """Gordon et al. (1993) roughening: add N(0, (k E_j N^(-1/d))^2) to dimension j, E_j = max - min of
    the run's cloud. ``mask`` (R,) selects the runs to roughen (others draw nothing)."""
    particles = np.asarray(particles, dtype=float)
    runs, n, d = particles.shape
    out = particles.copy()
    rows = np.arange(runs) if mask is None else np.flatnonzero(mask)
    if rows.size:
        ext = particles[rows].max(axis=1) - particles[rows].min(axis=1)
        sig = k * ext * n ** (-1.0 / d)
        z = np.stack([rngs[r].standard_normal((n, d)) for r in rows])
        out[rows] += sig[:, None, :] * z
    return out


def kernel_shrinkage(particles, rngs, h: float = 0.2, mask=None) -> np.ndarray:
    """Liu & West (2001) kernel smoothing with shrinkage, for equally weighted (resampled) clouds:
    ``x <- a x + (1 - a) m + h L z`` with ``a = sqrt(1 - h^2)``, m and L L^T the cloud's mean and covariance,
    z ~ N(0, I). Restores diversity while keeping the cloud's mean and covariance (in expectation), unlike
    roughening, which inflates the covariance at every resampling. ``mask`` (R,) selects the runs."""
    if not 0.0 < h < 1.0:
        raise ConfigError("particles.kernel_h", f"must be in (0, 1), got {h!r}")
    particles = np.asarray(particles, dtype=float)
    runs, n, d = particles.shape
    out = particles.copy()
    rows = np.arange(runs) if mask is None else np.flatnonzero(mask)
    if rows.size:
        x = particles[rows]
        m = x.mean(axis=1, keepdims=True)
        dx = x - m
        cov = np.einsum("rni,rnj->rij", dx, dx) / n
        L = np.linalg.cholesky(cov + 1e-12 * np.trace(cov, axis1=1, axis2=2)[:, None, None] * np.eye(d) / d
                               + 1e-300 * np.eye(d))
        z = np.stack([rngs[r].standard_normal((n, d)) for r in rows])
        a = np.sqrt(1.0 - h * h)
        out[rows] = m + a * dx + h * np.einsum("rij,rnj->rni", L, z)
    return out


def add_gaussian_noise(particles, chol, rngs) -> np.ndarray:
    """particles + L z, z ~ N(0, I) per particle; ``chol`` (d, d) or (R, d, d) lower Cholesky factor."""
    particles = np.asarray(particles, dtype=float)
    runs, n, d = particles.shape
    L = np.broadcast_to(np.asarray(chol, dtype=float), (runs, d, d))
    z = np.stack([g.standard_normal((n, d)) for g in _check_rngs(rngs, runs)])
    return particles + np.einsum("rij,rnj->rni", L, z)


def unique_count(particles) -> np.ndarray:
    """Number of distinct particles per run (R,) (diagnostic of impoverishment, T9)."""
    particles = np.asarray(particles)
    return np.array([np.unique(p, axis=0).shape[0] for p in particles])


def tempering_exponent(log_weights, log_likelihood, remaining, target_ess: float = 0.5,
                       iterations: int = 60) -> np.ndarray:
    """Adaptive tempering (progressive correction; Oudjane & Musso 2000, Jasra et al. 2011): per run the largest
    lambda in (0, remaining] whose partial update ``w L^lambda`` keeps N_eff >= target_ess N (bisection;
    ``remaining`` (R,) itself where the whole rest of the likelihood keeps it). log_weights, log_likelihood
    (R, N); -inf likelihoods allowed. Runs with nothing remaining get 0."""
    lw = np.asarray(log_weights, dtype=float)
    ll = np.asarray(log_likelihood, dtype=float)
    rem = np.broadcast_to(np.asarray(remaining, dtype=float), lw.shape[:1]).copy()
    if not 0.0 < target_ess <= 1.0:
        raise ConfigError("particles.target_ess", f"must be in (0, 1], got {target_ess!r}")
    n = lw.shape[1]

    def ess(lam):
        scaled = np.where(np.isneginf(ll), -np.inf, lam[:, None] * np.where(np.isneginf(ll), 0.0, ll))
        post, lse = normalize_log_weights(lw + scaled)
        with np.errstate(divide="ignore", invalid="ignore"):  # runs with zero likelihood everywhere: N_eff 0
            return np.where(np.isfinite(lse), effective_sample_size(post), 0.0)

    ok = ess(rem) >= target_ess * n
    lo, hi = np.zeros_like(rem), rem.copy()
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        good = ess(np.where(mid > 0, mid, hi)) >= target_ess * n
        lo, hi = np.where(good, mid, lo), np.where(good, hi, mid)
    lam = np.where(ok, rem, np.maximum(lo, 1e-12 * rem))  # always progress (a run stuck at N_eff < target)
    return np.where(rem > 0, lam, 0.0)
