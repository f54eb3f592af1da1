"""Strapdown mechanization in geodetic coordinates with a NED velocity, Earth rate and transport rate.

Sun (2022) eqs. 2.48-2.59 as reconstructed in the extraction (seed-003 §2.7: Groves 2008 §5.4 "simplified"
NED mechanization; the printed equations have sign and index typos, gap G4). One step over ``dt`` with the
body rate ``w_ib^b`` and specific force ``f^b`` held (or averaged) over the step:

1. ``omega_in^n = omega_ie^n(L) + omega_en^n(L, h, v)`` (eqs. 2.48, 2.51; Earth rate L480);
2. attitude ``q(k) = rotvec(-omega_in^n dt) (x) q(k-1) (x) rotvec(omega_ib^b dt)`` (eq. 2.51 as a rotation of
   the quaternion, gap G5, instead of the source's Euler-angle addition);
3. ``f^n = 1/2 (C_b^n(k-1) + C_b^n(k)) f^b`` (eq. 2.52 with + for the printed -);
4. ``v(k) = v(k-1) + [f^n + g^n(L, h) - (2 omega_ie^n + omega_en^n) x v(k-1)] dt`` (eq. 2.52's "E" term);
5. ``h(k) = h(k-1) - dt/2 (v_D(k-1) + v_D(k))`` (eq. 2.53, down positive);
6. ``L(k) = L(k-1) + dt/2 [v_N(k-1)/(R_N(L(k-1)) + h(k-1)) + v_N(k)/(R_N(L(k-1)) + h(k))]`` (eqs. 2.49-2.55);
7. ``lambda(k) = lambda(k-1) + dt/2 [v_E(k-1)/((R_E(L(k-1)) + h(k-1)) cos L(k-1))
   + v_E(k)/((R_E(L(k)) + h(k)) cos L(k))]`` (eqs. 2.56-2.59).

Steps 4-7 (the translational part, what a particle carries) are one numba kernel,
:func:`translational_step_inplace`, used by the particle filters for every particle; the numpy front end
:func:`translational_step` works on any leading shape. The flat, non-rotating mechanization of
``sarnav.ins.strapdown`` is untouched; this module is the Earth-rate / Coriolis variant the flat-Earth switch
(``sarnav.frames.EARTH_ROTATION``) was waiting for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba
import numpy as np

from sarnav.errors import InputDataError
from sarnav.frames.earth import OMEGA_EARTH, WGS84_A, WGS84_E2, WGS84_F
from sarnav.frames.wgs84 import GAMMA_EQUATOR, GRAVITY_M, SOMIGLIANA_K, earth_rate_ned, transport_rate_ned
from sarnav.rotations import quat_multiply, quat_normalize, quat_to_dcm, rotvec_to_quat

#: state layout of the translational part: latitude, longitude [rad], height [m], v_N, v_E, v_D [m/s]
GEODETIC_STATE = ("lat", "lon", "h", "vN", "vE", "vD")


@dataclass
class GeodeticNavState:
    """Geodetic navigation state of R runs: ``lat, lon`` (R,) [rad], ``h`` (R,) [m], ``v`` (R, 3) NED [m/s],
    ``q`` (R, 4) attitude q_b^n (Hamilton, scalar first)."""

    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    v: np.ndarray
    q: np.ndarray

    def copy(self) -> "GeodeticNavState":
        return replace(self, **{k: np.array(getattr(self, k), dtype=float) for k in ("lat", "lon", "h", "v", "q")})

    def translational(self) -> np.ndarray:
        """(R, 6) [lat, lon, h, vN, vE, vD]."""
        return np.concatenate([np.stack([self.lat, self.lon, self.h], -1), self.v], -1)


@numba.njit(cache=True, inline="always")
def _gravity(lat, h):
    s2 = math.sin(lat) ** 2
    g0 = GAMMA_EQUATOR * (1.0 + SOMIGLIANA_K * s2) / math.sqrt(1.0 - WGS84_E2 * s2)
    return g0 * (1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + GRAVITY_M - 2.0 * WGS84_F * s2) * h
                 + 3.0 / (WGS84_A * WGS84_A) * h * h)


@numba.njit(cache=True)
def translational_step_inplace(x, fN, fE, fD, dt, omega_e):
    """Steps 4-7 of the module docstring for one state ``x`` (6,) in place; ``omega_e`` = Earth rate (0 turns
    Earth rotation off). Called per particle by the filters' kernels."""
    lat, lon, h, vn, ve, vd = x[0], x[1], x[2], x[3], x[4], x[5]
    sl, cl = math.sin(lat), math.cos(lat)
    w = 1.0 - WGS84_E2 * sl * sl
    rn = WGS84_A * (1.0 - WGS84_E2) / (w * math.sqrt(w))
    re = WGS84_A / math.sqrt(w)
    # omega = 2 omega_ie^n + omega_en^n
    ox = 2.0 * omega_e * cl + ve / (re + h)
    oy = -vn / (rn + h)
    oz = -2.0 * omega_e * sl - ve * (sl / cl) / (re + h)
    g = _gravity(lat, h)
    vn1 = vn + (fN - (oy * vd - oz * ve)) * dt
    ve1 = ve + (fE - (oz * vn - ox * vd)) * dt
    vd1 = vd + (fD + g - (ox * ve - oy * vn)) * dt
    h1 = h - 0.5 * dt * (vd + vd1)
    lat1 = lat + 0.5 * dt * (vn / (rn + h) + vn1 / (rn + h1))
    s1 = math.sin(lat1)
    re1 = WGS84_A / math.sqrt(1.0 - WGS84_E2 * s1 * s1)
    lon1 = lon + 0.5 * dt * (ve / ((re + h) * cl) + ve1 / ((re1 + h1) * math.cos(lat1)))
    x[0], x[1], x[2], x[3], x[4], x[5] = lat1, lon1, h1, vn1, ve1, vd1


@numba.njit(cache=True)
def _step_many(x, f_n, dt, omega_e):
    for k in range(x.shape[0]):
        translational_step_inplace(x[k], f_n[k, 0], f_n[k, 1], f_n[k, 2], dt, omega_e)


def translational_step(x, f_n, dt: float, earth_rate: bool = True) -> np.ndarray:
    """One translational step (steps 4-7) for states ``x`` (..., 6) [lat, lon, h, vN, vE, vD] under NED
    specific force ``f_n`` (..., 3) [m/s^2] over ``dt`` [s]; returns a new array."""
    x = np.array(x, dtype=float)
    f = np.broadcast_to(np.asarray(f_n, dtype=float), x.shape[:-1] + (3,))
    flat = x.reshape(-1, 6)
    _step_many(flat, np.ascontiguousarray(f.reshape(-1, 3)), float(dt), OMEGA_EARTH if earth_rate else 0.0)
    return flat.reshape(x.shape)


def navigation_rate(lat, h, v, earth_rate: bool = True) -> np.ndarray:
    """omega_in^n = omega_ie^n + omega_en^n (..., 3) [rad/s]."""
    w = transport_rate_ned(lat, h, v)
    return w + earth_rate_ned(lat) if earth_rate else w


def attitude_step(q, w_ib_b, w_in_n, dt: float) -> np.ndarray:
    """q_b^n(k) = rotvec(-w_in^n dt) (x) q(k-1) (x) rotvec(w_ib^b dt), normalised (step 2); shapes (..., 4),
    (..., 3), (..., 3)."""
    dq_b = rotvec_to_quat(np.asarray(w_ib_b, dtype=float) * dt)
    dq_n = rotvec_to_quat(-np.asarray(w_in_n, dtype=float) * dt)
    return quat_normalize(quat_multiply(dq_n, quat_multiply(q, dq_b)))


def _check_imu(name, a, runs, n):
    a = np.asarray(a, dtype=float)
    if a.shape != (runs, n, 3):
        raise InputDataError(name, f"must have shape (runs={runs}, samples={n}, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        r, k, _ = np.argwhere(~np.isfinite(a))[0]
        raise InputDataError(name, f"NaN/inf IMU sample (run {r}, sample {k}); samples must be finite")
    return a


def mechanize_geodetic(nav: GeodeticNavState, times, f_b, w_ib_b, hold: str = "linear", earth_rate: bool = True):
    """Propagate through consecutive IMU samples; returns the state at every sample.

    Parameters
    ----------
    nav : state at ``times[0]`` (not modified).
    times : (M,) strictly increasing sample times [s].
    f_b, w_ib_b : (R, M, 3) specific force [m/s^2] and inertial body rate [rad/s] samples.
    hold : ``"linear"`` averages the two samples of each interval (second order for smooth motion);
        ``"zoh"`` holds the sample at the start of the interval (the source's zero-order hold, L750).
    earth_rate : False drops omega_ie (a non-rotating ellipsoid; transport rate kept).

    Returns
    -------
    history : dict of arrays with a sample axis: ``lat, lon, h`` (R, M), ``v`` (R, M, 3), ``q`` (R, M, 4).
    """
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise InputDataError("imu.time", "must be a finite, strictly increasing 1-D array of >= 2 sample times")
    if hold not in ("linear", "zoh"):
        raise InputDataError("hold", f"must be 'linear' or 'zoh', got {hold!r}")
    runs, m = nav.lat.shape[0], times.size
    f_b = _check_imu("imu.specific_force", f_b, runs, m)
    w_ib_b = _check_imu("imu.angular_rate", w_ib_b, runs, m)
    x = nav.translational()
    q = np.array(nav.q, dtype=float)
    out_x = np.empty((runs, m, 6))
    out_q = np.empty((runs, m, 4))
    out_x[:, 0], out_q[:, 0] = x, q
    for k in range(m - 1):
        dt = times[k + 1] - times[k]
        wb = 0.5 * (w_ib_b[:, k] + w_ib_b[:, k + 1]) if hold == "linear" else w_ib_b[:, k]
        fb = 0.5 * (f_b[:, k] + f_b[:, k + 1]) if hold == "linear" else f_b[:, k]
        w_in = navigation_rate(x[:, 0], x[:, 2], x[:, 3:], earth_rate)
        q_new = attitude_step(q, wb, w_in, dt)
        f_n = 0.5 * np.einsum("...ij,...j->...i", quat_to_dcm(q) + quat_to_dcm(q_new), fb)
        x = translational_step(x, f_n, dt, earth_rate)
        q = q_new
        out_x[:, k + 1], out_q[:, k + 1] = x, q
    return {"lat": out_x[..., 0], "lon": out_x[..., 1], "h": out_x[..., 2], "v": out_x[..., 3:], "q": out_q}
