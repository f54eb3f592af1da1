"""``imaging.geocode`` on a circular orbit about the origin, where zero Doppler has a closed form: |r| is constant, so
r . v = 0 and (p - r) . v = 0 reduces to p . v = 0, i.e. omega t0 = atan2(p_y, p_x) for an orbit in the x-y plane.
(The orbit is a geometric test object, not a physical one: geocoding is pure geometry.)"""

import math

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.frames.wgs84 import geodetic_to_ecef
from sarnav.imaging.geocode import OrbitArc, geocode, image_coordinates, zero_doppler
from sarnav.radar.terrain import Terrain, map_grid_around

RADIUS, SPEED = 7.0e6, 7500.0
OMEGA = SPEED / RADIUS
T = np.arange(0.0, 2.0, 0.01)


def _orbit(t):
    a = OMEGA * np.asarray(t, float)
    return RADIUS * np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=-1)


@pytest.fixture(scope="module")
def arc():
    return OrbitArc.fit(T, _orbit(T), t0=1.0)


def _closed_form(points):
    t0 = np.arctan2(points[:, 1], points[:, 0]) / OMEGA
    return t0, np.linalg.norm(points - _orbit(t0), axis=1)


def test_arc_reproduces_the_orbit_and_its_derivatives(arc):
    t = np.array([0.1, 1.0, 1.7])
    r, v, a = arc.derivatives(t)
    w = OMEGA * t
    np.testing.assert_allclose(r, _orbit(t), rtol=0, atol=1e-6)
    np.testing.assert_allclose(v, SPEED * np.stack([-np.sin(w), np.cos(w), 0 * w], 1), rtol=0, atol=1e-6)
    np.testing.assert_allclose(a, -SPEED * OMEGA * np.stack([np.cos(w), np.sin(w), 0 * w], 1), rtol=0, atol=1e-6)
    # the second-order arc of a state: r + v dt + a dt^2 / 2
    s = OrbitArc.from_state(1.0, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [2.0, 0.0, -2.0])
    np.testing.assert_allclose(s.derivatives(np.array([3.0]))[0][0], [1 + 8 + 4, 2 + 10, 3 + 12 - 4])


def test_zero_doppler_time_and_range_match_the_closed_form(arc):
    rng = np.random.default_rng(2)
    lat = np.radians(rng.uniform(2.0, 4.0, 20))
    lon = OMEGA * rng.uniform(0.3, 1.7, 20)  # TOCs inside the arc
    p = geodetic_to_ecef(lat, lon, rng.uniform(0.0, 500.0, 20))
    t0, rng_ = zero_doppler(arc, p)
    t_ref, r_ref = _closed_form(p)
    np.testing.assert_allclose(t0, t_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rng_, r_ref, rtol=1e-12)


def test_geocode_samples_a_linear_image_at_the_closed_form_coordinates(arc):
    """Bilinear interpolation of amplitude(row, col) = 2 row + 3 col is exact, so every map cell inside the image gets
    2 row + 3 col of its own zero-Doppler coordinates; cells outside the image get 0."""
    lat_c, lon_c, h = math.radians(3.0), OMEGA * 1.0, 120.0
    grid = map_grid_around(lat_c, lon_c, 1000.0, 1000.0, 100.0)
    terrain = Terrain(grid, np.full(grid.shape, h))
    lat, lon = grid.cell_latlon()
    pts = geodetic_to_ecef(lat, lon, np.full(lat.shape, h)).reshape(-1, 3)
    t_ref, r_ref = _closed_form(pts)
    prf, dr = 1000.0, 5.0
    t_first, r_first = float(np.median(t_ref)) - 0.1, float(np.median(r_ref)) - 600.0
    n_rows, n_cols = 200, 240  # +-0.1 s, -600..+600 m: part of the map falls outside
    i, j = np.meshgrid(np.arange(n_rows), np.arange(n_cols), indexing="ij")
    out = geocode(2.0 * i + 3.0 * j, t_first, prf, r_first, dr, arc, grid, terrain)
    row, col = (t_ref - t_first) * prf, (r_ref - r_first) / dr
    inside = (row >= 0) & (row <= n_rows - 1) & (col >= 0) & (col <= n_cols - 1)
    assert 0.2 < inside.mean() < 0.9  # both cases present
    np.testing.assert_allclose(out.ravel()[inside], (2.0 * row + 3.0 * col)[inside], rtol=1e-9)
    far = (row < -1) | (row > n_rows) | (col < -1) | (col > n_cols)
    np.testing.assert_array_equal(out.ravel()[far], 0.0)
    r2, c2 = image_coordinates(arc, pts, t_first, prf, r_first, dr)
    np.testing.assert_allclose(r2, row, atol=1e-5)
    np.testing.assert_allclose(c2, col, atol=1e-6)


def test_too_few_positions_for_the_fit_is_named():
    with pytest.raises(InputDataError, match="positions"):
        OrbitArc.fit(T[:4], _orbit(T[:4]), t0=0.0, degree=5)
