"""WGS-84 constants (NIMA TR8350.2, 3rd ed., Tables 3.1-3.3), geodesy (pymap3d) and the ECI <-> ECEF rotation.

SI units. Geodesy (geodetic <-> ECEF) goes through a maintained library (pymap3d) rather than hand-written
conversions; the constants here are the defining and derived parameters the models need directly.
"""

from __future__ import annotations

import numpy as np

#: semi-major axis [m]
WGS84_A = 6378137.0
#: flattening 1/f = 298.257223563
WGS84_F = 1.0 / 298.257223563
#: semi-minor axis b = a (1 - f) [m]
WGS84_B = WGS84_A * (1.0 - WGS84_F)
#: first eccentricity squared e^2 = f (2 - f)
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
#: Earth rotation rate omega_ie [rad/s]
OMEGA_EARTH = 7.292115e-5
#: Earth gravitational parameter GM [m^3/s^2] (including the atmosphere)
GM_EARTH = 3.986004418e14
#: second zonal harmonic J2 (unnormalised; C20 = -4.84166774985e-4 normalised, J2 = -sqrt(5) C20)
J2_EARTH = 1.08262982131e-3
#: Earth rotation vector omega_ie^e = [0, 0, omega] in ECEF (and in the ECI frame below) [rad/s]
OMEGA_EARTH_VECTOR = (0.0, 0.0, OMEGA_EARTH)

# --- geodesy (pymap3d, WGS-84) --------------------------------------------------------------------------------

def _wgs84():
    import pymap3d

    return pymap3d.Ellipsoid.from_name("wgs84")


def geodetic_to_ecef(lat, lon, h):
    """Geodetic latitude, longitude [rad] and height above the WGS-84 ellipsoid [m] -> ECEF (..., 3) [m].

    Through ``pymap3d.geodetic2ecef`` (WGS-84); any broadcastable shapes.
    """
    import pymap3d

    x, y, z = pymap3d.geodetic2ecef(np.asarray(lat, float), np.asarray(lon, float), np.asarray(h, float),
                                    ell=_wgs84(), deg=False)
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1)


def ecef_to_geodetic(r):
    """ECEF (..., 3) [m] -> (lat [rad], lon [rad], h [m]) on WGS-84 (``pymap3d.ecef2geodetic``)."""
    import pymap3d

    r = np.asarray(r, dtype=float)
    lat, lon, h = pymap3d.ecef2geodetic(r[..., 0], r[..., 1], r[..., 2], ell=_wgs84(), deg=False)
    shape = r.shape[:-1]
    return tuple(np.asarray(a, dtype=float).reshape(shape) for a in (lat, lon, h))


# --- ECI <-> ECEF -------------------------------------------------------------------------------------------
#
# Epoch convention: the ECI frame used in sarnav is the ECEF frame frozen at t = 0 (the simulation epoch),
# i.e. Earth rotation angle theta(t) = omega_ie t with theta(0) = 0. It is inertial for the models here (central
# gravity + J2 about the spin axis); precession, nutation, polar motion and UT1 are neglected, so this is not
# GCRF/ITRF: it is the frame pair of a J2-only orbit simulation. ECEF = R3(theta) ECI (passive rotation about z).


def eci_to_ecef_dcm(t):
    """Passive DCM C(t) (..., 3, 3) with r_ecef = C r_eci: rotation about z by theta = omega_ie t [rad]."""
    th = OMEGA_EARTH * np.asarray(t, dtype=float)
    c, s = np.cos(th), np.sin(th)
    z, o = np.zeros_like(th), np.ones_like(th)
    return np.stack([np.stack([c, s, z], -1), np.stack([-s, c, z], -1), np.stack([z, z, o], -1)], -2)


def eci_to_ecef(t, r_eci, v_eci):
    """(r, v) in ECI -> ECEF at time t [s]: r_e = C r_i, v_e = C (v_i - omega x r_i). Shapes (..., 3)."""
    C = eci_to_ecef_dcm(t)
    r_eci = np.asarray(r_eci, dtype=float)
    v_rel = np.asarray(v_eci, dtype=float) - np.cross(OMEGA_EARTH_VECTOR, r_eci)
    return np.einsum("...ij,...j->...i", C, r_eci), np.einsum("...ij,...j->...i", C, v_rel)


def ecef_to_eci(t, r_ecef, v_ecef):
    """(r, v) in ECEF -> ECI at time t [s]: r_i = C^T r_e, v_i = C^T (v_e + omega x r_e). Shapes (..., 3)."""
    Ct = np.swapaxes(eci_to_ecef_dcm(t), -1, -2)
    r_ecef = np.asarray(r_ecef, dtype=float)
    v_abs = np.asarray(v_ecef, dtype=float) + np.cross(OMEGA_EARTH_VECTOR, r_ecef)
    return np.einsum("...ij,...j->...i", Ct, r_ecef), np.einsum("...ij,...j->...i", Ct, v_abs)
