"""``filters.discretization.van_loan`` against closed forms and a quadrature of its defining integral."""

import numpy as np
import pytest
from scipy.linalg import expm

from sarnav.filters.discretization import van_loan


def test_double_integrator_closed_form():
    """Position-velocity with white acceleration of PSD q: Phi = [[1, dt], [0, 1]],
    Q_d = q [[dt^3/3, dt^2/2], [dt^2/2, dt]] (e.g. Bar-Shalom et al. 2001 §6.2.2)."""
    q, dt = 0.37, 0.8
    Phi, Qd = van_loan([[0.0, 1.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, q]], dt)
    np.testing.assert_allclose(Phi, [[1.0, dt], [0.0, 1.0]], atol=1e-14)
    np.testing.assert_allclose(Qd, q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]), rtol=1e-12)


def test_first_order_gauss_markov_closed_form():
    """dx/dt = -x / tau + w (PSD q): Phi = e^(-dt/tau), Q_d = q tau / 2 (1 - e^(-2 dt/tau))."""
    tau, q, dt = 30.0, 2.0e-4, 5.0
    Phi, Qd = van_loan([[-1.0 / tau]], [[q]], dt)
    assert Phi[0, 0] == pytest.approx(np.exp(-dt / tau), rel=1e-13)
    assert Qd[0, 0] == pytest.approx(q * tau / 2 * (1 - np.exp(-2 * dt / tau)), rel=1e-12)


def test_random_model_matches_the_integral_it_defines():
    """Phi = expm(F dt) and Q_d = int_0^dt expm(F s) B Q B^T expm(F s)^T ds (16-point Gauss-Legendre: the integrand
    is analytic, so the rule is exact to rounding over a short step), batched over 3 models."""
    rng = np.random.default_rng(3)
    F = rng.normal(size=(3, 4, 4))
    L = rng.normal(size=(3, 4, 4))
    BQBt = L @ np.swapaxes(L, -1, -2)
    dt = 0.3
    Phi, Qd = van_loan(F, BQBt, dt)
    for k in range(3):
        np.testing.assert_allclose(Phi[k], expm(F[k] * dt), rtol=1e-12)
        x, w = np.polynomial.legendre.leggauss(16)
        integral = sum(0.5 * dt * wi * expm(F[k] * s) @ BQBt[k] @ expm(F[k] * s).T
                       for s, wi in zip(0.5 * dt * (x + 1), w))
        np.testing.assert_allclose(Qd[k], integral, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(Qd[k], Qd[k].T)
        assert np.all(np.linalg.eigvalsh(Qd[k]) > 0)
    # one noise rate broadcast to the batch gives the same as repeating it
    _, Q1 = van_loan(F, BQBt[0], dt)
    _, Q2 = van_loan(F, np.repeat(BQBt[:1], 3, 0), dt)
    np.testing.assert_array_equal(Q1, Q2)
