"""Local NED frame at a geodetic reference point <-> WGS-84 ECEF (rigid transform, float64).

``ecef = ecef(ref) + N n + E e - D u`` with n, e, u the local north, east and up unit vectors of
the WGS-84 ellipsoid at the reference point (geodetic latitude; sarkit.wgs84). Distances are
preserved exactly up to rounding (~1e-9 m at ECEF magnitudes), so a back-projected image is the
same in either frame.
"""

from __future__ import annotations

import numpy as np
import sarkit.wgs84 as wgs84

from sarnav.errors import InputDataError

__all__ = ["ned_basis", "ned_to_ecef", "ecef_to_ned", "check_reference_point", "ground_grid_to_ecef",
           "grid_to_ecef"]


def check_reference_point(reference_point) -> np.ndarray:
    """(lat [deg], lon [deg], height above ellipsoid [m]) as a float64 array, validated."""
    ref = np.asarray(reference_point, dtype=np.float64)
    if ref.shape != (3,) or not np.all(np.isfinite(ref)) or abs(ref[0]) > 90 or abs(ref[1]) > 360:
        raise InputDataError("reference_point", f"must be finite (lat deg in [-90, 90], lon deg, hae m), got {reference_point!r}")
    return ref


def ned_basis(reference_point) -> tuple[np.ndarray, np.ndarray]:
    """(origin ECEF (3,), R (3, 3)) with columns north, east, down in ECEF."""
    ref = check_reference_point(reference_point)
    origin = wgs84.geodetic_to_cartesian(ref)
    rot = np.stack([wgs84.north(ref), wgs84.east(ref), -wgs84.up(ref)], axis=1)
    return origin, rot


def ned_to_ecef(ned, reference_point) -> np.ndarray:
    """(..., 3) NED [m] relative to the reference point -> (..., 3) ECEF [m]."""
    origin, rot = ned_basis(reference_point)
    return origin + np.asarray(ned, dtype=np.float64) @ rot.T


def ecef_to_ned(ecef, reference_point) -> np.ndarray:
    """(..., 3) ECEF [m] -> NED [m] relative to the reference point."""
    origin, rot = ned_basis(reference_point)
    return (np.asarray(ecef, dtype=np.float64) - origin) @ rot


def ground_grid_to_ecef(grid, reference_point):
    """A ``GroundGrid`` (NED at the reference point) as the same pixels on a ``PlaneGrid`` in ECEF
    (rows along north, columns along east, the plane ``down = grid.down``)."""
    from sarnav.imaging.grid import PlaneGrid

    origin, rot = ned_basis(reference_point)
    o = origin + rot @ np.array([0.0, 0.0, float(grid.down)])
    return PlaneGrid(o, rot[:, 0], rot[:, 1], grid.north, grid.east, "north", "east")


def grid_to_ecef(grid, reference_point):
    """Any plane grid in NED at the reference point (``GroundGrid``, ``SlantGrid``, ``PlaneGrid``) as the same
    pixels on a ``PlaneGrid`` in ECEF (same axes and names; a rigid transform, so distances are unchanged)."""
    from sarnav.imaging.grid import GroundGrid, PlaneGrid, SlantGrid

    if isinstance(grid, GroundGrid):
        return ground_grid_to_ecef(grid, reference_point)
    origin, rot = ned_basis(reference_point)
    if isinstance(grid, SlantGrid):
        o, a, b, rows, cols, names = (grid.origin, grid.direction, grid.normal_in_plane, grid.along_track,
                                      grid.slant_range, ("along_track", "slant_range"))
    elif isinstance(grid, PlaneGrid):
        o, a, b, rows, cols, names = (grid.origin, grid.row_direction, grid.col_direction, grid.rows, grid.cols,
                                      (grid.row_name, grid.col_name))
    else:
        raise InputDataError("grid", f"must be a GroundGrid, SlantGrid or PlaneGrid (a plane), got {type(grid).__name__}")
    return PlaneGrid(origin + rot @ np.asarray(o, dtype=np.float64), rot @ a, rot @ b, rows, cols, *names)
