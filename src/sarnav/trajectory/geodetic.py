"""A flight over the rotating WGS-84 Earth, built from a flat trajectory's NED velocity and attitude.

:class:`GeodeticFlight` takes any :class:`~sarnav.trajectory.base.Trajectory` (its NED velocity ``v^n(t)``,
attitude ``q_b^n(t)``, acceleration ``dv^n/dt`` and rate ``omega_nb^b``) and flies the same velocity and attitude
histories from a geodetic origin (lat0, lon0, h0) over the ellipsoid:

* ``h(t) = h0 - (p_D(t) - p_D(0))``; ``L, lambda`` integrate ``L_dot = v_N/(R_N + h)``,
  ``lambda_dot = v_E/((R_E + h) cos L)`` by classical RK4 every 20 ms (local error ~1e-19 rad for
  aircraft turn rates), with a cubic Hermite interpolant (exact derivatives at the nodes) in between;
* ideal IMU (what an error-free strapdown IMU on the rotating Earth measures, Groves 2008 eq. 5.53/5.48):
  ``f^b = C_n^b [dv^n/dt + (2 omega_ie^n + omega_en^n) x v^n - g^n(L, h)]``,
  ``omega_ib^b = omega_nb^b + C_n^b (omega_ie^n + omega_en^n)``.

The kinematic identities are checked independently in tests/trajectory/test_geodetic.py by differentiating
ECEF positions in an inertial frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numba
from scipy.interpolate import CubicHermiteSpline

from sarnav.errors import require_finite
from sarnav.frames.earth import WGS84_A, WGS84_E2
from sarnav.frames.wgs84 import earth_rate_ned, geodetic_rates, gravity_ned, transport_rate_ned
from sarnav.rotations import quat_to_dcm
from sarnav.trajectory.base import Trajectory


@dataclass(frozen=True)
class GeodeticState:
    """Truth at times t: ``lat, lon`` (...) [rad], ``h`` (...) [m], ``velocity`` (..., 3) NED [m/s],
    ``quaternion`` (..., 4) q_b^n."""

    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    velocity: np.ndarray
    quaternion: np.ndarray


_STEP = 0.02  # RK4 step [s]


@numba.njit(cache=True)
def _geodetic_rhs(lat, v, hgt):
    s = np.sin(lat)
    w = 1.0 - WGS84_E2 * s * s
    rn = WGS84_A * (1.0 - WGS84_E2) / (w * np.sqrt(w))
    re = WGS84_A / np.sqrt(w)
    return v[0] / (rn + hgt), v[1] / ((re + hgt) * np.cos(lat))


@numba.njit(cache=True)
def _rk4_geodetic(lat0, lon0, h, v, hgt):
    """RK4 of (L, lambda) with velocity/height given at nodes and half-steps (index 2k, 2k+1, 2k+2)."""
    n = (v.shape[0] - 1) // 2
    out = np.empty((n + 1, 2))
    out[0, 0], out[0, 1] = lat0, lon0
    lat, lon = lat0, lon0
    for k in range(n):
        a, b, c = 2 * k, 2 * k + 1, 2 * k + 2
        l1, o1 = _geodetic_rhs(lat, v[a], hgt[a])
        l2, o2 = _geodetic_rhs(lat + 0.5 * h * l1, v[b], hgt[b])
        l3, o3 = _geodetic_rhs(lat + 0.5 * h * l2, v[b], hgt[b])
        l4, o4 = _geodetic_rhs(lat + h * l3, v[c], hgt[c])
        lat += h / 6.0 * (l1 + 2.0 * l2 + 2.0 * l3 + l4)
        lon += h / 6.0 * (o1 + 2.0 * o2 + 2.0 * o3 + o4)
        out[k + 1, 0], out[k + 1, 1] = lat, lon
    return out


class GeodeticFlight:
    """The flat trajectory ``flat`` flown over the WGS-84 ellipsoid from (lat0, lon0, h0) [rad, rad, m]."""

    def __init__(self, flat: Trajectory, lat0: float, lon0: float, h0: float):
        self.flat = flat
        self.lat0 = require_finite("trajectory.lat0", lat0, lo=-1.5, hi=1.5, unit="rad")
        self.lon0 = require_finite("trajectory.lon0", lon0, lo=-2 * np.pi, hi=2 * np.pi, unit="rad")
        self.h0 = require_finite("trajectory.h0", h0, lo=-1e3, hi=1e5, unit="m")
        self.duration = flat.duration
        self._d0 = float(flat.state(0.0).position[2])
        n = max(2, int(np.ceil(self.duration / _STEP)))
        h = self.duration / n
        tt = np.linspace(0.0, self.duration, 2 * n + 1)  # nodes and half-steps
        s = flat.state(tt)
        y = _rk4_geodetic(self.lat0, self.lon0, h, s.velocity, self.h0 - (s.position[:, 2] - self._d0))
        dl, dlon, _ = geodetic_rates(y[:, 0], self.h0 - (s.position[::2, 2] - self._d0), s.velocity[::2])
        self._sol = CubicHermiteSpline(tt[::2], y, np.stack([dl, dlon], -1), axis=0)

    def state(self, t) -> GeodeticState:
        t = self.flat._times(t)
        s = self.flat.state(t)
        ll = np.moveaxis(self._sol(t), -1, 0)
        return GeodeticState(ll[0], ll[1], self.h0 - (s.position[..., 2] - self._d0), s.velocity, s.quaternion)

    def imu(self, t):
        """Ideal IMU at times ``t``: (f^b (..., 3) [m/s^2], omega_ib^b (..., 3) [rad/s])."""
        s = self.state(t)
        a_n = self.flat.acceleration(t)
        w_nb = self.flat.angular_rate(t)
        w_ie = earth_rate_ned(s.lat)
        w_en = transport_rate_ned(s.lat, s.h, s.velocity)
        f_n = a_n + np.cross(2.0 * w_ie + w_en, s.velocity) - gravity_ned(s.lat, s.h)
        C = quat_to_dcm(s.quaternion)
        to_body = lambda x: np.einsum("...ji,...j->...i", C, x)  # noqa: E731  C^T x
        return to_body(f_n), w_nb + to_body(w_ie + w_en)
