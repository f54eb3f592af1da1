"""``filters.second_order``: the Gaussian second-order terms are the mean and covariance of quadratic forms of a
Gaussian (for x ~ N(0, P), symmetric A, B: E[x^T A x / 2] = tr(A P) / 2, Cov(x^T A x / 2, x^T B x / 2) =
tr(A P B P) / 2; Isserlis' theorem), checked by Monte Carlo."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.filters.prediction import Prediction
from sarnav.filters.second_order import batched_terms, second_order_terms, with_second_order, \
    with_second_order_batched


def _sym(rng, n):
    a = rng.normal(size=(n, n))
    return 0.5 * (a + a.T)


def test_terms_are_the_moments_of_the_quadratic_remainder_monte_carlo():
    rng = np.random.default_rng(11)
    n = 4
    A = np.stack([_sym(rng, n), _sym(rng, n)])
    L = rng.normal(size=(n, n))
    P = L @ L.T / n
    dz, C = second_order_terms(A, P)
    x = rng.multivariate_normal(np.zeros(n), P, size=400_000)
    q = 0.5 * np.einsum("si,mij,sj->sm", x, A, x)
    se_mean = q.std(axis=0) / np.sqrt(x.shape[0])
    assert np.all(np.abs(q.mean(axis=0) - dz) < 4.5 * se_mean)
    np.testing.assert_allclose(np.cov(q.T), C, rtol=0.03, atol=0.01 * np.abs(C).max())
    np.testing.assert_allclose(C, C.T)


def test_with_second_order_adds_the_terms_per_run_and_the_batched_form_agrees():
    rng = np.random.default_rng(5)
    runs, m, n = 3, 2, 5
    A = np.stack([[_sym(rng, n) for _ in range(m)] for _ in range(runs)])
    A[:, :, 3:, :] = A[:, :, :, 3:] = 0.0  # the measurement models' pattern: only some states are curved
    L = rng.normal(size=(runs, n, n))
    P = L @ np.swapaxes(L, -1, -2)
    pred = Prediction(rng.normal(size=(runs, m)), rng.normal(size=(runs, m, n)), np.tile(np.eye(m), (runs, 1, 1)),
                      hessians=A)
    out = with_second_order(pred, P)
    for r in range(runs):
        dz = [0.5 * np.trace(A[r, i] @ P[r]) for i in range(m)]
        C = [[0.5 * np.trace(A[r, i] @ P[r] @ A[r, j] @ P[r]) for j in range(m)] for i in range(m)]
        np.testing.assert_allclose(out.z_hat[r] - pred.z_hat[r], dz, rtol=1e-12)
        np.testing.assert_allclose(out.R[r] - pred.R[r], C, rtol=1e-12)
    batched = with_second_order_batched(pred, P)
    np.testing.assert_allclose(batched.z_hat, out.z_hat, rtol=1e-12)
    np.testing.assert_allclose(batched.R, out.R, rtol=1e-12)
    dz_b, _ = batched_terms(A, P)
    np.testing.assert_allclose(dz_b, out.z_hat - pred.z_hat, rtol=1e-12)


def test_bad_inputs_name_the_field():
    pred = Prediction(np.zeros((1, 1)), np.zeros((1, 1, 2)), np.ones((1, 1, 1)))
    with pytest.raises(InputDataError, match="prediction.hessians"):
        with_second_order(pred, np.eye(2)[None])
    with pytest.raises(InputDataError, match="P_toc"):
        second_order_terms(np.zeros((1, 2, 2)), np.full((2, 2), np.nan))
    with pytest.raises(InputDataError, match="hessian"):
        second_order_terms(np.zeros((1, 3, 3)), np.eye(2))
    with pytest.raises(InputDataError, match="^P"):
        with_second_order(pred.replace(hessians=np.zeros((1, 1, 2, 2))), np.eye(2))
