"""The navigation frame: an Earth-fixed North-East-Down tangent frame with constant gravity.

The sources use a tangent frame with constant gravity and no Earth rotation (thesis L486-L488,
L787-L795, L1231; extraction seed-000 §2.1): position ``p^t`` is the vehicle's position in the
frame fixed on the Earth at the origin, expressed in NED; gravity is ``g^t = [0, 0, g]`` (down positive)
with ``g = 9.81 m/s^2`` (thesis Table A.5 reproduces exactly with this value).

Earth rotation is a per-scenario switch (``[earth] rotation``, default off: the sources absorb the Earth rate into
the gyro bias specification, NAVIGATION paper L1481-L1488). Off, the frame is inertial (the sources' model). On,
the tangent frame turns with the Earth at :func:`earth_rate_tangent` (latitude of the origin), and the local-level
mechanization of Groves (2008) §5.3 applies (docs/navigation.md "Frame")::

    p_dot = v,   v_dot = C_b^t f^b + g^t - 2 omega_ie^t x v,   C_dot = C [omega_ib^b x] - [omega_ie^t x] C

with the same constant ``g^t`` (plumb-bob gravity at the origin, centrifugal term included; its change across a
scene, ``Omega^2 |p|`` < 6e-5 m/s^2 at 10 km, is neglected like gravitation's own gradient). Transport rate does not
exist in an Earth-fixed frame; the curvature of the Earth is what this frame leaves out (``ins.geodetic`` has it).
The truth IMU (``Trajectory.specific_force`` / ``angular_rate`` with ``earth_rate``), the strapdown
(``ins.mechanize``) and the error model (``filters.ErrorStateModel``) take the same ``earth_rate`` vector.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError
from sarnav.frames.wgs84 import earth_rate_ned
from sarnav.units import G0

#: gravity in the NED tangent frame [m/s^2] (thesis eq. 3.1: g^n, down positive)
GRAVITY_NED = np.array([0.0, 0.0, G0])


def gravity_ned() -> np.ndarray:
    """Return a fresh copy of the constant gravity vector g^n = [0, 0, 9.81] m/s^2 (NED)."""
    return GRAVITY_NED.copy()


def earth_rate_tangent(latitude_rad: float) -> np.ndarray:
    """omega_ie^t = Omega [cos L, 0, -sin L] [rad/s]: the Earth's rate in the NED tangent frame at latitude L
    (Groves 2008 eq. 2.75), the ``earth_rate`` of an Earth-fixed tangent frame at the origin."""
    lat = float(latitude_rad)
    if not np.isfinite(lat) or abs(lat) > 0.5 * np.pi + 1e-12:
        raise ConfigError("earth.latitude_deg", f"must be in [-90, 90] deg, got {np.degrees(lat)!r}")
    return earth_rate_ned(lat)


def earth_rate_or_zero(earth_rate) -> np.ndarray:
    """The (3,) float64 Earth-rate vector of an ``earth_rate`` argument (None: the non-rotating frame, zeros)."""
    if earth_rate is None:
        return np.zeros(3)
    w = np.asarray(earth_rate, dtype=float)
    if w.shape != (3,) or not np.all(np.isfinite(w)):
        raise ConfigError("earth_rate", f"must be a finite 3-vector [rad/s] or None, got {earth_rate!r}")
    return w
