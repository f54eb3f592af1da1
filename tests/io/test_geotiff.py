"""GeoTIFF orthoimages and DEMs (``io.geotiff``): an image formed by sarnav written geocoded opens in rasterio with its
CRS and puts each scatterer within one pixel of its map position; a DEM gives heights by bilinear interpolation at
lat/lon (exact on a plane), NaN next to nodata and outside; UTM map coordinates against the meridian arc computed
here; write -> read keeps values, CRS, geotransform and nodata; bad files are one error naming the field."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")
from affine import Affine  # noqa: E402

from sarnav.errors import InputDataError  # noqa: E402
from sarnav.io.geotiff import (DEM_HEIGHT_RANGE, Dem, Orthoimage, bilinear, read_dem, read_orthoimage,  # noqa: E402
                               utm_crs, write_geotiff, write_plane_geotiff)

WGS84_A, WGS84_F = 6378137.0, 1 / 298.257223563


def _peak(values, near, radius=3):
    r0, c0 = (int(round(v)) for v in near)
    win = np.nan_to_num(values[r0 - radius:r0 + radius + 1, c0 - radius:c0 + radius + 1], nan=-np.inf)
    i, j = np.unravel_index(np.argmax(win), win.shape)
    return r0 - radius + i, c0 - radius + j


def test_image_geocoded_puts_each_scatterer_within_one_pixel(ground_scene, tmp_path):
    import sarkit.wgs84 as wgs84

    g = ground_scene
    path = write_plane_geotiff(tmp_path / "image.tif", g.image.data, g.grid)
    with rasterio.open(path) as src:                         # a plain GIS reader sees the georeference
        assert src.crs.to_epsg() == 32756 and src.count == 1 and src.dtypes[0] == "float32"
        assert math.isnan(src.nodata) and src.transform.b == 0 and src.transform.d == 0 and src.transform.e < 0
        assert src.transform.a == pytest.approx(0.6)
    ortho = read_orthoimage(path)
    assert ortho.crs.to_epsg() == 32756 and np.isnan(ortho.values).any() and np.isfinite(ortho.values).sum() > 4000
    llh = wgs84.cartesian_to_geodetic(g.truth)
    rows, cols = ortho.pixel_of(llh[:, 0], llh[:, 1])
    for k in range(len(g.truth)):
        peak = _peak(ortho.values, (rows[k], cols[k]))
        assert abs(peak[0] - rows[k]) <= 1.0 and abs(peak[1] - cols[k]) <= 1.0, (k, peak, rows[k], cols[k])
        # and the peak's centre maps back to within one pixel (0.6 m) of the scatterer on the ground
        lat, lon = ortho.latlon_of(*peak)
        d = wgs84.geodetic_to_cartesian([float(lat), float(lon), llh[k, 2]]) - g.truth[k]
        assert np.linalg.norm(d) < 0.6 * math.sqrt(2), d
        print(f"scatterer {k}: peak - map position {peak[0] - rows[k]:+.3f}, {peak[1] - cols[k]:+.3f} px; "
              f"peak centre {np.linalg.norm(d):.3f} m from the scatterer")
    # the amplitude at the scatterers is the image's (bilinear samples of |image| near its peaks)
    assert np.all(ortho.sample(llh[:, 0], llh[:, 1]) > 0.5 * np.abs(g.image.data).max())


def test_a_slant_plane_is_refused(ground_scene, tmp_path):
    from sarnav.imaging.grid import PlaneGrid

    g = ground_scene.grid
    tilted = PlaneGrid(g.origin, g.row_direction, math.cos(0.3) * g.col_direction + math.sin(0.3) * np.cross(
        g.row_direction, g.col_direction), g.rows, g.cols)
    with pytest.raises(InputDataError, match="^grid: .*tilted 17.2 deg"):
        write_plane_geotiff(tmp_path / "x.tif", ground_scene.image.data, tilted)


def _meridian_arc(lat_deg: float) -> float:
    """Length of the WGS-84 meridian from the equator [m]: the integral of the meridional radius of curvature."""
    e2 = WGS84_F * (2 - WGS84_F)
    phi = np.linspace(0.0, math.radians(lat_deg), 20001)
    m = WGS84_A * (1 - e2) / (1 - e2 * np.sin(phi) ** 2) ** 1.5
    return float(np.sum(0.5 * (m[1:] + m[:-1]) * np.diff(phi)))


def test_dem_heights_by_bilinear_interpolation_geographic_and_utm(tmp_path):
    rng = np.random.default_rng(5)
    # geographic DEM, 0.001 deg cells, heights a plane in lat/lon (bilinear interpolation is exact on it)
    lat_top, lon_left, d = 46.05, 7.40, 0.001
    h, w = 40, 50
    lat_c = lat_top - (np.arange(h) + 0.5) * d
    lon_c = lon_left + (np.arange(w) + 0.5) * d
    plane = lambda la, lo: 1200.0 + 3000.0 * (la - 46.0) - 1700.0 * (lo - 7.4)   # noqa: E731
    z = plane(lat_c[:, None], lon_c[None, :]).astype(np.float32)
    z[10, 20] = -32768.0                                        # a void flagged as nodata
    z[30, 5] = 1e6                                              # an implausible height, not flagged
    write_geotiff(tmp_path / "dem.tif", z, "EPSG:4326", Affine(d, 0, lon_left, 0, -d, lat_top), nodata=-32768.0)
    dem = read_dem(tmp_path / "dem.tif")
    assert isinstance(dem, Dem) and dem.nodata == -32768.0 and np.isnan(dem.values[10, 20])
    assert np.isnan(dem.values[30, 5]) and DEM_HEIGHT_RANGE[1] < 1e6
    la = rng.uniform(lat_c[-1], lat_c[0], 500)
    lo = rng.uniform(lon_c[0], lon_c[-1], 500)
    hgt = dem.height(la, lo)
    r, c = dem.pixel_of(la, lo)
    near_void = ((np.abs(r - 10) < 1) & (np.abs(c - 20) < 1)) | ((np.abs(r - 30) < 1) & (np.abs(c - 5) < 1))
    assert np.all(np.isnan(hgt[near_void])) and near_void.sum() >= 1
    assert np.allclose(hgt[~near_void], plane(la, lo)[~near_void], atol=2e-3)
    assert dem.height(lat_c[3], lon_c[4]) == pytest.approx(float(z[3, 4]))      # on a pixel centre: that pixel
    assert np.all(np.isnan(dem.height([lat_top + 0.01, 46.0, 46.02], [7.42, 7.39, lon_c[-1] + 0.0004])))
    # the same heights on a UTM map (zone 32: central meridian 9 E): the map coordinates against the meridian arc
    crs = utm_crs(46.0, 9.0)
    assert crs == "EPSG:32632"
    y0 = 0.9996 * _meridian_arc(46.0)
    x_left, y_top, s = 500_000.0 - 1000.0, y0 + 1000.0, 25.0
    xc = x_left + (np.arange(80) + 0.5) * s
    yc = y_top - (np.arange(80) + 0.5) * s
    zz = (500.0 + 0.01 * (xc[None, :] - 500_000.0) + 0.02 * (yc[:, None] - y0)).astype(np.float64)
    write_geotiff(tmp_path / "utm.tif", zz, crs, (s, 0, x_left, 0, -s, y_top))
    utm = read_dem(tmp_path / "utm.tif")
    assert utm.nodata is None
    x, y = utm.map_xy(46.0, 9.0)                               # on the central meridian: x = 500 km, y = k0 M
    assert abs(float(x) - 500_000.0) < 1e-3 and abs(float(y) - y0) < 1e-3
    assert utm.height(46.0, 9.0) == pytest.approx(500.0, abs=1e-6)


def test_write_read_round_trip_keeps_values_crs_transform_nodata(tmp_path):
    rng = np.random.default_rng(1)
    t = Affine(30.0, 0.0, 300_000.0, 0.0, -30.0, 5_000_000.0)
    ints = rng.integers(-100, 100, (7, 9)).astype(np.int16)
    ints[2, 3] = -9999
    write_geotiff(tmp_path / "i.tif", ints, 32618, t, nodata=-9999)
    o = read_orthoimage(tmp_path / "i.tif")
    assert isinstance(o, Orthoimage) and o.crs.to_epsg() == 32618 and o.transform == t and o.nodata == -9999.0
    assert np.isnan(o.values[2, 3]) and np.array_equal(np.delete(o.values.ravel(), 2 * 9 + 3),
                                                     np.delete(ints.ravel(), 2 * 9 + 3).astype(float))
    cplx = (rng.standard_normal((2, 6, 5)) + 1j * rng.standard_normal((2, 6, 5))).astype(np.complex64)
    write_geotiff(tmp_path / "c.tif", cplx, "EPSG:4326", (1e-4, 0, 10.0, 0, -1e-4, 50.0))
    assert np.array_equal(read_orthoimage(tmp_path / "c.tif", band=2).values, cplx[1])
    with pytest.raises(InputDataError, match=r"^geotiff.band: must be an integer in \[1, 2\], got 3"):
        read_orthoimage(tmp_path / "c.tif", band=3)


def test_bilinear_is_exact_on_planes_and_nan_next_to_nodata():
    v = np.add.outer(2.0 * np.arange(5), 3.0 * np.arange(6))
    r = np.array([0.0, 0.5, 3.25, 4.0, -0.01, 4.01, np.nan])
    c = np.array([0.0, 4.75, 2.5, 5.0, 1.0, 1.0, 1.0])
    out = bilinear(v, r, c)
    assert np.allclose(out[:4], 2 * r[:4] + 3 * c[:4]) and np.all(np.isnan(out[4:]))
    v[1, 1] = np.nan
    assert np.isnan(bilinear(v, 0.5, 0.5)) and bilinear(v, 0.0, 0.0) == 0.0 and bilinear(v, 2.0, 1.0) == 7.0


def test_bad_files_are_named(tmp_path):
    v = np.ones((4, 4), np.float32)
    with rasterio.open(tmp_path / "nocrs.tif", "w", driver="GTiff", width=4, height=4, count=1, dtype="float32",
                       transform=Affine(1, 0, 0, 0, -1, 4)) as f:
        f.write(v, 1)
    with pytest.raises(InputDataError, match=r"^geotiff.crs: CRS missing.*nocrs.tif"):
        read_orthoimage(tmp_path / "nocrs.tif")
    with pytest.warns(Warning):
        with rasterio.open(tmp_path / "plain.tif", "w", driver="GTiff", width=4, height=4, count=1,
                           dtype="float32") as f:
            f.write(v, 1)
    with pytest.raises(InputDataError, match=r"^geotiff.(crs|transform): "):
        read_orthoimage(tmp_path / "plain.tif")
    (tmp_path / "junk.tif").write_bytes(b"II*\x00" + b"\xff" * 60)
    with pytest.raises(InputDataError, match=r"^geotiff: not a readable GeoTIFF"):
        read_orthoimage(tmp_path / "junk.tif")
    with pytest.raises(InputDataError, match=r"^geotiff: not a readable file"):
        read_dem(tmp_path / "missing.tif")
    write_geotiff(tmp_path / "tiny.tif", np.ones((1, 5)), "EPSG:4326", (1, 0, 0, 0, -1, 1))
    with pytest.raises(InputDataError, match=r"^geotiff.size: must be at least 2 x 2"):
        read_orthoimage(tmp_path / "tiny.tif")
    with pytest.raises(InputDataError, match=r"^transform: must be finite and invertible"):
        write_geotiff(tmp_path / "x.tif", v, "EPSG:4326", (1, 0, 0, 0, 0, 4))
    with pytest.raises(InputDataError, match=r"^crs: not a coordinate reference system"):
        write_geotiff(tmp_path / "x.tif", v, "EPSG:999999", (1, 0, 0, 0, -1, 4))


def test_missing_rasterio_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "rasterio", None)
    with pytest.raises(InputDataError, match=r"^geotiff: .*pip install 'sarnav\[geo\]'"):
        read_dem(tmp_path / "dem.tif")
