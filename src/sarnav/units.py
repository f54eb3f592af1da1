"""Unit conversions, in one place.

Everything inside sarnav is SI (m, s, rad, m/s^2, rad/s, Hz). The sources quote IMU and
measurement figures in engineering units and often as 3-sigma values; convert them here,
once, at the edge (scenario loading, presets).

Conventions
-----------
* ``x_to_si`` functions take a value in the named unit and return SI.
* White-noise densities (random walks) are root-PSDs: VRW in m/s/sqrt(s), ARW in rad/sqrt(s).
* ``three_sigma_to_sigma`` divides by 3 (thesis L1885: "values are 3-sigma; sigma = 3sigma/3").
"""

from __future__ import annotations

import math

import numpy as np

#: standard gravity used by the sources (thesis Table A.5 reproduces exactly with 9.81)
G0 = 9.81
#: speed of light in vacuum [m/s]
C = 299_792_458.0

DEG = math.pi / 180.0
HOUR = 3600.0


def deg_to_rad(x):
    return np.multiply(x, DEG)


def rad_to_deg(x):
    return np.divide(x, DEG)


def km_to_m(x):
    return np.multiply(x, 1000.0)


def deg_per_hr_to_rad_per_s(x):
    """Gyro bias: deg/hr -> rad/s."""
    return np.multiply(x, DEG / HOUR)


def rad_per_s_to_deg_per_hr(x):
    return np.multiply(x, HOUR / DEG)


def deg_per_sqrt_hr_to_rad_per_sqrt_s(x):
    """Angle random walk: deg/sqrt(hr) -> rad/sqrt(s)."""
    return np.multiply(x, DEG / math.sqrt(HOUR))


def m_per_s_per_sqrt_hr_to_si(x):
    """Velocity random walk: m/s/sqrt(hr) -> m/s/sqrt(s)."""
    return np.divide(x, math.sqrt(HOUR))


def g_to_m_per_s2(x, g: float = G0):
    """Accelerometer bias: g -> m/s^2 (with the sources' g = 9.81)."""
    return np.multiply(x, g)


def milli_g_to_m_per_s2(x, g: float = G0):
    return np.multiply(x, 1e-3 * g)


def micro_g_to_m_per_s2(x, g: float = G0):
    return np.multiply(x, 1e-6 * g)


def ppm_to_ratio(x):
    return np.multiply(x, 1e-6)


def three_sigma_to_sigma(x):
    """A 3-sigma figure from a source table -> 1 sigma."""
    return np.divide(x, 3.0)


def ghz_to_hz(x):
    return np.multiply(x, 1e9)


def mhz_to_hz(x):
    return np.multiply(x, 1e6)


def us_to_s(x):
    return np.multiply(x, 1e-6)


def hpa_to_m(x, metres_per_hpa: float = 9.6):
    """Barometric altitude: a pressure figure in hPa -> metres near 1400 m elevation.

    9.6 m/hPa is the local hydrostatic gradient the thesis' real-data altimeter implies
    (extraction seed-000 §5.2: 0.4 hPa/3 -> 1.28 m, consistent with 1.3 m).
    """
    return np.multiply(x, metres_per_hpa)


def db_to_power(x):
    return np.power(10.0, np.divide(x, 10.0))


def power_to_db(x):
    return np.multiply(10.0, np.log10(x))


def amplitude_to_db(x):
    return np.multiply(20.0, np.log10(np.abs(x)))
