"""WGS-84 Earth model: closed-form values (Sun 2022 T3-T5) and pymap3d as the independent geodesy."""

import numpy as np
import pymap3d
import pytest

from sarnav.frames.earth import OMEGA_EARTH, WGS84_A, WGS84_B, WGS84_E2
from sarnav.frames.wgs84 import (
    geodetic_difference_ned,
    geodetic_to_ecef,
    ned_offset_to_geodetic,
    ned_to_ecef_dcm,
    normal_gravity,
    radii_of_curvature,
)


def test_constants_T4():
    assert OMEGA_EARTH == 7.292115e-5


def test_radii_T5():
    rn0, re0 = radii_of_curvature(0.0)
    rn90, re90 = radii_of_curvature(np.pi / 2)
    assert rn0 == pytest.approx(WGS84_A * (1 - WGS84_E2), abs=1e-6)  # 6335439.3 m
    assert rn0 == pytest.approx(6335439.327, abs=1e-3)
    assert re0 == WGS84_A
    assert rn90 == pytest.approx(WGS84_A / np.sqrt(1 - WGS84_E2), abs=1e-6) and re90 == pytest.approx(rn90)
    assert rn90 == pytest.approx(6399593.626, abs=1e-3)


def test_geodetic_to_ecef_T3_and_pymap3d():
    np.testing.assert_allclose(geodetic_to_ecef(0.0, 0.0, 0.0), [WGS84_A, 0, 0], atol=1e-9)
    assert geodetic_to_ecef(np.pi / 2, 0.3, 0.0)[2] == pytest.approx(WGS84_B, abs=1e-6)  # 6356752.314 m
    rng = np.random.default_rng(0)
    lat, lon, h = rng.uniform(-1.5, 1.5, 50), rng.uniform(-3, 3, 50), rng.uniform(-100, 1e4, 50)
    want = np.stack(pymap3d.geodetic2ecef(lat, lon, h, deg=False), -1)
    np.testing.assert_allclose(geodetic_to_ecef(lat, lon, h), want, rtol=0, atol=1e-6)


def test_ned_to_ecef_dcm_matches_pymap3d():
    rng = np.random.default_rng(1)
    lat, lon = rng.uniform(-1.5, 1.5, 20), rng.uniform(-3, 3, 20)
    v = rng.normal(size=(20, 3))
    C = ned_to_ecef_dcm(lat, lon)
    back = np.stack(pymap3d.ecef2nedv(*np.einsum("nij,nj->ni", C, v).T, lat, lon, deg=False), -1)
    np.testing.assert_allclose(back, v, atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(C), 1.0, atol=1e-12)


def test_normal_gravity_equator_pole_and_free_air():
    assert normal_gravity(0.0, 0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert normal_gravity(np.pi / 2, 0.0) == pytest.approx(9.8321849378, abs=1e-9)  # TR8350.2 gamma_p
    # free-air gradient ~ -3.086e-6 s^-2 at mid latitude
    dg = (normal_gravity(0.7, 1000.0) - normal_gravity(0.7, 0.0)) / 1000.0
    assert dg == pytest.approx(-3.086e-6, rel=0.01)


def test_ned_offsets_round_trip_against_pymap3d():
    lat0, lon0, h0 = 0.6, -1.7, 500.0
    d = np.array([[30.0, -40.0, 5.0], [-2.0, 1.0, -0.5]])
    lat, lon, h = ned_offset_to_geodetic(lat0, lon0, h0, d)
    np.testing.assert_allclose(geodetic_difference_ned(lat, lon, h, lat0, lon0, h0), d, atol=1e-9)
    n, e, dd = pymap3d.geodetic2ned(lat, lon, h, lat0, lon0, h0, deg=False)
    np.testing.assert_allclose(np.stack([n, e, dd], -1), d, atol=2e-4)  # tangent plane vs curvilinear at 50 m
