"""WGS-84 Earth model for geodetic navigation: radii of curvature, normal gravity, Earth and transport rates.

Sun (2022) dissertation eqs. 2.48-2.59 as reconstructed in the extraction (seed-003 §2.7, Groves 2008 ch. 2
and 5), with the constants of :mod:`sarnav.frames.earth` (NIMA TR8350.2):

* meridian radius ``R_N(L) = a (1 - e^2) / (1 - e^2 sin^2 L)^(3/2)`` (eq. 2.49);
* transverse radius ``R_E(L) = a / sqrt(1 - e^2 sin^2 L)`` (eq. 2.56);
* Earth rate in NED ``omega_ie^n = Omega [cos L, 0, -sin L]`` (L480, rotated from ECEF to NED);
* transport rate ``omega_en^n = [v_E/(R_E+h), -v_N/(R_N+h), -v_E tan L/(R_E+h)]`` (eq. 2.48, signs corrected);
* normal (plumb-bob) gravity, Somigliana with the TR8350.2 eq. 4-3 height series, along +D; its small north
  component at height (< 1e-5 m/s^2 below 1 km) is neglected, in truth and mechanization alike.

All functions are vectorised over any leading shape; angles in rad, lengths in m, SI throughout.
"""

from __future__ import annotations

import numpy as np

from sarnav.frames.earth import GM_EARTH, OMEGA_EARTH, WGS84_A, WGS84_B, WGS84_E2, WGS84_F

#: normal gravity at the equator [m/s^2] (TR8350.2 Table 3.4)
GAMMA_EQUATOR = 9.7803253359
#: Somigliana constant k = b gamma_p / (a gamma_e) - 1 (TR8350.2 Table 3.4)
SOMIGLIANA_K = 0.00193185265241
#: m = omega^2 a^2 b / GM (TR8350.2 Table 3.4)
GRAVITY_M = OMEGA_EARTH**2 * WGS84_A**2 * WGS84_B / GM_EARTH


def radii_of_curvature(lat):
    """(R_N, R_E): meridian (eq. 2.49) and transverse (eq. 2.56) radii of curvature [m] at latitude ``lat``."""
    s2 = np.sin(lat) ** 2
    w = 1.0 - WGS84_E2 * s2
    return WGS84_A * (1.0 - WGS84_E2) / w**1.5, WGS84_A / np.sqrt(w)


def normal_gravity(lat, h):
    """Magnitude of normal gravity [m/s^2] at geodetic latitude ``lat`` and height ``h`` (Somigliana + TR8350.2
    eq. 4-3 second-order height series); points along +Down."""
    s2 = np.sin(lat) ** 2
    g0 = GAMMA_EQUATOR * (1.0 + SOMIGLIANA_K * s2) / np.sqrt(1.0 - WGS84_E2 * s2)
    return g0 * (1.0 - 2.0 / WGS84_A * (1.0 + WGS84_F + GRAVITY_M - 2.0 * WGS84_F * s2) * h
                 + 3.0 / WGS84_A**2 * h * h)


def gravity_ned(lat, h):
    """Normal gravity vector g^n = [0, 0, gamma(L, h)] (..., 3) [m/s^2]."""
    g = np.asarray(normal_gravity(lat, h), dtype=float)
    z = np.zeros_like(g)
    return np.stack([z, z, g], -1)


def earth_rate_ned(lat):
    """omega_ie^n = Omega [cos L, 0, -sin L] (..., 3) [rad/s]."""
    lat = np.asarray(lat, dtype=float)
    return OMEGA_EARTH * np.stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)], -1)


def transport_rate_ned(lat, h, v_ned):
    """omega_en^n (..., 3) [rad/s] of a vehicle at (lat, h) with NED velocity ``v_ned`` (eq. 2.48, corrected)."""
    rn, re = radii_of_curvature(lat)
    v = np.asarray(v_ned, dtype=float)
    return np.stack([v[..., 1] / (re + h), -v[..., 0] / (rn + h), -v[..., 1] * np.tan(lat) / (re + h)], -1)


def geodetic_rates(lat, h, v_ned):
    """(L_dot, lambda_dot, h_dot) of the NED velocity (eqs. 2.53-2.59 in continuous form)."""
    rn, re = radii_of_curvature(lat)
    v = np.asarray(v_ned, dtype=float)
    return v[..., 0] / (rn + h), v[..., 1] / ((re + h) * np.cos(lat)), -v[..., 2]


def ned_to_ecef_dcm(lat, lon):
    """C_n^e (..., 3, 3): rotates NED vectors at (lat, lon) into ECEF."""
    lat, lon = np.broadcast_arrays(np.asarray(lat, dtype=float), np.asarray(lon, dtype=float))
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    z = np.zeros_like(lat)
    return np.stack([np.stack([-sl * co, -so, -cl * co], -1),
                     np.stack([-sl * so, co, -cl * so], -1),
                     np.stack([cl, z, -sl], -1)], -2)


def geodetic_to_ecef(lat, lon, h):
    """ECEF position (..., 3) [m] of geodetic coordinates (eq. 2.44 with the transverse radius R_E(L), gap G3)."""
    _, re = radii_of_curvature(lat)
    return np.stack([(re + h) * np.cos(lat) * np.cos(lon), (re + h) * np.cos(lat) * np.sin(lon),
                     ((1.0 - WGS84_E2) * re + h) * np.sin(lat)], -1)


def geodetic_difference_ned(lat, lon, h, lat_ref, lon_ref, h_ref):
    """Small geodetic differences (estimate - reference) expressed as NED metres at the reference (..., 3):
    ``[dL (R_N + h), dlambda (R_E + h) cos L, -dh]`` (first order; exact to < 1e-6 relative for the
    metre-level errors it measures)."""
    rn, re = radii_of_curvature(lat_ref)
    dlon = np.angle(np.exp(1j * (np.asarray(lon) - lon_ref)))
    return np.stack([(np.asarray(lat) - lat_ref) * (rn + h_ref), dlon * (re + h_ref) * np.cos(lat_ref),
                     -(np.asarray(h) - h_ref)], -1)


def ned_offset_to_geodetic(lat, lon, h, d_ned):
    """Inverse of :func:`geodetic_difference_ned` to first order: geodetic coordinates of the point offset by
    the NED metres ``d_ned`` (..., 3) from (lat, lon, h)."""
    rn, re = radii_of_curvature(lat)
    d = np.asarray(d_ned, dtype=float)
    return lat + d[..., 0] / (rn + h), lon + d[..., 1] / ((re + h) * np.cos(lat)), h - d[..., 2]
