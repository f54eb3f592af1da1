"""Spacecraft MEKF pieces (filters.mekf): F, G, Q (eqs. 12-15, G6, G7), numba propagation, reset (T6), errors."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.filters.mekf import (MekfModel, covariance_propagation_reference, disperse, error_state,
                                 noise_input_matrix, process_noise, propagate, reset, transition_matrix)
from sarnav.ins.orbital import OrbitalNavState, mechanization_step
from sarnav.rotations import quat_normalize, quat_to_dcm, skew
from sarnav.trajectory.orbit import initial_ecef_state, table2_elements

RNG = np.random.default_rng(11)


@pytest.fixture(scope="module")
def rv():
    r, v = initial_ecef_state(table2_elements())
    return r[None], v[None]


def _state(r, v, n=1):
    return OrbitalNavState(np.repeat(r, n, 0), np.repeat(v, n, 0), quat_normalize(RNG.normal(size=(n, 4))))


def test_coriolis_F_is_the_exact_jacobian_of_the_mechanization_step(rv):
    r, v = rv
    dt = 0.01

    def increment(rr, vv):  # step minus its large linear part, to keep the difference quotient above rounding
        r1, v1 = mechanization_step(rr, vv, dt)
        return np.concatenate([r1 - rr - vv * dt, v1 - vv], axis=1)[0]

    J = np.zeros((6, 6))
    for j in range(6):
        e = np.zeros(6)
        e[j] = 10.0
        J[:, j] = (increment(r + e[:3], v + e[3:]) - increment(r - e[:3], v - e[3:])) / 20.0
    J += np.eye(6)
    J[:3, 3:] += np.eye(3) * dt
    F_full = transition_matrix(r, dt, coriolis=True)[0]
    F_paper = transition_matrix(r, dt, coriolis=False)[0]
    assert np.max(np.abs(F_full[:6, :6] - J)) < 0.01 * np.max(np.abs(F_full - F_paper))
    assert np.max(np.abs(F_paper[:6, :6] - J)) > 0.5 * np.max(np.abs(F_full - F_paper))
    W = skew([0, 0, 7.292115e-5])
    assert np.allclose(F_full[3:6, 3:6] - F_paper[3:6, 3:6], -2 * W * dt)  # G7: what eq. 13 omits
    assert np.allclose(F_paper[3:6, 3:6], np.eye(3)) and np.allclose(F_paper[6:, 6:], np.eye(3))


def test_process_noise_literal_is_G_Q_Gt_dt_and_standard_form():
    dt, qa, qm = 0.01, 3.5e-11, 3.4e-13
    T = quat_to_dcm(quat_normalize(RNG.normal(size=(3, 4))))
    G = noise_input_matrix(T, dt)
    Q = np.diag([qa] * 3 + [qm] * 3)
    lit = G @ Q @ np.swapaxes(G, -1, -2) * dt  # eq. 12 as printed; T drops out (isotropic Q)
    assert np.allclose(lit, process_noise(dt, qa, qm, literal=True), rtol=1e-12, atol=1e-30)
    std = process_noise(dt, qa, qm, literal=False)
    assert std[3, 3] == pytest.approx(qa * dt) and std[0, 0] == pytest.approx(qa * dt**3 / 3)
    assert std[6, 6] == pytest.approx(lit[0, 6, 6]) == qm * dt  # misalignment block identical in both readings


def test_numba_propagation_equals_numpy_reference(rv):
    r, v = rv
    st = _state(r, v, 3)
    st.r[1] += 500.0
    A = RNG.normal(size=(3, 9, 9))
    P0 = A @ np.swapaxes(A, 1, 2) + np.eye(9)
    for coriolis in (False, True):
        model = MekfModel(coriolis=coriolis, literal_q=not coriolis)
        st_k, P_k = propagate(st, P0, 5, model)
        P_ref, rr, vv = P0.copy(), st.r.copy(), st.v.copy()
        for _ in range(5):
            P_ref = covariance_propagation_reference(P_ref, rr, model)
            rr, vv = mechanization_step(rr, vv, model.dt)
        assert np.allclose(P_k, P_ref, rtol=1e-12, atol=1e-12)
        assert np.allclose(st_k.r, rr, rtol=0, atol=1e-7) and np.array_equal(st_k.q_mu, st.q_mu)
    # runs are independent of the batch
    one, P1 = propagate(st.select([1]), P0[1:2], 5, model)
    assert np.array_equal(one.r[0], st_k.r[1]) and np.array_equal(P1[0], P_k[1])


def test_reset_keeps_unit_quaternion_and_dmu_convention(rv):
    """T6, eqs. 40-41: after the reset |q| = 1 and T_mu+ = R(dmu)^T T_mu- (I - [dmu x] to first order)."""
    r, v = rv
    st = _state(r, v, 50)
    dx = RNG.normal(size=(50, 9)) * np.r_[[100.0] * 3, [1.0] * 3, [0.05] * 3]
    new = reset(st, dx)
    assert np.allclose(np.linalg.norm(new.q_mu, axis=1), 1.0, atol=1e-15)
    assert np.allclose(new.r, st.r + dx[:, :3]) and np.allclose(new.v, st.v + dx[:, 3:6])
    # the estimate moved by dmu: error_state(new, old) = -dmu... i.e. old = truth would have error -dmu w.r.t. new
    assert np.allclose(error_state(new, st)[:, 6:], dx[:, 6:], atol=1e-12)
    small = dx[:, 6:] * 1e-3
    Tn = quat_to_dcm(reset(st, np.c_[np.zeros((50, 6)), small]).q_mu)
    assert np.allclose(Tn, (np.eye(3) - skew(small)) @ quat_to_dcm(st.q_mu), atol=1e-9)


def test_disperse_gives_the_drawn_error(rv):
    r, v = rv
    truth = OrbitalNavState(np.repeat(r, 4, 0), np.repeat(v, 4, 0), np.tile([1.0, 0, 0, 0], (4, 1)))
    sig = np.r_[[1000.0] * 3, [10.0] * 3, [np.radians(0.1)] * 3]
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(1).spawn(4)]
    est, e = disperse(truth, sig, rngs)
    assert np.allclose(error_state(truth, est), e, atol=1e-12)
    rngs2 = [np.random.default_rng(s) for s in np.random.SeedSequence(1).spawn(4)[2:3]]
    assert np.array_equal(disperse(truth.select([2]), sig, rngs2)[1][0], e[2])
    with pytest.raises(ConfigError, match="initial.sigma"):
        disperse(truth, sig[:8], rngs)


def test_model_validation():
    with pytest.raises(ConfigError, match="q_accel"):
        MekfModel(q_accel=-1.0)
    with pytest.raises(ConfigError, match="dt"):
        MekfModel(dt=0.0)
