"""``filters.feedback``: the error-state maps of thesis eqs. A.4-A.6. Corrupting a truth by dx and feeding dx back
returns the truth (for the attitude exactly: [1; -a] (x) [1; a] = [1 + |a|^2; 0], the identity up to scale), and the
error state of a corrupted truth is dx to second order in the attitude (first order in the quaternion's vector)."""

import numpy as np
import pytest

from sarnav.filters.feedback import apply_feedback, corrupt_state, error_state
from sarnav.filters.layout import ErrorStateLayout
from sarnav.ins.state import NavState
from sarnav.rotations import quat_normalize, quat_to_dcm

L = ErrorStateLayout(("b_alt", "b_range"))


@pytest.fixture(scope="module")
def truth_and_dx():
    rng = np.random.default_rng(4)
    R = 5
    truth = NavState(rng.normal(size=(R, 3)) * 100, rng.normal(size=(R, 3)) * 10,
                     quat_normalize(rng.normal(size=(R, 4))), rng.normal(size=(R, 3)) * 1e-3,
                     rng.normal(size=(R, 3)) * 1e-5, rng.normal(size=(R, 2)))
    dx = rng.normal(size=(R, L.n)) * 0.01
    return truth, dx


def test_feedback_undoes_the_corruption(truth_and_dx):
    truth, dx = truth_and_dx
    back = apply_feedback(corrupt_state(truth, dx, L), dx, L)
    for name in ("p", "v", "ba", "bg", "bm"):
        np.testing.assert_allclose(getattr(back, name), getattr(truth, name), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(quat_to_dcm(back.q), quat_to_dcm(truth.q), atol=1e-14)


def test_error_state_of_a_corrupted_truth_is_dx(truth_and_dx):
    """Exact for position, velocity and biases; the attitude error of q_hat = [1; dth/2] (x) q is
    -2 vec(q (x) q_hat*) = dth / sqrt(1 + |dth/2|^2): dth to within |dth|^3 / 8."""
    truth, dx = truth_and_dx
    est = corrupt_state(truth, dx, L)
    e = error_state(truth, est, L)
    th = L.slice("th")
    mask = np.ones(L.n, bool)
    mask[th] = False
    np.testing.assert_allclose(e[:, mask], dx[:, mask], rtol=1e-12, atol=1e-12)  # p - (p - dp): rounding of p
    a = dx[:, th]
    expect = a / np.sqrt(1 + np.sum((a / 2) ** 2, axis=1, keepdims=True))
    np.testing.assert_allclose(e[:, th], expect, rtol=1e-10)
    # and the DCM relation the filter's H matrices use: T_true = (I - [dth x]) T_est to first order (eq. 4.9)
    T_true, T_est = quat_to_dcm(truth.q), quat_to_dcm(est.q)
    for r in range(a.shape[0]):
        x, y, z = a[r]
        skew = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
        assert np.abs(T_true[r] - (np.eye(3) - skew) @ T_est[r]).max() < 2 * np.sum(a[r] ** 2)


def test_feedback_does_not_modify_its_input(truth_and_dx):
    truth, dx = truth_and_dx
    before = truth.copy()
    apply_feedback(truth, dx, L)
    for name in ("p", "v", "q", "ba", "bg", "bm"):
        np.testing.assert_array_equal(getattr(truth, name), getattr(before, name))
