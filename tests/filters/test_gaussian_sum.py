"""The Gaussian-sum update (sarnav.filters.gaussian_sum): its split, its criterion and direction, its reduction to the
Gaussian second-order filter with one component, and Monte Carlo consistency on quadratic problems where the
second-order filter is over-confident (truth drawn from the prior, so the exact posterior is calibrated)."""

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.stats import chi2

from sarnav.filters import Prediction, second_order, update
from sarnav.filters import gaussian_sum as gs


def _npdf(x, var):
    return np.exp(-0.5 * x * x / var) / np.sqrt(2 * np.pi * var)


def _l2(w_side, sigma):
    """Squared L2 distance between N(0, 1) and the symmetric three-component split with N(0, 1)'s variance."""
    m = np.sqrt((1 - sigma**2) / (2 * w_side))
    W, M = np.array([w_side, 1 - 2 * w_side, w_side]), np.array([-m, 0.0, m])
    return (np.sum(W[:, None] * W[None] * _npdf(M[:, None] - M[None], 2 * sigma**2))
            - 2 * np.sum(W * _npdf(M, sigma**2 + 1)) + _npdf(0.0, 2.0))


def test_split_keeps_the_mean_and_variance_and_is_the_l2_optimum_for_its_width():
    w, m, s = gs.SPLIT_WEIGHTS, gs.SPLIT_OFFSETS, gs.SPLIT_SIGMA
    assert np.isclose(w.sum(), 1.0, rtol=0, atol=1e-15) and np.all(w > 0)
    assert abs(np.sum(w * m)) < 1e-15
    assert np.isclose(np.sum(w * (m**2 + s**2)), 1.0, rtol=0, atol=1e-14)
    best = minimize_scalar(lambda x: _l2(x, s), bounds=(1e-3, 0.5 - 1e-6), method="bounded", options={"xatol": 1e-12})
    assert abs(best.x - w[0]) < 1e-6
    assert _l2(w[0], s) < 1e-4
    # the split that keeps moments 0..5 but not the shape (1/6, 2/3, 1/6 at -3/2, 0, 3/2, sigma 1/2) is >100x farther
    W, M = np.array([1, 4, 1]) / 6, np.array([-1.5, 0, 1.5])
    far = (np.sum(W[:, None] * W[None] * _npdf(M[:, None] - M[None], 0.5)) - 2 * np.sum(W * _npdf(M, 1.25))
           + _npdf(0.0, 2.0))
    assert far > 100 * _l2(w[0], s)


def _random_problem(rng, runs=3, m=2, n=5):
    B = rng.standard_normal((runs, n, n))
    P = B @ np.swapaxes(B, -1, -2) + 0.5 * np.eye(n)
    A = rng.standard_normal((runs, m, n, n))
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    H = rng.standard_normal((runs, m, n))
    R = np.broadcast_to(np.diag(rng.uniform(0.5, 2.0, m)), (runs, m, m)).copy()
    x0 = rng.standard_normal((runs, n))

    def predict_at(run, dx):  # a quadratic model expanded at x0[run] + dx
        d = dx
        Ad = np.einsum("rmij,rj->rmi", A[run], d)
        z = np.einsum("rmi,ri->rm", H[run], x0[run] + d) + 0.5 * np.einsum("ri,rmi->rm", d, Ad)
        return Prediction(z, H[run] + Ad, R[run], hessians=A[run])

    return P, predict_at, H, R, A


def test_nonlinearity_is_the_remainder_std_over_the_posterior_sigma():
    rng = np.random.default_rng(3)
    P, predict_at, H, R, A = _random_problem(rng, runs=1)
    pred = predict_at(np.array([0]), np.zeros((1, 5)))
    nu = gs.nonlinearity(pred, P)
    dx = rng.multivariate_normal(np.zeros(5), P[0], size=200000)
    rem = 0.5 * np.einsum("si,mij,sj->sm", dx, A[0], dx)
    hph = np.einsum("mi,ij,mj->m", H[0], P[0], H[0])
    post = np.sqrt(1 / (1 / hph + 1 / np.diag(R[0])))
    np.testing.assert_allclose(nu[0], rem.std(axis=0) / post, rtol=0.02)


def test_split_direction_is_that_of_the_largest_remainder_and_keeps_the_mixture_moments():
    # one measurement, curvature only in state 1, P diagonal: the split is along state 1 by its 1-sigma
    P = np.diag([1.0, 4.0, 9.0])[None]
    A = np.zeros((1, 1, 3, 3))
    A[0, 0, 1, 1] = 1.0
    e = gs.split_direction(A, P, np.ones((1, 1)))
    np.testing.assert_allclose(np.abs(e[0]), [0.0, 2.0, 0.0], atol=1e-12)
    rng = np.random.default_rng(5)
    P, predict_at, *_ = _random_problem(rng)
    mix = gs.GaussianSum.single(P, 3)
    mix.means[:, 0] = rng.standard_normal((3, 5))
    m0, P0 = mix.moments()
    gs.split(mix, predict_at, threshold=1e-9)  # three slots: one split per run
    assert np.all(mix.counts == 3)
    m1, P1 = mix.moments()
    np.testing.assert_allclose(m1, m0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(P1, P0, rtol=1e-12, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(mix.covariances) > 0)


def test_one_component_is_the_gaussian_second_order_filter():
    rng = np.random.default_rng(7)
    P, predict_at, *_ = _random_problem(rng)
    z = rng.standard_normal((3, 2))
    out = gs.gaussian_sum_update(gs.GaussianSum.single(P, 5), predict_at, z, threshold=1e9)
    pred = second_order.with_second_order(predict_at(np.arange(3), np.zeros((3, 5))), P)
    ref = update.joseph(P, pred, z)
    assert np.all(out.components == 1)
    for a, b in ((out.update.dx, ref.dx), (out.update.P, ref.P), (out.update.S, ref.S),
                 (out.update.residual, ref.residual)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def _quadratic_campaign(strategy, runs, seed=0, steps=200, dynamic=False):
    """z_k = x1 + x2^2 / (2 rho_k) + v_k: x1 is seen linearly, x2 only at second order (like the cross-track error of
    a target under the track). Static (x1, x2) or with x2' = x3 and process noise on x3. Truth drawn from the prior
    around the estimate. Returns the NEES of every run at the end."""
    rng = np.random.default_rng(seed)
    n = 3 if dynamic else 2
    sig = np.array([0.3, 0.3, 0.3]) if dynamic else np.array([1.0, 6.0])
    rho = np.full(steps, 500.0) if dynamic else 500.0 + 300 * np.abs(np.linspace(-1, 1, steps))
    Phi, Q = np.eye(n), np.zeros((n, n))
    if dynamic:
        Phi[1, 2], Q[2, 2] = 0.1, 0.05**2 * 0.1
    est = np.zeros((runs, n))
    x = rng.standard_normal((runs, n)) * sig
    P = np.broadcast_to(np.diag(sig**2), (runs, n, n)).copy()
    mix = gs.GaussianSum.single(P, 27 if strategy == "gaussian-sum" else 1)
    for k in range(steps):
        x = x @ Phi.T
        est, P = est @ Phi.T, Phi @ P @ Phi.T + Q
        if dynamic:
            x[:, 2] += rng.standard_normal(runs) * np.sqrt(Q[2, 2])
        mix.propagate(np.broadcast_to(Phi, (runs, n, n)), np.broadcast_to(Q, (runs, n, n)), P)
        z = (x[:, 0] + x[:, 1] ** 2 / (2 * rho[k]) + 0.067 * rng.standard_normal(runs))[:, None]

        def predict_at(run, dx):
            p = est[run] + dx
            H = np.zeros((len(run), 1, n))
            H[:, 0, 0], H[:, 0, 1] = 1.0, p[:, 1] / rho[k]
            A = np.zeros((len(run), 1, n, n))
            A[:, 0, 1, 1] = 1.0 / rho[k]
            return Prediction((p[:, 0] + p[:, 1] ** 2 / (2 * rho[k]))[:, None], H, np.full((len(run), 1, 1), 0.067**2),
                              hessians=A)

        if strategy == "ekf":
            up = update.joseph(P, predict_at(np.arange(runs), np.zeros((runs, n))), z)
        else:
            up = gs.gaussian_sum_update(mix, predict_at, z, threshold=0.1).update
        est, P = est + up.dx, up.P
    e = x - est
    return np.sum(e * np.linalg.solve(P, e[..., None])[..., 0], axis=1)


@pytest.mark.parametrize("dynamic", [False, True])
def test_quadratic_problem_is_consistent_with_the_gaussian_sum_and_not_with_second_order_terms_alone(dynamic):
    runs = 1000
    n = 3 if dynamic else 2
    lo, hi = chi2.ppf([0.025, 0.975], n * runs) / runs
    nees = {s: _quadratic_campaign(s, runs, dynamic=dynamic).mean() for s in ("ekf", "second-order", "gaussian-sum")}
    assert nees["ekf"] > 3 * hi and nees["second-order"] > 3 * hi, nees
    assert lo < nees["gaussian-sum"] < hi, (nees, lo, hi)


def test_runs_do_not_depend_on_the_batch():
    rng = np.random.default_rng(11)
    P, predict_at, *_ = _random_problem(rng, runs=4)
    z = rng.standard_normal((4, 2))
    both = gs.gaussian_sum_update(gs.GaussianSum.single(P, 9), predict_at, z, threshold=0.05)
    for r in range(4):
        def one(run, dx, r=r):
            return predict_at(np.full(len(run), r), dx)
        alone = gs.gaussian_sum_update(gs.GaussianSum.single(P[r:r + 1], 9), one, z[r:r + 1], threshold=0.05)
        assert alone.components[0] == both.components[r]
        np.testing.assert_array_equal(alone.update.dx[0], both.update.dx[r])
        np.testing.assert_array_equal(alone.update.P[0], both.update.P[r])
