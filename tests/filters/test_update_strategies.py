"""Update strategies on the Prediction contract (sarnav.filters.update, .delayed, .second_order): each against an
independent computation."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.filters import Prediction, correlated_update, delayed, joseph_update, stack_predictions, update


def _pred(rng, runs=2, m=2, n=5, C=False):
    H = rng.standard_normal((runs, m, n))
    A = rng.standard_normal((runs, m, m))
    R = A @ np.swapaxes(A, -1, -2) + np.eye(m)
    return Prediction(rng.standard_normal((runs, m)), H, R, C=0.1 * rng.standard_normal((runs, n, m)) if C else None)


def _cov(rng, runs, n):
    A = rng.standard_normal((runs, n, n))
    return A @ np.swapaxes(A, -1, -2) + n * np.eye(n)


def test_joseph_and_correlated_strategies_are_the_matrix_forms_with_the_residual():
    rng = np.random.default_rng(1)
    P, pred, z = _cov(rng, 2, 5), _pred(rng), rng.standard_normal((2, 2))
    up = update.joseph(P, pred, z)
    dx, Pp, S = joseph_update(P, pred.H, pred.R, z - pred.z_hat)
    np.testing.assert_array_equal(up.dx, dx)
    np.testing.assert_array_equal(up.P, Pp)
    np.testing.assert_array_equal(up.residual, z - pred.z_hat)
    np.testing.assert_allclose(up.residual_sigma, np.sqrt(np.einsum("rii->ri", S)))
    np.testing.assert_allclose(up.nis, [r @ np.linalg.solve(s, r) for r, s in zip(up.residual, S)])
    cpred = _pred(rng, C=True)
    cu = update.correlated(P, cpred, z)
    dx, Pp, _ = correlated_update(P, cpred.H, cpred.R, cpred.C, z - cpred.z_hat)
    np.testing.assert_array_equal(cu.P, Pp)
    # C = None counts as zero: the correlated form agrees with Joseph to rounding
    np.testing.assert_allclose(update.correlated(P, pred, z).P, up.P, rtol=1e-10, atol=1e-12)
    with pytest.raises(InputDataError, match="prediction.C"):
        update.joseph(P, cpred, z)
    with pytest.raises(InputDataError, match="^z"):
        update.joseph(P, pred, z[:, :1])


def test_delayed_state_mapping_matches_the_joint_distribution_of_dx_k_and_the_noise():
    """dx_c = Phi^-1 (dx_k - w), z = H_c dx_c + v: the mapped (H, R, C) are the moments of (dx_k, z)."""
    rng = np.random.default_rng(2)
    n, m = 4, 2
    Phi = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    Phi_inv = np.linalg.inv(Phi)
    Qd = _cov(rng, 1, n)[0] * 0.01
    pred = _pred(rng, runs=1, m=m, n=n)
    mapped = delayed.map_to_update_epoch(pred, Phi_inv[None], Qd[None])
    H_c, R = pred.H[0], pred.R[0]
    np.testing.assert_allclose(mapped.H[0], H_c @ Phi_inv)
    # nu = v - H_c Phi^-1 w: cov(nu) = R + H Q H^T, cov(dx_k, nu) = cov(dx_k, -H w) with dx_k = Phi dx_c + w
    np.testing.assert_allclose(mapped.R[0], R + (H_c @ Phi_inv) @ Qd @ (H_c @ Phi_inv).T)
    np.testing.assert_allclose(mapped.C[0], -Qd @ (H_c @ Phi_inv).T)
    P = _cov(rng, 1, n)
    np.testing.assert_allclose(delayed.covariance_at(P, Phi_inv[None], Qd[None])[0], Phi_inv @ (P[0] - Qd) @ Phi_inv.T)
    with pytest.raises(InputDataError, match="prediction.C"):
        delayed.map_to_update_epoch(mapped, Phi_inv[None], Qd[None])


def test_back_transition_inverts_the_model_transition_and_is_identity_for_no_span():
    from sarnav.filters import ErrorStateLayout, ErrorStateModel

    L = ErrorStateLayout(("b",), scalar_units=("m",))
    model = ErrorStateModel(L, 1e-3, 1e-4, 1e-3, 1e-5, 100.0, 100.0, [0.1], [50.0])
    T = np.eye(3)[None].repeat(2, 0)
    f = np.array([[0.0, 0.0, -9.81]] * 2)
    Phi_inv, Qd = delayed.back_transition(model, T, f, np.array([0.4, 0.0]))
    Phi, Q = model.discretize(T[:1], f[:1], 0.4)
    np.testing.assert_allclose(Phi_inv[0] @ Phi[0], np.eye(L.n), atol=1e-12)
    np.testing.assert_array_equal(Qd[0], Q[0])
    np.testing.assert_array_equal(Phi_inv[1], np.eye(L.n))
    assert np.all(Qd[1] == 0)


def test_stacking_is_block_diagonal_and_keeps_cross_covariances():
    rng = np.random.default_rng(4)
    a, b = _pred(rng, m=1), _pred(rng, m=2, C=True)
    s = stack_predictions([a, b])
    assert s.z_hat.shape == (2, 3) and s.R.shape == (2, 3, 3) and s.C.shape == (2, 5, 3)
    np.testing.assert_array_equal(s.R[:, :1, :1], a.R)
    np.testing.assert_array_equal(s.R[:, 1:, 1:], b.R)
    assert np.all(s.R[:, 0, 1:] == 0) and np.all(s.C[:, :, 0] == 0)
    np.testing.assert_array_equal(s.C[:, :, 1:], b.C)
    with pytest.raises(InputDataError):
        Prediction(np.zeros((2, 1)), np.zeros((2, 2, 5)), np.zeros((2, 1, 1)))
