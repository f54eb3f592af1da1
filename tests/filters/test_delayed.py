"""``filters.delayed``: a measurement of the error state at an earlier epoch t_c, applied at t_k.

Independent computation: with dx(t_c) ~ N(0, P_c), process noise w ~ N(0, Q_d) over [t_c, t_k] and
dx(t_k) = Phi dx(t_c) + w, the joint Gaussian of (dx(t_k), z = H_c dx(t_c) + v) is written down directly; the mapped
prediction (H Phi^-1, R + H Q_d H^T, C = -Q_d H^T) must give the same innovation covariance, cross-covariance and
Kalman posterior (the exact conditional), and ``covariance_at`` must recover P_c from P(t_k)."""

import numpy as np
import pytest
from scipy.linalg import expm

from sarnav.errors import InputDataError
from sarnav.filters import update
from sarnav.filters.delayed import back_transition, covariance_at, map_to_update_epoch
from sarnav.filters.discretization import van_loan
from sarnav.filters.prediction import Prediction

N, M = 4, 2


class _Layout:
    n = N


class _LinearModel:
    """An error model of fixed F and noise rate (what ``back_transition`` needs: ``layout.n`` and ``discretize``)."""

    layout = _Layout()

    def __init__(self, F, BQBt):
        self.F, self.BQBt = F, BQBt

    def discretize(self, T, f, dt):
        Phi, Qd = van_loan(self.F, self.BQBt, dt)
        return Phi[None], Qd[None]


def _spd(rng, n, scale=1.0):
    L = rng.normal(size=(n, n))
    return scale * (L @ L.T / n + 0.1 * np.eye(n))


@pytest.fixture(scope="module")
def case():
    rng = np.random.default_rng(7)
    F = 0.3 * rng.normal(size=(N, N))
    model = _LinearModel(F, _spd(rng, N, 0.05))
    spans = np.array([0.4, 0.0])  # the second run's TOC is the update epoch: nothing to map
    Phi_inv, Qd = back_transition(model, np.zeros((2, 3, 3)), np.zeros((2, 3)), spans)
    Pc = np.stack([_spd(rng, N), _spd(rng, N)])
    Hc = rng.normal(size=(2, M, N))
    R = np.stack([_spd(rng, M, 0.2), _spd(rng, M, 0.2)])
    return dict(F=F, model=model, spans=spans, Phi_inv=Phi_inv, Qd=Qd, Pc=Pc, Hc=Hc, R=R, rng=rng)


def test_back_transition_is_the_inverse_transition_and_identity_for_no_span(case):
    np.testing.assert_allclose(case["Phi_inv"][0], expm(-case["F"] * 0.4), rtol=1e-11)
    _, Qd = van_loan(case["F"], case["model"].BQBt, 0.4)
    np.testing.assert_allclose(case["Qd"][0], Qd, rtol=1e-12)
    np.testing.assert_array_equal(case["Phi_inv"][1], np.eye(N))
    np.testing.assert_array_equal(case["Qd"][1], np.zeros((N, N)))


def test_mapped_prediction_reproduces_the_joint_gaussian_and_its_conditional(case):
    Phi = np.linalg.inv(case["Phi_inv"])
    Pc, Qd, Hc, R = case["Pc"], case["Qd"], case["Hc"], case["R"]
    Pk = Phi @ Pc @ np.swapaxes(Phi, -1, -2) + Qd
    cov_xz = Phi @ Pc @ np.swapaxes(Hc, -1, -2)  # cov(dx(t_k), z): w and v are independent of dx(t_c)
    var_z = Hc @ Pc @ np.swapaxes(Hc, -1, -2) + R
    pred = map_to_update_epoch(Prediction(np.zeros((2, M)), Hc, R), case["Phi_inv"], Qd)
    Ht = np.swapaxes(pred.H, -1, -2)
    np.testing.assert_allclose(Pk @ Ht + pred.C, cov_xz, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(update.innovation_covariance(Pk, pred), var_z, rtol=1e-10)
    z = case["rng"].normal(size=(2, M))
    up = update.correlated(Pk, pred, z)
    gain = cov_xz @ np.linalg.inv(var_z)
    np.testing.assert_allclose(up.dx, (gain @ z[..., None])[..., 0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(up.P, Pk - gain @ np.swapaxes(cov_xz, -1, -2), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(covariance_at(Pk, case["Phi_inv"], Qd), Pc, rtol=1e-10)
    np.testing.assert_array_equal(pred.C[1], 0.0)  # no span: an ordinary measurement


def test_mapping_twice_or_with_wrong_shapes_is_refused(case):
    pred = map_to_update_epoch(Prediction(np.zeros((2, M)), case["Hc"], case["R"]), case["Phi_inv"], case["Qd"])
    with pytest.raises(InputDataError, match="prediction.C"):
        map_to_update_epoch(pred, case["Phi_inv"], case["Qd"])
    with pytest.raises(InputDataError, match="Phi_inv"):
        map_to_update_epoch(Prediction(np.zeros((2, M)), case["Hc"], case["R"]), case["Phi_inv"][:1], case["Qd"])
