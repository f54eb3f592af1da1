"""WGS-84 geodesy, ECI <-> ECEF, and point-mass + J2 gravity with its gradient (frames.earth, frames.gravity)."""

import numpy as np
import pytest

from sarnav.frames.earth import (GM_EARTH, J2_EARTH, OMEGA_EARTH, WGS84_A, WGS84_B, ecef_to_eci, ecef_to_geodetic,
                                 eci_to_ecef, eci_to_ecef_dcm, geodetic_to_ecef)
from sarnav.frames.gravity import gravitation, gravitation_gradient, local_gravity, local_gravity_gradient

RNG = np.random.default_rng(7)


def _orbit_points(n=20):
    d = RNG.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True) * RNG.uniform(6.6e6, 7.5e6, (n, 1))


def test_geodetic_known_points_and_round_trip():
    assert np.allclose(geodetic_to_ecef(0.0, 0.0, 0.0), [WGS84_A, 0, 0], atol=1e-6)
    assert np.allclose(geodetic_to_ecef(np.pi / 2, 0.0, 100.0), [0, 0, WGS84_B + 100.0], atol=1e-6)
    lat, lon, h = RNG.uniform(-1.5, 1.5, 50), RNG.uniform(-3, 3, 50), RNG.uniform(-100, 8e5, 50)
    r = geodetic_to_ecef(lat, lon, h)
    la, lo, hh = ecef_to_geodetic(r)
    assert np.allclose(la, lat, atol=1e-11) and np.allclose(lo, lon, atol=1e-11) and np.allclose(hh, h, atol=1e-4)


def test_eci_ecef_rotation():
    t = 1234.5
    C = eci_to_ecef_dcm(t)
    assert np.allclose(C @ C.T, np.eye(3), atol=1e-15)
    assert np.isclose(np.arctan2(-C[1, 0], C[0, 0]), OMEGA_EARTH * t)  # theta(0) = 0 epoch convention
    r_e, v_e = RNG.normal(size=(4, 3)) * 7e6, RNG.normal(size=(4, 3)) * 7e3
    r_i, v_i = ecef_to_eci(t, r_e, v_e)
    r2, v2 = eci_to_ecef(t, r_i, v_i)
    assert np.allclose(r2, r_e, atol=1e-6) and np.allclose(v2, v_e, atol=1e-9)
    # a point fixed on the Earth moves with w x r in the ECI frame
    _, v_fixed = ecef_to_eci(0.0, r_e, np.zeros_like(r_e))
    assert np.allclose(v_fixed, np.cross([0, 0, OMEGA_EARTH], r_e))


def _potential(r):
    """U = mu/r [1 - J2 (R/r)^2 P2(sin phi)]: an independent form of the same field (g = grad U)."""
    rr = np.linalg.norm(r, axis=-1)
    s = r[..., 2] / rr
    return GM_EARTH / rr * (1.0 - J2_EARTH * (WGS84_A / rr) ** 2 * 0.5 * (3 * s * s - 1))


def _central_diff(fun, r, h):
    cols = []
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        cols.append((fun(r + e) - fun(r - e)) / (2 * h))
    return np.stack(cols, axis=-1)


def test_j2_gravity_against_potential_and_k_form():
    r = _orbit_points()
    g = gravitation(r)
    g_pot = _central_diff(_potential, r, 1.0)  # (n, 3): dU/dr_j
    assert np.max(np.abs(g - g_pot)) < 1e-8
    # the extraction's k-form: g = -(mu/r^3)[x(1 - k(5z^2/r^2 - 1)), y(..), z(1 - k(5z^2/r^2 - 3))]
    rr = np.linalg.norm(r, axis=1)
    k = 1.5 * J2_EARTH * (WGS84_A / rr) ** 2
    zz = 5 * r[:, 2] ** 2 / rr**2
    g_k = -(GM_EARTH / rr**3)[:, None] * np.stack(
        [r[:, 0] * (1 - k * (zz - 1)), r[:, 1] * (1 - k * (zz - 1)), r[:, 2] * (1 - k * (zz - 3))], 1)
    assert np.allclose(g, g_k, rtol=1e-13, atol=1e-15)
    # J2 is a ~1e-3 effect: the point-mass part alone is far off
    assert np.max(np.abs(gravitation(r, j2=0.0) - g)) > 1e-3


def test_gravity_gradients_against_central_differences():
    r = _orbit_points()
    G = gravitation_gradient(r)
    G_num = _central_diff(gravitation, r, 10.0)
    # gradients are ~1e-6 1/s^2; the difference quotient's rounding floor is ~1e-16 * 8 m/s^2 / 10 m ~ 1e-16
    assert np.max(np.abs(G - G_num)) < 1e-8 * np.max(np.abs(G))
    assert np.allclose(G, np.swapaxes(G, -1, -2), atol=1e-20)  # Hessian of a potential
    Gl = local_gravity_gradient(r)
    Gl_num = _central_diff(local_gravity, r, 10.0)
    assert np.max(np.abs(Gl - Gl_num)) < 1e-8 * np.max(np.abs(Gl))
    # dropping the J2 part of the gradient is visible at this tolerance (the test can fail)
    assert np.max(np.abs(gravitation_gradient(r, j2=0.0) - G_num)) > 1e-3 * np.max(np.abs(G))
    w = np.array([0, 0, OMEGA_EARTH])
    assert np.allclose(local_gravity(r) - gravitation(r), -np.cross(w, np.cross(w, r)), atol=1e-12)


@pytest.mark.parametrize("shape", [(3,), (2, 4, 3)])
def test_gravity_shapes(shape):
    r = RNG.normal(size=shape) * 1e6 + 7e6
    assert gravitation(r).shape == shape and gravitation_gradient(r).shape == shape + (3,)
