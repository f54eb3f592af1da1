"""Frames and the Earth (ground floor: imports only ``units`` and ``errors``).

- ``ned``: the sources' flat, non-rotating Earth with a North-East-Down tangent frame and constant gravity
  (aircraft scenarios); :data:`GRAVITY_NED`, the :data:`EARTH_ROTATION` switch
- ``earth``: WGS-84 constants (and, for orbiting vehicles, ECEF / ECI / geodetic frames)
"""

from sarnav.frames.ned import EARTH_ROTATION, GRAVITY_NED, gravity_ned, require_flat_earth

__all__ = ["GRAVITY_NED", "EARTH_ROTATION", "gravity_ned", "require_flat_earth"]
