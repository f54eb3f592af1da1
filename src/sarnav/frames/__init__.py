"""Frames and the Earth (ground floor: imports only ``units`` and ``errors``).

- ``ned``: the Earth-fixed NED tangent frame with constant gravity (aircraft scenarios): :data:`GRAVITY_NED`,
  :func:`earth_rate_tangent` (the frame's rate when a scenario turns ``earth.rotation`` on; off by default, the
  sources' non-rotating Earth)
- ``earth``: WGS-84 constants (and, for orbiting vehicles, ECEF / ECI / geodetic frames)
"""

from sarnav.frames.ned import GRAVITY_NED, earth_rate_or_zero, earth_rate_tangent, gravity_ned

__all__ = ["GRAVITY_NED", "earth_rate_or_zero", "earth_rate_tangent", "gravity_ned"]
