"""Gaussian-sum measurement update that splits the prior where a measurement's second-order term is large.

Why (docs/scenarios/telemetry.md, "Target under the track"): the Gaussian second-order filter
(``filters.second_order``, Gelb 1974 §6.1) adds the variance of the quadratic remainder ``dx^T A dx / 2`` to R as if
it were white noise. The remainder is a function of the error itself, which persists from one update to the next
(measured: autocorrelation 0.82 over 100 updates), so where it is not small the filter treats one slowly varying
error as many independent ones and becomes over-confident. Splitting a component along the direction in which the
remainder is largest shrinks the remainder of each child; the children's weights carry what the measurements say
about that direction (Alspach & Sorenson 1972, Gaussian sums; splitting in the measurement update along the
direction of largest nonlinearity when a Hessian-based measure exceeds a threshold: Tuggle & Zanetti 2018,
Huber 2011, DeMars, Bishop & Jah 2013).

Criterion, per component and measurement component m (``nonlinearity``)::

    nu_m = s_m / sigma_post,m,   s_m^2 = tr(A_m P A_m P) / 2,   sigma_post,m^2 = (1/(H P H^T)_mm + 1/R_mm)^-1

the remainder's standard deviation against the 1-sigma the filter will claim for h_m(x) after the update: a
persistent error is harmless only when it is small against the accuracy the filter claims. A component whose
largest nu exceeds ``threshold`` is split while its run has two free slots (the worst first).

Split (``SPLIT_WEIGHTS``, ``SPLIT_OFFSETS``, ``SPLIT_SIGMA``): N(0, 1) is replaced by three components of standard
deviation 0.7 whose weights and offsets keep its mean and variance and, under that constraint, minimise the L2
distance to it (the univariate-library construction of DeMars, Bishop & Jah 2013, with the variance kept exactly);
along the whitened direction u of largest remainder (L L^T = P, u the leading eigenvector of
sum_m (L^T A_m L)^2 / sigma_post,m^2, e = L u)::

    N(0, 1) ~ 0.2076 N(-1.1083, 0.49) + 0.5848 N(0, 0.49) + 0.2076 N(1.1083, 0.49)   (L2 distance^2 8.2e-5)
    children: weight w * SPLIT_WEIGHTS, mean mu + SPLIT_OFFSETS e, covariance P - (1 - 0.49) e e^T

so each child's remainder variance along u falls to 0.49^2 = 0.24 of its parent's. A split that keeps only the
moments is not enough: 1/6 N(-3/2, 1/4) + 2/3 N(0, 1/4) + 1/6 N(3/2, 1/4) (moments 0..5 equal, L2 distance^2
1.8e-2) left the filter 10 % over-confident on the quadratic test problem of tests/filters/test_gaussian_sum.py, where
this split matches the exact posterior.

Every component is then updated with the second-order terms under its own covariance (``second_order.batched_terms``) and the Joseph form, re-weighted by its
likelihood N(r; 0, S); weights below ``PRUNE`` of the largest are dropped; the estimate fed back is the mixture mean
and P its covariance. The residual and S reported are those of the mixture's predicted measurement.

Components live in a fixed number of slots per run (``GaussianSum``), relative to the navigation estimate (error-state
means), and share its transition between updates (``propagate``). One component is exactly the Gaussian second-order
filter. Each run's arithmetic uses its own rows only (batch-independent).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from sarnav.errors import InputDataError
from sarnav.filters.ekf import joseph_update, normalized_squared, symmetrize
from sarnav.filters.prediction import Prediction
from sarnav.filters.second_order import batched_terms
from sarnav.filters.update import Update

__all__ = ["GaussianSum", "GaussianSumUpdate", "nonlinearity", "split_direction", "gaussian_sum_update",
           "SPLIT_WEIGHTS", "SPLIT_OFFSETS", "SPLIT_SIGMA", "PRUNE"]

#: the three-component split of N(0, 1) (module docstring): common standard deviation, side weight (the L2-optimal one
#: for this sigma and an exact variance, checked in tests/filters/test_gaussian_sum.py), weights and offsets
SPLIT_SIGMA = 0.7
_SIDE_WEIGHT = 0.2076177269
SPLIT_WEIGHTS = np.array([_SIDE_WEIGHT, 1.0 - 2.0 * _SIDE_WEIGHT, _SIDE_WEIGHT])
SPLIT_OFFSETS = np.sqrt((1.0 - SPLIT_SIGMA**2) / (2.0 * _SIDE_WEIGHT)) * np.array([-1.0, 0.0, 1.0])
#: components whose weight falls below this fraction of the largest are dropped (numerical floor)
PRUNE = 1e-9


@dataclass
class GaussianSum:
    """Mixture of error-state Gaussians for R runs in K slots: ``weights`` (R, K), 0 in a free slot; ``means``
    (R, K, n) relative to the navigation estimate; ``covariances`` (R, K, n, n)."""

    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray

    @classmethod
    def single(cls, P, slots: int) -> "GaussianSum":
        """One component of covariance ``P`` (R, n, n), zero mean, in ``slots`` >= 1 slots."""
        P = np.asarray(P, dtype=np.float64)
        R, n = P.shape[0], P.shape[-1]
        w = np.zeros((R, slots))
        w[:, 0] = 1.0
        C = np.zeros((R, slots, n, n))
        C[:, 0] = P
        return cls(w, np.zeros((R, slots, n)), C)

    @property
    def counts(self) -> np.ndarray:
        """(R,) number of components of each run."""
        return np.count_nonzero(self.weights > 0, axis=1)

    def propagate(self, Phi, Qd, P_single) -> None:
        """Advance every component by the shared transition (Phi (R, n, n), Qd (R, n, n)) over an interval; a run
        with one component takes ``P_single`` (R, n, n), the covariance the flight propagated step by step."""
        counts = self.counts
        run, slot = self.rows()
        multi = counts[run] > 1
        if np.any(multi):
            r, k = run[multi], slot[multi]
            F = Phi[r]
            self.means[r, k] = (F @ self.means[r, k][..., None])[..., 0]
            self.covariances[r, k] = symmetrize(F @ self.covariances[r, k] @ np.swapaxes(F, -1, -2) + Qd[r])
        one = ~multi
        self.covariances[run[one], slot[one]] = P_single[run[one]]

    def rows(self) -> tuple[np.ndarray, np.ndarray]:
        """(run, slot) of every component, sorted by run then slot (every run has at least one)."""
        return np.nonzero(self.weights > 0)

    def moments(self) -> tuple[np.ndarray, np.ndarray]:
        """Mixture mean (R, n) and covariance (R, n, n)."""
        run, slot = self.rows()
        w, mu = self.weights[run, slot], self.means[run, slot]
        m = _per_run_sum(run, w[:, None] * mu)
        d = mu - m[run]
        P = _per_run_sum(run, w[:, None, None] * (self.covariances[run, slot] + d[:, :, None] * d[:, None, :]))
        return m, symmetrize(P)

    def recentre(self, mean) -> None:
        """The navigation estimate moved by ``mean`` (R, n): component means are now relative to it."""
        run, slot = self.rows()
        self.means[run, slot] -= np.asarray(mean)[run]


def _per_run_sum(run, x):
    """Sum of the rows of x (N, ...) of each run; ``run`` sorted, every run present (one row: the row itself)."""
    starts = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
    return np.add.reduceat(x, starts, axis=0)


@dataclass(frozen=True)
class GaussianSumUpdate:
    """``update``: the mixture's Update (dx = mixture mean, P, S and residual of the mixture's predicted
    measurement); ``components`` (R,) used in the update; ``nonlinearity`` (R, m) the largest nu over the components
    after splitting (above the threshold only where a run had no free slots left)."""

    update: Update
    components: np.ndarray
    nonlinearity: np.ndarray


def _post_variance(pred: Prediction, P) -> np.ndarray:
    hph = np.einsum("rmi,rij,rmj->rm", pred.H, P, pred.H)
    r2 = np.einsum("rii->ri", pred.R)
    return hph * r2 / (hph + r2)


def _terms(pred: Prediction, P):
    """Second-order terms dz (R, m), C (R, m, m), posterior variances (R, m) and nu (R, m)."""
    if pred.hessians is None:
        raise InputDataError("prediction.hessians", "the nonlinearity measure needs the measurement's Hessians")
    dz, C = batched_terms(pred.hessians, P)
    s2 = np.maximum(np.einsum("rii->ri", C), 0.0)
    post2 = _post_variance(pred, P)
    nu2 = np.where(s2 > 0, np.inf, 0.0)
    np.divide(s2, post2, out=nu2, where=post2 > 0)
    return dz, C, post2, np.sqrt(nu2)


def nonlinearity(pred: Prediction, P) -> np.ndarray:
    """(R, m) nu = s / sigma_post (module docstring) of a prediction with Hessians under covariance P (R, n, n)."""
    return _terms(pred, P)[3]


def split_direction(hessians, P, post2) -> np.ndarray:
    """(N, n) e = L u: the direction of largest remainder (module docstring); hessians (N, m, n, n), P (N, n, n),
    post2 (N, m) the posterior variances that weight the components."""
    lam, U = np.linalg.eigh(P)
    L = U * np.sqrt(np.maximum(lam, 0.0))[:, None, :]
    B = np.swapaxes(L, -1, -2)[:, None] @ hessians @ L[:, None]
    scale = np.max(post2, axis=1, keepdims=True)
    weight = 1.0 / np.maximum(post2, 1e-12 * scale + np.finfo(float).tiny)
    M = np.einsum("rm,rmij->rij", weight, B @ B)
    u = np.linalg.eigh(symmetrize(M))[1][..., -1]
    return np.einsum("rij,rj->ri", L, u)


def _choose(run, worst, free, threshold) -> np.ndarray:
    """Rows to split now: per run, the components above the threshold, worst first, while two slots are free."""
    order = np.lexsort((-worst, run))
    rank = np.empty(run.size, dtype=int)
    starts = np.searchsorted(run[order], run[order], side="left")
    rank[order] = np.arange(run.size) - starts
    return (worst > threshold) & (rank < free[run] // 2)


def _split_rows(mix: GaussianSum, run, slot, e) -> None:
    """Split the components (run[i], slot[i]) along e[i] into their slot and two free slots of their run."""
    for i, (r, k) in enumerate(zip(run.tolist(), slot.tolist())):
        free = np.flatnonzero(mix.weights[r] == 0)[:2]  # the slots filled by this loop are no longer free
        w, mu, P = mix.weights[r, k], mix.means[r, k].copy(), mix.covariances[r, k]
        child = symmetrize(P - (1.0 - SPLIT_SIGMA**2) * np.outer(e[i], e[i]))
        for s, cw, off in zip((free[0], k, free[1]), SPLIT_WEIGHTS, SPLIT_OFFSETS):
            mix.weights[r, s] = w * cw
            mix.means[r, s] = mu + off * e[i]
            mix.covariances[r, s] = child


def split(mix: GaussianSum, predict_at: Callable, threshold: float):
    """Split components (in place) until none of a run with free slots exceeds ``threshold``.

    Returns the rows (run, slot) of the components, their Prediction with the second-order terms under their own
    covariance added, and the largest nu of each run (R, m)."""
    while True:
        run, slot = mix.rows()
        pred = predict_at(run, mix.means[run, slot])
        P = mix.covariances[run, slot]
        dz, C, post2, nu = _terms(pred, P)
        pick = _choose(run, nu.max(axis=1), mix.weights.shape[1] - mix.counts, threshold)
        if not pick.any():
            starts = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
            return (run, slot), pred.replace(z_hat=pred.z_hat + dz, R=pred.R + C), np.maximum.reduceat(nu, starts, axis=0)
        _split_rows(mix, run[pick], slot[pick], split_direction(pred.hessians[pick], P[pick], post2[pick]))


def _mixture_prediction(run, w, z_hat, S):
    z_mix = _per_run_sum(run, w[:, None] * z_hat)
    d = z_hat - z_mix[run]
    return z_mix, symmetrize(_per_run_sum(run, w[:, None, None] * (S + d[:, :, None] * d[:, None, :])))


def _reweight(mix: GaussianSum, run, slot, r, S) -> None:
    loglik = -0.5 * normalized_squared(r, S) - 0.5 * np.linalg.slogdet(S)[1]
    logw = np.full(mix.weights.shape, -np.inf)
    logw[run, slot] = np.log(mix.weights[run, slot]) + loglik
    logw -= np.max(logw, axis=1, keepdims=True)
    w = np.exp(logw)
    gone = (w < PRUNE) & (mix.weights > 0)
    w[w < PRUNE] = 0.0
    mix.weights = w / np.sum(w, axis=1, keepdims=True)
    mix.means[gone] = 0.0
    mix.covariances[gone] = 0.0


def gaussian_sum_update(mix: GaussianSum, predict_at: Callable, z, threshold: float) -> GaussianSumUpdate:
    """Split, update every component, re-weight (module docstring). ``mix`` is changed in place and is left
    relative to the *corrected* estimate (the caller feeds ``update.dx`` back into its navigation state).

    ``predict_at(run (N,), dx (N, n)) -> Prediction`` (N rows, with Hessians): the measurement predicted from the
    navigation estimate of run ``run[i]`` corrected by ``dx[i]``. ``z`` (R, m) the measurements."""
    z = np.asarray(z, dtype=np.float64)
    (run, slot), pred, worst = split(mix, predict_at, threshold)
    components = mix.counts
    P = mix.covariances[run, slot]
    r = z[run] - pred.z_hat
    dx, P_post, S = joseph_update(P, pred.H, pred.R, r)
    z_mix, S_mix = _mixture_prediction(run, mix.weights[run, slot], pred.z_hat, S)
    mix.means[run, slot] += dx
    mix.covariances[run, slot] = P_post
    _reweight(mix, run, slot, r, S)
    mean, P_mix = mix.moments()
    mix.recentre(mean)
    return GaussianSumUpdate(Update(mean, P_mix, S_mix, z - z_mix), components, worst)
