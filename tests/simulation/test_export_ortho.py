"""``sarnav.simulation.export_ortho``: reference (b) of an exported recording, a GeoTIFF orthoimage tile per aperture
and a DEM (docs/recording.md §6b, §9).

The files are read back with rasterio and their pixel centres taken to the local NED frame with pymap3d: the tile's
peak sits where the product puts the point (target + the tile's geolocation error), its grid covers the targets
plus the margin at the documented spacing, and the DEM's heights are the terrain's above the ellipsoid.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pymap3d
import pytest

from sarnav.radar.ground_scene import HillTerrain
from sarnav.simulation.export_ortho import (DEM_SPACING_M, ORTHO_MARGIN_M, ORTHO_SPACING_M, geolocation_errors,
                                            horizontal, write_dem, write_ortho_tile)

rasterio = pytest.importorskip("rasterio")

ORIGIN = (45.0, 7.0, 300.0)


def read_tif(path):
    """(values (H, W), lat (H, W), lon (H, W)) of the pixel centres of a north-up EPSG:4326 GeoTIFF."""
    with rasterio.open(path) as ds:
        assert ds.crs.to_epsg() == 4326
        t = ds.transform
        assert t.b == 0.0 and t.d == 0.0 and t.e < 0 < t.a  # north-up
        values = ds.read(1)
        rows, cols = np.meshgrid(np.arange(ds.height) + 0.5, np.arange(ds.width) + 0.5, indexing="ij")
        lon, lat = t.c + cols * t.a, t.f + rows * t.e
    return values, lat, lon


def ned_of(lat, lon, h=ORIGIN[2]):
    """NED at ORIGIN of (lat, lon, h); the default h: the tangent plane's height near the origin (the curvature's
    few decimetres here move a point horizontally by micrometres)."""
    return np.stack(pymap3d.geodetic2ned(lat, lon, h, *ORIGIN), axis=-1)


# ---- geolocation errors --------------------------------------------------------------------------------------------


def test_horizontal_zeroes_down_and_keeps_the_input():
    sigma = [0.3, 0.4, 0.5]
    np.testing.assert_array_equal(horizontal(sigma), [0.3, 0.4, 0.0])
    assert sigma == [0.3, 0.4, 0.5]
    arr = np.array([1.0, 2.0, 3.0])
    horizontal(arr)
    np.testing.assert_array_equal(arr, [1.0, 2.0, 3.0])


def test_geolocation_errors_are_drawn_from_the_horizontal_sigma():
    """N(0, diag(sigma_N^2, sigma_E^2, 0)): sample standard deviations within 3 % over 20,000 tiles, no down."""
    err = geolocation_errors(np.random.SeedSequence(5), 20_000, [0.3, 1.2, 4.0])
    assert err.shape == (20_000, 3)
    np.testing.assert_array_equal(err[:, 2], 0.0)
    np.testing.assert_allclose(err[:, :2].std(axis=0), [0.3, 1.2], rtol=0.03)
    np.testing.assert_allclose(err[:, :2].mean(axis=0), [0.0, 0.0], atol=0.03)
    assert abs(np.corrcoef(err[:, 0], err[:, 1])[0, 1]) < 0.03


def test_geolocation_errors_follow_the_seed_without_consuming_it():
    """Same seed, same errors (and the first tiles do not depend on the number of tiles); another seed, others; the
    run's SeedSequence is read, not spawned (the campaign's own draws are untouched)."""
    seed = np.random.SeedSequence(42)
    a = geolocation_errors(seed, 6, [1.0, 1.0, 0.0])
    assert seed.n_children_spawned == 0
    before = seed.spawn(1)[0].generate_state(2)
    np.testing.assert_array_equal(a, geolocation_errors(np.random.SeedSequence(42), 6, [1.0, 1.0, 0.0]))
    np.testing.assert_array_equal(before, np.random.SeedSequence(42).spawn(1)[0].generate_state(2))
    assert not np.allclose(a, geolocation_errors(np.random.SeedSequence(43), 6, [1.0, 1.0, 0.0]))
    b = geolocation_errors(np.random.SeedSequence(42), 6, [2.0, 0.5, 0.0])
    np.testing.assert_allclose(b[:, 0], 2.0 * a[:, 0], rtol=1e-15)
    np.testing.assert_allclose(b[:, 1], 0.5 * a[:, 1], rtol=1e-15)


# ---- the orthoimage tile -------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def flat_tile(point_target_block, tmp_path_factory):
    """The tile of the conftest's point target (flat ground) with a geolocation error of (3, -2, 5) m."""
    blk = point_target_block
    path = tmp_path_factory.mktemp("ortho") / "0000.tif"
    error = np.array([3.0, -2.0, 5.0])
    ref = SimpleNamespace(pulses=blk.rc, positions=np.asarray(blk.rc.positions))
    write_ortho_tile(path, ref, blk.target[None], ORIGIN, None, error)
    return path, blk.target, error


def test_tile_peak_is_where_the_product_puts_the_point(flat_tile):
    """The tile shows the ground point (n - dn, e - de) at (n, e): the target appears at target + (dn, de)."""
    path, target, error = flat_tile
    values, lat, lon = read_tif(path)
    assert values.dtype == np.float32 and np.all(values >= 0)
    k = np.unravel_index(np.argmax(values), values.shape)
    peak = ned_of(lat[k], lon[k])
    np.testing.assert_allclose(peak[:2], target[:2] + error[:2], atol=1.5 * ORTHO_SPACING_M)
    # the peak stands well clear of the tile's edges (the point is focused, not smeared)
    assert values[k] > 20.0 * np.median(values)


def test_tile_covers_the_targets_and_margin_at_the_spacing(flat_tile):
    """North-up grid of ORTHO_SPACING_M pixels reaching ORTHO_MARGIN_M beyond the targets (half a pixel more)."""
    path, target, _ = flat_tile
    _, lat, lon = read_tif(path)
    ned = ned_of(lat, lon)
    np.testing.assert_allclose(ned[0, 0, :2], target[:2] + [ORTHO_MARGIN_M, -ORTHO_MARGIN_M], atol=0.02)
    np.testing.assert_allclose(ned[-1, -1, :2], target[:2] + [-ORTHO_MARGIN_M, ORTHO_MARGIN_M], atol=0.02)
    step_n = ned[:-1, :, 0] - ned[1:, :, 0]   # rows go south
    step_e = ned[:, 1:, 1] - ned[:, :-1, 1]   # columns go east
    np.testing.assert_allclose(step_n, ORTHO_SPACING_M, rtol=1e-3)
    np.testing.assert_allclose(step_e, ORTHO_SPACING_M, rtol=1e-3)
    assert lat.shape == (int(round(2 * ORTHO_MARGIN_M / ORTHO_SPACING_M)) + 1,) * 2


def test_tile_on_terrain_focuses_a_raised_point(small_radar, tmp_path):
    """On terrain the pixels are the terrain's surface: a point 6 m up a hill is focused at its own north and east
    (on the flat plane it is laid over towards the radar: about 6 x 1000 / 1732 = 3.5 m nearer in ground range)."""
    from sarnav.imaging.range_compression import range_compress
    from sarnav.radar.echoes import simulate_echoes
    from sarnav.radar.scene import point_targets

    hill = HillTerrain(np.array([[0.0, 1732.05]]), np.array([150.0]), np.array([6.0]))
    target = np.array([0.0, np.sqrt(2000.0**2 - 1000.0**2), 0.0])
    target[2] = -hill.height(target[0], target[1])
    n, speed = 250, 60.0
    t = (np.arange(n) - n // 2) / small_radar.prf
    pos = np.c_[speed * t, np.zeros(n), np.full(n, -1000.0)]
    rc = range_compress(simulate_echoes(small_radar, pos, t, point_targets(target)))
    ref = SimpleNamespace(pulses=rc, positions=pos)
    write_ortho_tile(tmp_path / "hill.tif", ref, target[None], ORIGIN, hill, np.zeros(3))
    values, lat, lon = read_tif(tmp_path / "hill.tif")
    k = np.unravel_index(np.argmax(values), values.shape)
    peak = ned_of(lat[k], lon[k])
    np.testing.assert_allclose(peak[:2], target[:2], atol=2.0 * ORTHO_SPACING_M)
    write_ortho_tile(tmp_path / "flat.tif", ref, target[None], ORIGIN, None, np.zeros(3))
    values, lat, lon = read_tif(tmp_path / "flat.tif")
    k = np.unravel_index(np.argmax(values), values.shape)
    assert target[1] - ned_of(lat[k], lon[k])[1] > 2.5  # the flat plane lays it over towards the radar


# ---- the DEM -------------------------------------------------------------------------------------------------------


def test_dem_holds_the_terrains_heights_above_the_ellipsoid(tmp_path):
    """Each pixel's value h at its (lat, lon) is a point of the terrain: its NED down is -terrain.height(n, e)."""
    hill = HillTerrain(np.array([[30.0, 1700.0], [-40.0, 1760.0]]), np.array([25.0, 40.0]), np.array([15.0, -8.0]))
    box = ((-60.0, 80.0), (1650.0, 1800.0))
    write_dem(tmp_path / "dem.tif", box, ORIGIN, hill)
    h, lat, lon = read_tif(tmp_path / "dem.tif")
    assert np.all(np.isfinite(h))
    ned = ned_of(lat, lon, h.astype(np.float64))
    np.testing.assert_allclose(-ned[..., 2], hill.height(ned[..., 0], ned[..., 1]), atol=2e-3)
    assert h.max() - h.min() > 15.0  # the hills are in it, not a flat sheet at the origin's height


def test_dem_covers_the_box_with_four_pixels_of_margin(tmp_path):
    flat = HillTerrain(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    box = ((-50.0, 50.0), (1700.0, 1760.0))
    write_dem(tmp_path / "dem.tif", box, ORIGIN, flat)
    h, lat, lon = read_tif(tmp_path / "dem.tif")
    ned = ned_of(lat, lon, h.astype(np.float64))
    m = 4.0 * DEM_SPACING_M
    np.testing.assert_allclose(ned[0, 0, :2], [box[0][1] + m, box[1][0] - m], atol=0.05)
    np.testing.assert_allclose(ned[-1, -1, :2], [box[0][0] - m, box[1][1] + m], atol=0.05)
    np.testing.assert_allclose(ned[:-1, :, 0] - ned[1:, :, 0], DEM_SPACING_M, rtol=1e-3)
    # the tangent plane (down 0) lies below the origin's height by the Earth's curvature only (< 1 mm here)
    np.testing.assert_allclose(ned[..., 2], 0.0, atol=2e-3)
