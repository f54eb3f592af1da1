"""WGS-84 constants (NIMA TR8350.2, 3rd ed., Tables 3.1-3.3) shared by every Earth-referenced model.

SI units. Geodesy (geodetic <-> ECEF) goes through a maintained library (pymap3d) rather than hand-written
conversions; the constants here are the defining and derived parameters the models need directly.
"""

from __future__ import annotations

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
