"""Earth gravitation: point mass + J2, its gradient, and the local (plumb-line) gravity of an Earth-fixed frame.

Extraction seed-002 §2.3 (the paper, Pogorelsky et al. 2022, gives no formula: gap G2). With z the spin axis,
r = |r|, c = 3/2 mu J2 R_e^2 and f(r, z) = 5 z^2 / r^7 - 1 / r^5::

    g(r)   = -mu r / r^3 + c [ f r - 2 z e_z / r^5 ]                       (point mass + J2, any frame with z = spin)
    dg/dr  =  mu / r^3 (3 r r^T / r^2 - I)
            + c [ f I + r (df/dr)^T - 2 e_z (e_z / r^5 - 5 z r / r^7)^T ],  df/dr = 10 z e_z / r^7 + (5/r^7 - 35 z^2/r^9) r
    g_l    = g - w x (w x r)                                              (paper eq. 9: mass attraction + centrifugal)
    dg_l/dr = dg/dr - [w x][w x]                                          (paper eq. 14)

The gradient includes J2 (the paper leaves it open). The kernels are numba functions on one 3-vector so that the
mechanization and covariance kernels (``sarnav.ins.orbital``, ``sarnav.filters.mekf``) call them per step; the
``*_batch``/public functions take stacks (..., 3). SI units, ECEF (or the ECI frame of ``frames.earth``).
"""

from __future__ import annotations

import numba
import numpy as np

from sarnav.frames.earth import GM_EARTH, J2_EARTH, OMEGA_EARTH, WGS84_A

__all__ = ["gravitation", "gravitation_gradient", "local_gravity", "local_gravity_gradient", "J2_COEFF"]

#: c = 3/2 mu J2 R_e^2 [m^5/s^2]
J2_COEFF = 1.5 * GM_EARTH * J2_EARTH * WGS84_A**2


@numba.njit(cache=True)
def gravitation_vec(x, y, z, mu, c):
    """Point mass + J2 mass attraction at (x, y, z) [m] -> (gx, gy, gz) [m/s^2] (module docstring)."""
    r2 = x * x + y * y + z * z
    r = np.sqrt(r2)
    ir3 = 1.0 / (r2 * r)
    ir5 = ir3 / r2
    f = 5.0 * z * z * ir5 / r2 - ir5
    gx = -mu * x * ir3 + c * f * x
    gy = -mu * y * ir3 + c * f * y
    gz = -mu * z * ir3 + c * (f * z - 2.0 * z * ir5)
    return gx, gy, gz


@numba.njit(cache=True)
def gravitation_gradient_fill(x, y, z, mu, c, out):
    """dg/dr (3, 3) of :func:`gravitation_vec` at (x, y, z), written into ``out``."""
    rv = (x, y, z)
    r2 = x * x + y * y + z * z
    r = np.sqrt(r2)
    ir3 = 1.0 / (r2 * r)
    ir5 = ir3 / r2
    ir7 = ir5 / r2
    f = 5.0 * z * z * ir7 - ir5
    a = 5.0 * ir7 - 35.0 * z * z * ir7 / r2
    for i in range(3):
        for j in range(3):
            dij = 1.0 if i == j else 0.0
            dfj = a * rv[j] + (10.0 * z * ir7 if j == 2 else 0.0)
            v = mu * ir3 * (3.0 * rv[i] * rv[j] / r2 - dij) + c * (f * dij + rv[i] * dfj)
            if i == 2:
                v -= c * 2.0 * ((ir5 if j == 2 else 0.0) - 5.0 * z * ir7 * rv[j])
            out[i, j] = v


@numba.njit(cache=True)
def _grav_batch(r, mu, c, omega, centrifugal):
    n = r.shape[0]
    out = np.empty((n, 3))
    for k in range(n):
        gx, gy, gz = gravitation_vec(r[k, 0], r[k, 1], r[k, 2], mu, c)
        if centrifugal:  # - w x (w x r) = w^2 [x, y, 0] for w along z
            gx += omega * omega * r[k, 0]
            gy += omega * omega * r[k, 1]
        out[k, 0], out[k, 1], out[k, 2] = gx, gy, gz
    return out


@numba.njit(cache=True)
def _grad_batch(r, mu, c, omega, centrifugal):
    n = r.shape[0]
    out = np.empty((n, 3, 3))
    for k in range(n):
        gravitation_gradient_fill(r[k, 0], r[k, 1], r[k, 2], mu, c, out[k])
        if centrifugal:  # -[w x][w x] = w^2 diag(1, 1, 0)
            out[k, 0, 0] += omega * omega
            out[k, 1, 1] += omega * omega
    return out


def _stack(r):
    r = np.asarray(r, dtype=np.float64)
    return np.ascontiguousarray(r.reshape(-1, 3)), r.shape[:-1]


def gravitation(r, mu: float = GM_EARTH, j2: float = J2_EARTH, radius: float = WGS84_A):
    """Mass attraction g(r) (..., 3) [m/s^2], point mass + J2 (module docstring)."""
    rs, shape = _stack(r)
    return _grav_batch(rs, mu, 1.5 * mu * j2 * radius**2, 0.0, False).reshape(shape + (3,))


def gravitation_gradient(r, mu: float = GM_EARTH, j2: float = J2_EARTH, radius: float = WGS84_A):
    """dg/dr (..., 3, 3) [1/s^2] of :func:`gravitation`."""
    rs, shape = _stack(r)
    return _grad_batch(rs, mu, 1.5 * mu * j2 * radius**2, 0.0, False).reshape(shape + (3, 3))


def local_gravity(r, omega: float = OMEGA_EARTH):
    """g_l = g - w x (w x r) (paper eq. 9), ECEF (..., 3) [m/s^2]."""
    rs, shape = _stack(r)
    return _grav_batch(rs, GM_EARTH, J2_COEFF, omega, True).reshape(shape + (3,))


def local_gravity_gradient(r, omega: float = OMEGA_EARTH):
    """dg_l/dr = dg/dr - [w x][w x] (paper eq. 14), ECEF (..., 3, 3) [1/s^2]."""
    rs, shape = _stack(r)
    return _grad_batch(rs, GM_EARTH, J2_COEFF, omega, True).reshape(shape + (3, 3))
