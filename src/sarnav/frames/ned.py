"""The navigation frame: a flat, non-rotating Earth with a North-East-Down tangent frame.

The sources use a tangent frame with constant gravity and no Earth rotation (thesis L486-L488,
L787-L795, L1231; extraction seed-000 §2.1): position ``p^n`` is the vehicle's position in the
frame fixed on the flat Earth, expressed in NED; gravity is ``g^n = [0, 0, g]`` (down positive)
with ``g = 9.81 m/s^2`` (thesis Table A.5 reproduces exactly with this value).

Earth rate and Coriolis/transport-rate terms are **not modelled** (the sources absorb the Earth
rate into the gyro bias specification, NAVIGATION paper L1481-L1488). :data:`EARTH_ROTATION` is
the documented switch for adding them later; every mechanization and error model checks it via
:func:`require_flat_earth` so that turning it on without implementing the terms fails loudly.
"""

from __future__ import annotations

import numpy as np

from sarnav.units import G0

#: gravity in the NED tangent frame [m/s^2] (thesis eq. 3.1: g^n, down positive)
GRAVITY_NED = np.array([0.0, 0.0, G0])

#: switch for Earth rate / Coriolis terms; False = the sources' flat, non-rotating Earth
EARTH_ROTATION = False


def gravity_ned() -> np.ndarray:
    """Return a fresh copy of the constant gravity vector g^n = [0, 0, 9.81] m/s^2 (NED)."""
    return GRAVITY_NED.copy()


def require_flat_earth() -> None:
    """Raise NotImplementedError when :data:`EARTH_ROTATION` has been switched on.

    Earth-rate and Coriolis terms (e.g. ``-2 omega_ie^n x v^n`` in the velocity equation and
    ``-omega_in^n`` in the attitude equation) are left for later; this guard keeps the flat-Earth
    code from silently ignoring them.
    """
    if EARTH_ROTATION:
        raise NotImplementedError("sarnav.frames.EARTH_ROTATION=True: Earth rate/Coriolis terms are not implemented")
