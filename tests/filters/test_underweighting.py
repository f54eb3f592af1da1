"""Lear underweighting (filters.underweighting; paper eqs. 35-37, 42-43; claim T5, gap G12)."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.filters.ekf import joseph_update
from sarnav.filters.prediction import Prediction
from sarnav.filters.underweighting import LearUnderweighting, underweighted_update

RNG = np.random.default_rng(5)


def _problem(runs=6, n=9, m=4):
    A = RNG.normal(size=(runs, n, n))
    P = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(n)
    H = RNG.normal(size=(runs, m, n))
    B = RNG.normal(size=(runs, m, m))
    R = B @ np.swapaxes(B, 1, 2) + 0.01 * np.eye(m)
    return P, Prediction(np.zeros((runs, m)), H, R), RNG.normal(size=(runs, m))


def test_t5_joseph_with_R_prime_equals_short_form():
    P, pred, res = _problem()
    beta = np.array([0.0, 0.2, 0.5, 1.0, 0.2, 3.0])
    dx, Pp, S = underweighted_update(P, pred, res, beta)
    HPHt = pred.H @ P @ np.swapaxes(pred.H, 1, 2)
    S_35 = (1 + beta)[:, None, None] * HPHt + pred.R  # eq. 35
    K = P @ np.swapaxes(pred.H, 1, 2) @ np.linalg.inv(S_35)  # eq. 36
    assert np.allclose(S, S_35, rtol=1e-12)
    assert np.allclose(dx, (K @ res[..., None])[..., 0], rtol=1e-9, atol=1e-12)  # eq. 37
    assert np.allclose(Pp, P - K @ pred.H @ P, rtol=1e-8, atol=1e-10)  # T5: eq. 42 == P - K H P
    # beta = 0 is the plain Joseph update; beta > 0 leaves a larger posterior (P+_uw - P+_plain is PSD)
    dx0, P0, _ = joseph_update(P, pred.H, pred.R, res)
    assert np.allclose(dx[0], dx0[0]) and np.allclose(Pp[0], P0[0])
    for k in range(1, 6):
        assert np.linalg.eigvalsh(Pp[k] - P0[k]).min() > -1e-9
        assert np.trace(Pp[k]) > np.trace(P0[k])


def test_schedule_by_index_and_by_trace():
    P = np.stack([np.eye(9) * 100.0**2, np.eye(9) * 10.0**2])
    idx = LearUnderweighting(beta=0.2, first_updates=10)
    assert np.array_equal(idx.beta_for(0, P), [0.2, 0.2]) and np.array_equal(idx.beta_for(9, P), [0.2, 0.2])
    assert np.array_equal(idx.beta_for(10, P), [0.0, 0.0])
    tr = LearUnderweighting(beta=0.2, first_updates=None, trace_threshold=100.0)  # sqrt(3 * sigma^2) vs gamma
    assert np.array_equal(tr.beta_for(50, P), [0.2, 0.0])
    both = LearUnderweighting(beta=0.3, first_updates=2, trace_threshold=100.0)
    assert np.array_equal(both.beta_for(1, P), [0.3, 0.3]) and np.array_equal(both.beta_for(5, P), [0.3, 0.0])


@pytest.mark.parametrize("kwargs,field", [({"beta": -0.1}, "underweight_beta"),
                                          ({"first_updates": -1}, "underweight_updates"),
                                          ({"trace_threshold": 0.0}, "underweight_gamma")])
def test_bad_settings(kwargs, field):
    with pytest.raises(ConfigError, match=field):
        LearUnderweighting(**kwargs)
