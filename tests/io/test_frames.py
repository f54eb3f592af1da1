"""``io.frames`` (local NED <-> WGS-84 ECEF through sarkit) against sarnav's own WGS-84 geodesy (``frames.wgs84``,
Groves 2013 eqs. 2.44, 2.49, 2.56): the down axis is the ellipsoid normal (moving up changes only the height), north
and east are the directions in which latitude and longitude grow at the meridian / transverse radii, and the map is
rigid."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.frames.wgs84 import geodetic_to_ecef, radii_of_curvature
from sarnav.imaging.grid import GroundGrid, PlaneGrid, SlantGrid
from sarnav.io.frames import ecef_to_ned, grid_to_ecef, ned_basis, ned_to_ecef

REF = (47.3, -122.8, 135.0)  # lat, lon [deg], height above the ellipsoid [m]
LAT, LON, H = np.radians(REF[0]), np.radians(REF[1]), REF[2]


def test_origin_and_basis_follow_the_ellipsoid():
    origin, rot = ned_basis(REF)
    np.testing.assert_allclose(origin, geodetic_to_ecef(LAT, LON, H), rtol=0, atol=1e-6)
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-15)
    assert np.linalg.det(rot) == pytest.approx(1.0, abs=1e-14)  # north x east = down: right-handed
    # 1 km up is 1 km more height at the same latitude and longitude (the normal is the down axis)
    np.testing.assert_allclose(ned_to_ecef([0.0, 0.0, -1000.0], REF), geodetic_to_ecef(LAT, LON, H + 1000.0),
                               rtol=0, atol=1e-6)
    # north / east: a small step in latitude / longitude moves R_N dlat / R_E cos(lat) dlon along them
    rn, re = radii_of_curvature(LAT)
    d = 1e-6  # rad: ~6 m, curvature terms ~ 3e-6 m
    dn = ecef_to_ned(geodetic_to_ecef(LAT + d, LON, H), REF)
    de = ecef_to_ned(geodetic_to_ecef(LAT, LON + d, H), REF)
    np.testing.assert_allclose(dn, [(rn + H) * d, 0.0, 0.0], rtol=0, atol=1e-4)
    np.testing.assert_allclose(de, [0.0, (re + H) * np.cos(LAT) * d, 0.0], rtol=0, atol=1e-4)


def test_the_map_is_rigid_and_inverts():
    rng = np.random.default_rng(8)
    ned = rng.uniform(-5000, 5000, (50, 3))
    ecef = ned_to_ecef(ned, REF)
    np.testing.assert_allclose(ecef_to_ned(ecef, REF), ned, rtol=0, atol=1e-8)
    d_ned = np.linalg.norm(ned[:, None] - ned[None], axis=-1)
    d_ecef = np.linalg.norm(ecef[:, None] - ecef[None], axis=-1)
    np.testing.assert_allclose(d_ecef, d_ned, rtol=0, atol=1e-8)


def test_grids_in_ecef_are_the_same_pixels():
    ground = GroundGrid.centered(100.0, 1800.0, 0.5, (7, 9), down=3.0)
    slant = SlantGrid(np.array([0.0, 0.0, -1000.0]), np.array([1.0, 0.2, 0.0]), np.array([0.0, 1800.0, 0.0]),
                      np.linspace(-5, 5, 6), np.linspace(2000, 2010, 8))
    for g in (ground, slant):
        e = grid_to_ecef(g, REF)
        assert isinstance(e, PlaneGrid) and e.shape == g.shape
        np.testing.assert_allclose(e.points(), ned_to_ecef(g.points(), REF), rtol=0, atol=1e-7)
        assert e.axes()[2:] == g.axes()[2:]


@pytest.mark.parametrize("ref", [(91.0, 0.0, 0.0), (0.0, 0.0), (np.nan, 0.0, 0.0)])
def test_a_bad_reference_point_is_named(ref):
    with pytest.raises(InputDataError, match="reference_point"):
        ned_basis(ref)
