"""Geodetic strapdown (Sun 2022 eqs. 2.48-2.59 reconstructed): stationary on the rotating Earth, great circle,
eastward parallel, maneuvering flight, agreement with the flat mechanization over short spans, input checks."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.frames.wgs84 import geodetic_difference_ned, gravity_ned, earth_rate_ned, radii_of_curvature
from sarnav.ins import NavState, mechanize
from sarnav.ins.geodetic import (
    GeodeticNavState,
    attitude_step,
    mechanize_geodetic,
    navigation_rate,
    translational_step,
)
from sarnav.rotations import euler_to_quat, quat_to_dcm
from sarnav.trajectory import Maneuvering, StraightLevel
from sarnav.trajectory.geodetic import GeodeticFlight

LAT0, LON0 = np.radians(35.2), np.radians(-97.4)


def _nav(s, i=0):
    return GeodeticNavState(s.lat[i:i + 1].copy(), s.lon[i:i + 1].copy(), s.h[i:i + 1].copy(),
                            s.velocity[i:i + 1].copy(), s.quaternion[i:i + 1].copy())


def _err(out, s):
    return geodetic_difference_ned(out["lat"][0], out["lon"][0], out["h"][0], s.lat, s.lon, s.h)


def test_stationary_imu_on_the_rotating_earth_stays_put():
    """An IMU at rest senses -g and the Earth rate; one hour of mechanization keeps it within 1 mm. Without the
    Earth-rate terms the same data drift by kilometres (the terms are really used)."""
    q = euler_to_quat(0.1, -0.05, 1.0)
    C = quat_to_dcm(q)
    f_b = C.T @ (-gravity_ned(LAT0, 300.0))
    w_b = C.T @ earth_rate_ned(LAT0)
    t = np.arange(36001) * 0.1
    nav = GeodeticNavState(np.array([LAT0]), np.array([LON0]), np.array([300.0]), np.zeros((1, 3)), q[None])
    f = np.broadcast_to(f_b, (1, t.size, 3))
    w = np.broadcast_to(w_b, (1, t.size, 3))
    out = mechanize_geodetic(nav, t, f, w)
    e = geodetic_difference_ned(out["lat"][0, -1], out["lon"][0, -1], out["h"][0, -1], LAT0, LON0, 300.0)
    assert np.abs(e).max() < 1e-3
    wrong = mechanize_geodetic(nav, t, f, w, earth_rate=False)
    e = geodetic_difference_ned(wrong["lat"][0, -1], wrong["lon"][0, -1], wrong["h"][0, -1], LAT0, LON0, 300.0)
    assert np.hypot(e[0], e[1]) > 1e3


@pytest.mark.parametrize("heading,h0", [(0.0, 0.0), (np.pi / 2, 1000.0)])
def test_great_circle_and_parallel_flights(heading, h0):
    """Meridian (a geodesic) and an eastward parallel at constant height: the ideal IMU of the truth flight,
    mechanized at 100 Hz for 10 min (60 km), stays within 2 mm of truth (the Earth terms are evaluated at the
    start of each step, first order: measured 1.3 mm; a sign error in any Coriolis or transport term gives
    kilometres); on the parallel the latitude stays put and the longitude grows as v t / ((R_E + h) cos L)."""
    g = GeodeticFlight(StraightLevel([0.0, 0.0, -h0], 100.0, heading, 600.0), LAT0, LON0, h0)
    t = np.arange(60001) / 100.0
    s = g.state(t)
    f, w = g.imu(t)
    out = mechanize_geodetic(_nav(s), t, f[None], w[None])
    assert np.abs(_err(out, s)).max() < 2e-3
    if heading:
        _, re = radii_of_curvature(LAT0)
        assert abs(out["lat"][0, -1] - LAT0) < 1e-13
        assert out["lon"][0, -1] - LON0 == pytest.approx(100.0 * 600.0 / ((re + h0) * np.cos(LAT0)), rel=1e-9)


def test_maneuvering_flight_linear_hold_is_second_order():
    """S-turn with climb over 120 s: 1.5 cm at 100 Hz, about 4x less at 200 Hz (trapezoid rule); the source's
    zero-order hold is first order (about 2x less per doubling)."""
    g = GeodeticFlight(Maneuvering.s_turn_climb([0.0, 0.0, -1000.0], 50.0, 0.3, 120.0), LAT0, LON0, 1000.0)
    errs = {}
    for rate in (100.0, 200.0):
        t = np.arange(int(120 * rate) + 1) / rate
        s = g.state(t)
        f, w = g.imu(t)
        for hold in ("linear", "zoh"):
            errs[hold, rate] = np.abs(_err(mechanize_geodetic(_nav(s), t, f[None], w[None], hold=hold), s)).max()
    assert errs["linear", 100.0] < 0.015
    assert 3.0 < errs["linear", 100.0] / errs["linear", 200.0] < 5.0
    assert 1.6 < errs["zoh", 100.0] / errs["zoh", 200.0] < 2.4


def test_geodetic_and_flat_mechanizations_agree_over_short_spans():
    """The flat mechanization on the flat truth's IMU and the geodetic one on the same flight over the rotating
    ellipsoid reproduce the same NED velocity history; displacements agree to the integration accuracy."""
    flat = Maneuvering.s_turn_climb([0.0, 0.0, -1000.0], 50.0, 0.3, 60.0)
    g = GeodeticFlight(flat, LAT0, LON0, 1000.0)
    t = np.arange(6001) / 100.0
    s, sf = g.state(t), flat.state(t)
    f, w = g.imu(t)
    geo = mechanize_geodetic(_nav(s), t, f[None], w[None])
    z = np.zeros((1, 3))
    nav = NavState(sf.position[:1].copy(), sf.velocity[:1].copy(), sf.quaternion[:1].copy(), z, z.copy())
    flat_end, _, _ = mechanize(nav, t, flat.specific_force(t)[None], flat.angular_rate(t)[None], 1e9, 1e9)
    np.testing.assert_allclose(geo["v"][0, -1], flat_end.v[0], atol=5e-4)
    # displacement along the path in metres: increments scaled by the local radii (curvilinear NED)
    lat, lon, h = geo["lat"][0], geo["lon"][0], geo["h"][0]
    lat_mid, h_mid = 0.5 * (lat[1:] + lat[:-1]), 0.5 * (h[1:] + h[:-1])
    rn, re = radii_of_curvature(lat_mid)
    d_geo = [np.sum(np.diff(lat) * (rn + h_mid)), np.sum(np.diff(lon) * (re + h_mid) * np.cos(lat_mid)), -(h[-1] - h[0])]
    np.testing.assert_allclose(d_geo, flat_end.p[0] - sf.position[0], atol=0.02)


def test_numba_and_numpy_front_ends_agree():
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.uniform(-1, 1, 5), rng.uniform(-3, 3, 5), rng.uniform(0, 1e4, 5), rng.normal(0, 50, (5, 3))])
    f = rng.normal(0, 3, (5, 3)) - [0, 0, 9.8]
    y = translational_step(x, f, 0.01)
    w = navigation_rate(x[:, 0], x[:, 2], x[:, 3:])
    vdot = (y[:, 3:] - x[:, 3:]) / 0.01
    want = f + gravity_ned(x[:, 0], x[:, 2]) - np.cross(w + earth_rate_ned(x[:, 0]), x[:, 3:])
    np.testing.assert_allclose(vdot, want, rtol=1e-9, atol=1e-9)
    q = euler_to_quat(0.1, 0.2, 0.3)[None].repeat(5, 0)
    q2 = attitude_step(q, rng.normal(0, 0.1, (5, 3)), w, 0.01)
    np.testing.assert_allclose(np.linalg.norm(q2, axis=-1), 1.0, atol=1e-14)


def test_bad_imu_input_is_named():
    nav = GeodeticNavState(np.array([LAT0]), np.array([LON0]), np.array([0.0]), np.zeros((1, 3)),
                           euler_to_quat(0.0, 0.0, 0.0)[None])
    t = np.arange(5) * 0.01
    f = np.zeros((1, 5, 3))
    bad = f.copy()
    bad[0, 2, 1] = np.nan
    with pytest.raises(InputDataError, match="imu.specific_force"):
        mechanize_geodetic(nav, t, bad, f)
    with pytest.raises(InputDataError, match="imu.time"):
        mechanize_geodetic(nav, t[::-1], f, f)
    with pytest.raises(InputDataError, match="imu.angular_rate"):
        mechanize_geodetic(nav, t, f, np.zeros((1, 4, 3)))


def test_cloud_step_with_shared_latitude_functions_matches_per_particle_step():
    """The particle filters' step evaluates radii, gravity and latitude trig once at the cloud mean; for a cloud
    spread over +-20 m it agrees with the per-particle step to 1e-9 m/s and 1e-7 m (4e-7 of the step's 0.3 m)
    over a 5 ms step."""
    from sarnav.ins.geodetic import translational_step_cloud

    rng = np.random.default_rng(3)
    x = np.empty((500, 6))
    x[:, 0] = LAT0 + rng.normal(0, 20 / 6.37e6, 500)
    x[:, 1] = LON0 + rng.normal(0, 20 / 5.2e6, 500)
    x[:, 2] = 1000.0 + rng.normal(0, 20, 500)
    x[:, 3:] = [50.0, 30.0, -2.0] + rng.normal(0, 0.5, (500, 3))
    f = np.array([0.5, -0.3, -9.7])
    ref = translational_step(x, f, 0.005)
    y = x.copy()
    translational_step_cloud(y, *f, 0.005, 7.292115e-5, x[:, 0].mean(), x[:, 2].mean())
    np.testing.assert_allclose(y[:, 3:], ref[:, 3:], atol=1e-9)
    d = geodetic_difference_ned(y[:, 0], y[:, 1], y[:, 2], ref[:, 0], ref[:, 1], ref[:, 2])
    assert np.abs(d).max() < 1e-7
