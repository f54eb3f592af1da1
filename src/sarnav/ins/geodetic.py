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

Steps 4-7 (the translational part, what a particle carries) are one numba function,
:func:`translational_step_inplace`, used by the particle filters for every particle; steps 1-7 are
:func:`strapdown_step_inplace`. The numpy front ends :func:`translational_step`, :func:`attitude_step` and
:func:`mechanize_geodetic` work on any number of runs. The local-level mechanization of
``sarnav.ins.strapdown`` works in an Earth-fixed tangent frame (flat, optionally rotating: ``earth_rate``); this
module adds what that frame leaves out, the curvature of the ellipsoid (transport rate, latitude-dependent gravity).
tests/ins/test_earth_rotation.py checks that both give the same Earth-rate effect.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba
import numpy as np

from sarnav.errors import InputDataError
from sarnav.frames.earth import OMEGA_EARTH, WGS84_A, WGS84_E2, WGS84_F
from sarnav.frames.wgs84 import GAMMA_EQUATOR, GRAVITY_M, SOMIGLIANA_K, earth_rate_ned, transport_rate_ned
from sarnav.rotations import quat_multiply, quat_normalize, rotvec_to_quat

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
def gravity_scalar(lat, h):
    """Normal gravity (numba scalar twin of ``sarnav.frames.wgs84.normal_gravity``)."""
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
    g = gravity_scalar(lat, h)
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
def translational_step_cloud(x, fN, fE, fD, dt, omega_e, lat_ref, h_ref):
    """Steps 4-7 for a cloud ``x`` (N, 6) in place, with the latitude functions (radii, gravity, Earth-rate
    components, tan L) evaluated once at the cloud's reference latitude/height, sec L to first order about it:
    particles tens of metres apart change them by < 1e-6 relative. Per particle: its own height in R + h,
    velocity in the Coriolis/transport terms, and position."""
    sl, cl = math.sin(lat_ref), math.cos(lat_ref)
    tl = sl / cl
    w = 1.0 - WGS84_E2 * sl * sl
    rn = WGS84_A * (1.0 - WGS84_E2) / (w * math.sqrt(w)) + h_ref
    re = WGS84_A / math.sqrt(w) + h_ref
    irn, ire, sec = 1.0 / rn, 1.0 / re, 1.0 / cl
    g0 = gravity_scalar(lat_ref, h_ref)
    dg_dh = -2.0 * g0 / WGS84_A  # free-air gradient, for the height spread across the cloud
    cor_x, cor_z = 2.0 * omega_e * cl, -2.0 * omega_e * sl
    for i in range(x.shape[0]):
        lat, h, vn, ve, vd = x[i, 0], x[i, 2], x[i, 3], x[i, 4], x[i, 5]
        # 1/(R + h) to first order in h - h_ref (relative error ((h - h_ref)/R)^2): no division per particle
        dh = h - h_ref
        irn0, ire0 = irn * (1.0 - dh * irn), ire * (1.0 - dh * ire)
        ox = cor_x + ve * ire0
        oy = -vn * irn0
        oz = cor_z - ve * tl * ire0
        g = g0 + dg_dh * dh
        vn1 = vn + (fN - (oy * vd - oz * ve)) * dt
        ve1 = ve + (fE - (oz * vn - ox * vd)) * dt
        vd1 = vd + (fD + g - (ox * ve - oy * vn)) * dt
        h1 = h - 0.5 * dt * (vd + vd1)
        dh1 = h1 - h_ref
        irn1, ire1 = irn * (1.0 - dh1 * irn), ire * (1.0 - dh1 * ire)
        lat1 = lat + 0.5 * dt * (vn * irn0 + vn1 * irn1)
        # sec L to first order about the reference latitude (error (dL)^2 ~ 1e-12 for metre-sized clouds)
        sec0 = (1.0 + tl * (lat - lat_ref)) * sec
        sec1 = (1.0 + tl * (lat1 - lat_ref)) * sec
        x[i, 0] = lat1
        x[i, 1] += 0.5 * dt * (ve * sec0 * ire0 + ve1 * sec1 * ire1)
        x[i, 2], x[i, 3], x[i, 4], x[i, 5] = h1, vn1, ve1, vd1


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


@numba.njit(cache=True)
def navigation_rate_inplace(x, omega_e, out):
    """omega_in^n of state ``x`` (6,) into ``out`` (3,) (eqs. 2.48 + Earth rate)."""
    lat, h, vn, ve = x[0], x[2], x[3], x[4]
    sl, cl = math.sin(lat), math.cos(lat)
    w = 1.0 - WGS84_E2 * sl * sl
    rn = WGS84_A * (1.0 - WGS84_E2) / (w * math.sqrt(w))
    re = WGS84_A / math.sqrt(w)
    out[0] = omega_e * cl + ve / (re + h)
    out[1] = -vn / (rn + h)
    out[2] = -omega_e * sl - ve * (sl / cl) / (re + h)


@numba.njit(cache=True, inline="always")
def _rotvec_quat(ax, ay, az, out):
    ang = math.sqrt(ax * ax + ay * ay + az * az)
    k = math.sin(0.5 * ang) / ang if ang > 1e-8 else 0.5 - ang * ang / 48.0
    out[0], out[1], out[2], out[3] = math.cos(0.5 * ang), k * ax, k * ay, k * az


@numba.njit(cache=True, inline="always")
def _qmul(a, b, out):
    out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]


@numba.njit(cache=True)
def attitude_step_inplace(q, w_b, w_n, dt):
    """Step 2 in place: q <- rotvec(-w_n dt) (x) q (x) rotvec(w_b dt), normalised; q (4,), w_b, w_n (3,)."""
    db = np.empty(4)
    dn = np.empty(4)
    t1 = np.empty(4)
    t2 = np.empty(4)
    _rotvec_quat(w_b[0] * dt, w_b[1] * dt, w_b[2] * dt, db)
    _rotvec_quat(-w_n[0] * dt, -w_n[1] * dt, -w_n[2] * dt, dn)
    _qmul(q, db, t1)
    _qmul(dn, t1, t2)
    nrm = math.sqrt(t2[0] ** 2 + t2[1] ** 2 + t2[2] ** 2 + t2[3] ** 2)
    for i in range(4):
        q[i] = t2[i] / nrm


@numba.njit(cache=True)
def rotate_to_nav(q, f, out):
    """out += C_b^n(q) f (accumulates, so the caller can average two attitudes)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    out[0] += (w * w + x * x - y * y - z * z) * f[0] + 2 * (x * y - w * z) * f[1] + 2 * (x * z + w * y) * f[2]
    out[1] += 2 * (x * y + w * z) * f[0] + (w * w - x * x + y * y - z * z) * f[1] + 2 * (y * z - w * x) * f[2]
    out[2] += 2 * (x * z - w * y) * f[0] + 2 * (y * z + w * x) * f[1] + (w * w - x * x - y * y + z * z) * f[2]


@numba.njit(cache=True)
def strapdown_step_inplace(x, q, f_b, w_b, dt, omega_e, f_n):
    """Steps 1-7 for one state: x (6,), q (4,) updated in place; the NED specific force used is left in f_n."""
    w_n = np.empty(3)
    navigation_rate_inplace(x, omega_e, w_n)
    f_n[:] = 0.0
    rotate_to_nav(q, f_b, f_n)
    attitude_step_inplace(q, w_b, w_n, dt)
    rotate_to_nav(q, f_b, f_n)
    f_n *= 0.5
    translational_step_inplace(x, f_n[0], f_n[1], f_n[2], dt, omega_e)


@numba.njit(cache=True)
def _mechanize_kernel(x0, q0, times, f_b, w_b, linear, omega_e, out_x, out_q):
    fb = np.empty(3)
    wb = np.empty(3)
    fn = np.empty(3)
    for r in range(x0.shape[0]):
        x = x0[r].copy()
        q = q0[r].copy()
        out_x[r, 0] = x
        out_q[r, 0] = q
        for k in range(times.size - 1):
            for i in range(3):
                fb[i] = 0.5 * (f_b[r, k, i] + f_b[r, k + 1, i]) if linear else f_b[r, k, i]
                wb[i] = 0.5 * (w_b[r, k, i] + w_b[r, k + 1, i]) if linear else w_b[r, k, i]
            strapdown_step_inplace(x, q, fb, wb, times[k + 1] - times[k], omega_e, fn)
            out_x[r, k + 1] = x
            out_q[r, k + 1] = q


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
    out_x = np.empty((runs, m, 6))
    out_q = np.empty((runs, m, 4))
    _mechanize_kernel(np.ascontiguousarray(nav.translational()), np.array(nav.q, dtype=float), times,
                      np.ascontiguousarray(f_b), np.ascontiguousarray(w_ib_b), hold == "linear",
                      OMEGA_EARTH if earth_rate else 0.0, out_x, out_q)
    return {"lat": out_x[..., 0], "lon": out_x[..., 1], "h": out_x[..., 2], "v": out_x[..., 3:], "q": out_q}
