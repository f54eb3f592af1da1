"""EKF steps: Joseph update against independent forms, Riccati steady state, feedback, layouts,
and bit-identity of every batched step whatever the batch size."""

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters import (
    ErrorStateLayout,
    apply_feedback,
    joseph_update,
    normalized_squared,
    propagate_covariance,
)
from sarnav.ins import NavState
from sarnav.rotations import quat_multiply, quat_normalize


def _spd(rng, runs, n):
    A = rng.standard_normal((runs, n, n))
    return A @ np.swapaxes(A, 1, 2) + n * np.eye(n)


def test_joseph_update_matches_information_form():
    rng = np.random.default_rng(0)
    P = _spd(rng, 4, 6)
    H = rng.standard_normal((4, 3, 6))
    R = _spd(rng, 4, 3)
    r = rng.standard_normal((4, 3))
    dx, Pp, S = joseph_update(P, H, R, r)
    for i in range(4):
        Ri = np.linalg.inv(R[i])
        P_info = np.linalg.inv(np.linalg.inv(P[i]) + H[i].T @ Ri @ H[i])
        np.testing.assert_allclose(Pp[i], P_info, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(dx[i], P_info @ H[i].T @ Ri @ r[i], rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(S[i], H[i] @ P[i] @ H[i].T + R[i], rtol=1e-13)
    np.testing.assert_array_equal(Pp, np.swapaxes(Pp, 1, 2))  # exactly symmetric


def test_riccati_steady_state():
    """Propagate + update on a constant-velocity model converges to the DARE solution."""
    dt, q, r = 0.1, 0.3, 0.5
    Phi = np.array([[1.0, dt], [0.0, 1.0]])
    Qd = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])  # Van Loan of white acceleration
    H = np.array([[1.0, 0.0]])
    P = np.eye(2)[None] * 100.0
    for _ in range(2000):
        P = propagate_covariance(P, Phi[None], Qd[None])
        _, P, _ = joseph_update(P, H[None], np.array([[r]]), np.zeros((1, 1)))
    prior = solve_discrete_are(Phi.T, H.T, Qd, np.array([[r]]))  # steady prior covariance
    K = prior @ H.T / (H @ prior @ H.T + r)
    np.testing.assert_allclose(P[0], (np.eye(2) - K @ H) @ prior, rtol=1e-9)


def test_steps_are_bit_identical_for_any_batch_size():
    rng = np.random.default_rng(1)
    R = 37
    P = _spd(rng, R, 18)
    Phi = np.eye(18) + 0.01 * rng.standard_normal((R, 18, 18))
    Qd = _spd(rng, R, 18) * 1e-3
    H = rng.standard_normal((R, 3, 18))
    Rm = _spd(rng, R, 3)
    r = rng.standard_normal((R, 3))
    full_P = propagate_covariance(P, Phi, Qd)
    full = joseph_update(full_P, H, Rm, r)
    nees = normalized_squared(r, full[2])
    for sl in (slice(0, 1), slice(5, 6), slice(3, 20), slice(36, 37)):
        part_P = propagate_covariance(P[sl], Phi[sl], Qd[sl])
        np.testing.assert_array_equal(part_P, full_P[sl])
        part = joseph_update(part_P, H[sl], Rm[sl], r[sl])
        for a, b in zip(part, full):
            np.testing.assert_array_equal(a, b[sl])
        np.testing.assert_array_equal(normalized_squared(r[sl], part[2]), nees[sl])


def test_normalized_squared_and_bad_residual():
    rng = np.random.default_rng(2)
    C = _spd(rng, 3, 4)
    e = rng.standard_normal((3, 4))
    ref = [e[i] @ np.linalg.inv(C[i]) @ e[i] for i in range(3)]
    np.testing.assert_allclose(normalized_squared(e, C), ref, rtol=1e-12)
    with pytest.raises(InputDataError, match="residual"):
        joseph_update(C[:, :2, :2], np.eye(2)[None].repeat(3, 0), np.eye(2), np.array([[np.nan, 0.0]] * 3))


def test_feedback_applies_eq_3_23():
    L = ErrorStateLayout(("b_alt",))
    rng = np.random.default_rng(3)
    q = quat_normalize(rng.standard_normal((2, 4)))
    nav = NavState(rng.standard_normal((2, 3)), rng.standard_normal((2, 3)), q,
                   rng.standard_normal((2, 3)), rng.standard_normal((2, 3)), rng.standard_normal((2, 1)))
    dx = 0.01 * rng.standard_normal((2, L.n))
    out = apply_feedback(nav, dx, L)
    np.testing.assert_allclose(out.p, nav.p + dx[:, 0:3])
    np.testing.assert_allclose(out.v, nav.v + dx[:, 3:6])
    dq = np.concatenate([np.ones((2, 1)), -0.5 * dx[:, 6:9]], axis=1)
    np.testing.assert_allclose(out.q, quat_normalize(quat_multiply(dq, q)), rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(out.q, axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(out.ba, nav.ba + dx[:, 9:12])
    np.testing.assert_allclose(out.bg, nav.bg + dx[:, 12:15])
    np.testing.assert_allclose(out.bm, nav.bm + dx[:, 15:16])
    np.testing.assert_array_equal(nav.q, q)  # input untouched


def test_layouts():
    ch3 = ErrorStateLayout(("b_alt", "b_range", "b_rate"))
    assert ch3.n == 18
    assert ch3.state_names() == "pN pE pD vN vE vD thN thE thD baX baY baZ bgX bgY bgZ b_alt b_range b_rate".split()
    assert ch3.index("b_range") == 16 and ch3.slice("bg") == slice(12, 15)
    ch5 = ErrorStateLayout(("b_alt", "b_range", "b_cross"))
    assert ch5.index("b_cross") == 17
    nine = ErrorStateLayout(blocks=("p", "v", "th"))
    assert nine.n == 9 and not nine.has("ba")
    with pytest.raises(ConfigError, match="layout.blocks"):
        ErrorStateLayout(blocks=("p", "th", "v"))
    with pytest.raises(ConfigError, match="layout.scalar_biases"):
        ErrorStateLayout(("b", "b"))
    with pytest.raises(KeyError):
        nine.slice("bg")
