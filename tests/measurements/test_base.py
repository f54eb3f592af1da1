"""``measurements.base``: the machinery every scalar measurement shares (Jacobian and Hessian placement in the error
state, the bias state, the noise), checked on a toy model h(p, v) = (a . p)(b . v) + |v|^2 / 2 against central
differences of h along dx = truth - estimate (so z(truth) = h(p_hat + dp, v_hat + dv) + b_hat + db)."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.filters.layout import ErrorStateLayout
from sarnav.measurements.base import ScalarBiasedMeasurement, unit_noise

from helpers import level_nav, spawn_rngs

A, B = np.array([0.3, -1.2, 0.5]), np.array([2.0, 0.1, -0.7])
L = ErrorStateLayout(("b_alt", "b_toy"))


class Toy(ScalarBiasedMeasurement):
    names, units = ("toy",), ("m",)

    def model(self, p, v):
        ap, bv = p @ A, v @ B
        return ap * bv + 0.5 * np.sum(v * v, axis=1), A[None] * bv[:, None], B[None] * ap[:, None] + v

    def hessian_blocks(self, p, v):
        R = p.shape[0]
        return np.zeros((R, 3, 3)), np.broadcast_to(np.outer(A, B), (R, 3, 3)), np.broadcast_to(np.eye(3), (R, 3, 3))


def _z(nav, dx):
    """The noise-free measurement of the state nav corrected by dx (truth = estimate + dx)."""
    p, v = nav.p + dx[:, L.slice("p")], nav.v + dx[:, L.slice("v")]
    return Toy(1.0, L, "b_toy").model(p, v)[0] + nav.bm[:, 1] + dx[:, L.index("b_toy")]


@pytest.fixture(scope="module")
def nav():
    rng = np.random.default_rng(6)
    return level_nav(rng.normal(size=(2, 3)) * 50, rng.normal(size=(2, 3)) * 10, [0.0, 0.4])


def test_prediction_jacobian_and_hessian_are_the_derivatives_along_the_error_state(nav):
    pred = Toy(0.25, L, "b_toy").predict(nav)
    np.testing.assert_allclose(pred.z_hat[:, 0], _z(nav, np.zeros((2, L.n))), rtol=1e-14)
    assert pred.R[0, 0, 0] == pytest.approx(0.0625)
    h = 1e-4
    E = np.eye(L.n)
    J = np.stack([(_z(nav, h * E[i][None].repeat(2, 0)) - _z(nav, -h * E[i][None].repeat(2, 0))) / (2 * h)
                  for i in range(L.n)], axis=1)
    np.testing.assert_allclose(pred.H[:, 0], J, rtol=1e-7, atol=1e-7)
    for i in range(L.n):  # d(dz/dx_j)/dx_i: central differences of the Jacobian of h
        Hp = Toy(0.25, L, "b_toy").predict(level_nav(nav.p + h * E[i][L.slice("p")], nav.v + h * E[i][L.slice("v")],
                                                     [0.0, 0.4])).H[:, 0]
        Hm = Toy(0.25, L, "b_toy").predict(level_nav(nav.p - h * E[i][L.slice("p")], nav.v - h * E[i][L.slice("v")],
                                                     [0.0, 0.4])).H[:, 0]
        np.testing.assert_allclose(pred.hessians[:, 0, i], (Hp - Hm) / (2 * h), rtol=1e-7, atol=1e-7)
    np.testing.assert_array_equal(pred.hessians[:, 0], np.swapaxes(pred.hessians[:, 0], -1, -2))


def test_simulate_is_the_model_plus_the_true_bias_plus_sigma_noise(nav):
    m = Toy(0.25, L, "b_toy")
    z0 = _z(nav, np.zeros((2, L.n)))
    np.testing.assert_allclose(m.simulate(nav, noise=np.array([[1.0], [-2.0]]))[:, 0], z0 + [0.25, -0.5], rtol=1e-14)
    z = np.stack([m.simulate(nav, spawn_rngs(2, s))[:, 0] for s in range(4000)])
    assert np.all(np.abs(z.mean(0) - z0) < 4 * 0.25 / np.sqrt(4000))
    np.testing.assert_allclose(z.std(0), 0.25, rtol=0.05)


def test_unit_noise_checks_its_inputs():
    np.testing.assert_array_equal(unit_noise(2, 1, noise=[[0.5], [1.5]]), [[0.5], [1.5]])
    assert unit_noise(3, 2, spawn_rngs(3, 1)).shape == (3, 2)
    with pytest.raises(InputDataError, match="noise"):
        unit_noise(2, 1, noise=[[np.nan], [0.0]])
    with pytest.raises(InputDataError, match="rngs"):
        unit_noise(2, 1, spawn_rngs(1, 1))
