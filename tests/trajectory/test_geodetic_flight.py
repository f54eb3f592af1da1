"""GeodeticFlight: positions against Vincenty (pymap3d) and the ideal IMU against an independent inertial-frame
differentiation of ECEF positions."""

import numpy as np
import pytest
from pymap3d.vincenty import vreckon

from sarnav.frames.earth import OMEGA_EARTH
from sarnav.frames.wgs84 import geodetic_to_ecef, gravity_ned, ned_to_ecef_dcm
from sarnav.rotations import quat_to_dcm
from sarnav.trajectory import Maneuvering, StraightLevel
from sarnav.trajectory.geodetic import GeodeticFlight

LAT0, LON0 = np.radians(35.2), np.radians(-97.4)


def test_meridian_flight_follows_the_geodesic():
    g = GeodeticFlight(StraightLevel([0.0, 0.0, 0.0], 100.0, 0.0, 600.0), LAT0, LON0, 0.0)
    t = np.array([0.0, 150.0, 600.0])
    s = g.state(t)
    lat, lon = vreckon(np.degrees(LAT0), np.degrees(LON0), 100.0 * t, 0.0)
    np.testing.assert_allclose(s.lat, np.radians(lat), atol=1e-11)  # 60 um
    np.testing.assert_allclose(s.lon, LON0, atol=1e-14)


def test_eastward_flight_stays_on_its_parallel():
    g = GeodeticFlight(StraightLevel([0.0, 0.0, -1000.0], 80.0, np.pi / 2, 600.0), LAT0, LON0, 1000.0)
    t = np.linspace(0, 600, 7)
    s = g.state(t)
    from sarnav.frames.wgs84 import radii_of_curvature

    _, re = radii_of_curvature(LAT0)
    np.testing.assert_allclose(s.lat, LAT0, atol=1e-15)
    np.testing.assert_allclose(s.lon, LON0 + 80.0 * t / ((re + 1000.0) * np.cos(LAT0)), atol=1e-13)


def _inertial(g, t):
    """ECI position of the flight at times t (ECI = ECEF at t = 0, rotating at Omega)."""
    s = g.state(t)
    r = geodetic_to_ecef(s.lat, s.lon, s.h)
    c, sn = np.cos(OMEGA_EARTH * t), np.sin(OMEGA_EARTH * t)
    return np.stack([c * r[..., 0] - sn * r[..., 1], sn * r[..., 0] + c * r[..., 1], r[..., 2]], -1), s


def _c_e_i(t):
    c, sn = np.cos(OMEGA_EARTH * t), np.sin(OMEGA_EARTH * t)
    return np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("t0", [13.3, 47.0, 101.6])
def test_ideal_imu_equals_inertial_kinematics(t0):
    """f^b = C_i^b (d2r_i/dt2 - G) with gravitation G = g - centrifugal; omega_ib^b from dC_b^i/dt."""
    g = GeodeticFlight(Maneuvering.s_turn_climb([0.0, 0.0, -800.0], 60.0, 0.4, 120.0), LAT0, LON0, 800.0)
    h = 0.02
    k = np.arange(-2, 3)
    ri, s = _inertial(g, t0 + h * k)
    acc = (-ri[4] + 16 * ri[3] - 30 * ri[2] + 16 * ri[1] - ri[0]) / (12 * h * h)
    r_e = geodetic_to_ecef(s.lat[2], s.lon[2], s.h[2])
    C_ne = ned_to_ecef_dcm(s.lat[2], s.lon[2])
    grav_e = C_ne @ gravity_ned(s.lat[2], s.h[2]) - OMEGA_EARTH**2 * np.array([r_e[0], r_e[1], 0.0])
    C_ei = _c_e_i(t0)
    C_bn = quat_to_dcm(s.quaternion[2])
    f_b_want = C_bn.T @ C_ne.T @ (C_ei.T @ acc - grav_e)
    f_b, w_b = g.imu(np.array(t0))
    np.testing.assert_allclose(f_b, f_b_want, atol=2e-5)

    C_bi = [_c_e_i(t0 + h * j) @ ned_to_ecef_dcm(s.lat[i], s.lon[i]) @ quat_to_dcm(s.quaternion[i])
            for i, j in enumerate(k)]
    dC = (-C_bi[4] + 8 * C_bi[3] - 8 * C_bi[1] + C_bi[0]) / (12 * h)
    W = C_bi[2].T @ dC
    np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], w_b, atol=1e-9)
