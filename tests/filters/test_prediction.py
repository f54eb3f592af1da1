"""``filters.prediction``: stacking and masking predictions, checked through Kalman updates against independent
ones. With independent noises a batch update equals the sequential updates (the information form adds
H_i^T R_i^-1 H_i), so the update with ``stack_predictions([a, b])`` must equal updating with a, then with b; a masked
prediction must update exactly as the prediction of only the kept components."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.filters import update
from sarnav.filters.prediction import Prediction, stack_predictions

RUNS, N = 3, 5


def _spd(rng, n, scale=1.0):
    L = rng.normal(size=(RUNS, n, n))
    return scale * (L @ np.swapaxes(L, -1, -2) / n + 0.1 * np.eye(n))


@pytest.fixture(scope="module")
def parts():
    rng = np.random.default_rng(21)
    a = Prediction(rng.normal(size=(RUNS, 2)), rng.normal(size=(RUNS, 2, N)), _spd(rng, 2, 0.3), names=("x", "y"))
    b = Prediction(rng.normal(size=(RUNS, 1)), rng.normal(size=(RUNS, 1, N)), _spd(rng, 1, 0.1), names=("w",))
    return rng, _spd(rng, N), a, b, rng.normal(size=(RUNS, 3))


def test_stacked_update_equals_sequential_updates(parts):
    rng, P, a, b, z = parts
    both = stack_predictions([a, b])
    assert both.names == ("x", "y", "w") and both.C is None and both.hessians is None
    np.testing.assert_array_equal(both.R[:, :2, 2], 0.0)  # independent parts: block-diagonal noise
    batch = update.joseph(P, both, z)
    first = update.joseph(P, a, z[:, :2])
    # the second update sees the first one's posterior: its prediction moves by H_b dx_1
    b1 = b.replace(z_hat=b.z_hat + (b.H @ first.dx[..., None])[..., 0])
    second = update.joseph(first.P, b1, z[:, 2:])
    np.testing.assert_allclose(batch.P, second.P, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(batch.dx, first.dx + second.dx, rtol=1e-9, atol=1e-12)


def test_masked_components_do_not_update(parts):
    rng, P, a, b, z = parts
    both = stack_predictions([a, b])
    keep = np.array([[True, True, True], [True, False, True], [False, False, False]])
    up = update.joseph(P, both.masked(keep), np.where(keep, z, 1e6))  # the values of dropped components are unused
    for r in range(RUNS):
        idx = np.flatnonzero(keep[r])
        if idx.size == 0:
            np.testing.assert_allclose(up.P[r], P[r], rtol=1e-12)
            np.testing.assert_array_equal(up.dx[r], 0.0)
            continue
        sub = Prediction(both.z_hat[r:r + 1, idx], both.H[r:r + 1, idx], both.R[r:r + 1][:, idx][:, :, idx])
        ref = update.joseph(P[r:r + 1], sub, z[r:r + 1, idx])
        np.testing.assert_allclose(up.P[r], ref.P[0], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(up.dx[r], ref.dx[0], rtol=1e-9, atol=1e-12)


def test_stacking_keeps_cross_covariances_and_hessians_in_place(parts):
    rng, P, a, b, z = parts
    C = rng.normal(size=(RUNS, N, 1))
    A = rng.normal(size=(RUNS, 2, N, N))
    both = stack_predictions([a.replace(hessians=A), b.replace(C=C)])
    np.testing.assert_array_equal(both.C[:, :, 2:], C)
    np.testing.assert_array_equal(both.C[:, :, :2], 0.0)
    np.testing.assert_array_equal(both.hessians[:, :2], A)
    np.testing.assert_array_equal(both.hessians[:, 2:], 0.0)


def test_shapes_are_checked_with_the_field_named(parts):
    rng, P, a, b, z = parts
    with pytest.raises(InputDataError, match="prediction"):
        Prediction(np.zeros((2, 1)), np.zeros((2, 2, N)), np.zeros((2, 1, 1)))
    with pytest.raises(InputDataError, match="prediction.C"):
        a.replace(C=np.zeros((RUNS, N, 3)))
    with pytest.raises(InputDataError, match="predictions"):
        stack_predictions([])
    with pytest.raises(InputDataError, match="predictions"):
        stack_predictions([a, Prediction(np.zeros((1, 1)), np.zeros((1, 1, N)), np.ones((1, 1, 1)))])
    with pytest.raises(InputDataError, match="keep"):
        a.masked(np.ones((RUNS, 3), bool))
