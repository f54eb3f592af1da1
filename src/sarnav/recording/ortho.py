"""Reference (b) of a recording (docs/recording.md §6b): a geocoded orthoimage (GeoTIFF) and an optional DEM, read
with rasterio (an optional dependency: ``pip install 'sarnav[geo]'``), and the product as the image extractor asks
for it (``measurements.sar_product.GeocodedProduct``): the amplitude at NED ground points and the surface's down at
a horizontal position.

A raster's pixel (row, col) centre is ``transform * (col + 0.5, row + 0.5)`` in its CRS (GDAL's convention); points
are taken from the recording's NED frame to WGS-84 (``pymap3d.ned2geodetic`` at the manifest's origin) and, when the
raster's CRS is not geographic WGS-84 (EPSG:4326), to its CRS (``rasterio.warp.transform``). Values between pixel
centres are interpolated bicubically (``scipy.ndimage.map_coordinates``, order 3, on the amplitude: sample the
product at least three pixels per resolution cell); a point outside the raster or next to a nodata pixel reads NaN.
The orthoimage's value is the amplitude (a complex band: its magnitude). The DEM holds heights above the WGS-84
ellipsoid [m]; without one the surface is the origin's tangent plane (down = 0).

This module is the recording's own minimal GeoTIFF reader and writer (``sarnav.io.geotiff`` may replace it).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sarnav.errors import ConfigError, InputDataError

__all__ = ["Raster", "read_raster", "write_geotiff", "OrthoProduct", "GEO_EXTRA"]

GEO_EXTRA = "pip install 'sarnav[geo]'"
_WGS84 = "EPSG:4326"


def _rasterio():
    try:
        import rasterio
        import rasterio.warp  # noqa: F401
    except ImportError:
        raise ConfigError("rasterio", f"reading or writing a GeoTIFF reference needs rasterio: {GEO_EXTRA}") from None
    return rasterio


@dataclass(frozen=True)
class Raster:
    """One band of a GeoTIFF: ``data`` (H, W) float64 (nodata -> NaN), its affine ``transform`` (pixel corner ->
    CRS) and ``crs`` (text, e.g. ``EPSG:4326``)."""

    data: np.ndarray
    transform: object
    crs: str

    def sample(self, x, y) -> np.ndarray:
        """Bicubic interpolation at CRS coordinates (x, y) (arrays of one shape); NaN outside or near nodata."""
        from scipy import ndimage

        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        col, row = ~self.transform @ (x.ravel(), y.ravel())
        coords = np.stack([np.asarray(row) - 0.5, np.asarray(col) - 0.5])
        bad = np.isnan(self.data)
        filled = np.where(bad, 0.0, self.data)
        out = ndimage.map_coordinates(filled, coords, order=3, mode="constant", cval=np.nan)
        if bad.any():  # a nodata pixel inside the bicubic stencil poisons the value
            near = ndimage.map_coordinates(ndimage.binary_dilation(bad, iterations=2).astype(np.float64), coords,
                                           order=0, mode="constant", cval=1.0)
            out[near > 0] = np.nan
        h, w = self.data.shape
        out[(coords[0] < 0) | (coords[0] > h - 1) | (coords[1] < 0) | (coords[1] > w - 1)] = np.nan
        return out.reshape(x.shape)


def read_raster(path, field: str) -> Raster:
    """Band 1 of the GeoTIFF ``path`` (``field``: the manifest key naming it, for errors)."""
    rio = _rasterio()
    path = Path(path)
    if not path.is_file():
        raise InputDataError(field, f"{path.name!r} is not a file of the recording")
    try:
        with rio.open(path) as ds:
            data = ds.read(1)
            nodata, transform, crs = ds.nodata, ds.transform, ds.crs
    except rio.errors.RasterioError as err:
        raise InputDataError(field, f"cannot read as a GeoTIFF ({err})") from None
    if crs is None:
        raise InputDataError(field, "has no CRS (a geocoded product states its coordinate reference system)")
    if transform.b != 0 or transform.d != 0:
        raise InputDataError(field, "has a rotated geotransform; write it north-up")
    data = np.abs(data) if np.iscomplexobj(data) else data.astype(np.float64)
    if nodata is not None and not np.isnan(nodata):
        data = np.where(data == nodata, np.nan, data)
    if not np.any(np.isfinite(data)):
        raise InputDataError(field, "holds no valid pixel")
    return Raster(data, transform, crs.to_string())


def write_geotiff(path, data, west: float, north: float, dx: float, dy: float, crs: str = _WGS84) -> None:
    """Write ``data`` (H, W) as a float32 north-up GeoTIFF: pixel (0, 0)'s corner at (west, north) in ``crs``,
    pixel size (dx, dy) (degrees for EPSG:4326), nodata NaN."""
    rio = _rasterio()
    from rasterio.transform import Affine

    data = np.asarray(data, dtype=np.float32)
    with rio.open(Path(path), "w", driver="GTiff", height=data.shape[0], width=data.shape[1], count=1,
                  dtype="float32", crs=crs, transform=Affine(dx, 0.0, west, 0.0, -dy, north), nodata=np.nan) as ds:
        ds.write(data, 1)


class OrthoProduct:
    """The orthoimage and DEM of a recording (module docstring) in its NED frame at ``origin`` (lat, lon, h);
    the ``GeocodedProduct`` of ``measurements.sar_product``. ``noise_power``: the product's noise power per pixel
    (None: estimated from the image, ``measurements.sar_product.product_noise_power``)."""

    def __init__(self, image: Raster, dem: Raster | None, origin, noise_power: float | None = None):
        self.image, self.dem = image, dem
        self.origin = tuple(float(x) for x in origin)
        self.noise_power = noise_power

    def _to_crs(self, lat, lon, crs: str):
        if crs == _WGS84:
            return lon, lat
        from rasterio.warp import transform

        x, y = transform(_WGS84, crs, np.ravel(lon), np.ravel(lat))
        return np.reshape(x, np.shape(lon)), np.reshape(y, np.shape(lat))

    def _geodetic(self, points):
        import pymap3d

        p = np.asarray(points, dtype=np.float64)
        lat, lon, h = pymap3d.ned2geodetic(p[..., 0], p[..., 1], p[..., 2], *self.origin)
        return np.asarray(lat), np.asarray(lon), np.asarray(h)

    def amplitude(self, points) -> np.ndarray:
        """The orthoimage's amplitude at the NED ground points (..., 3) (their latitude and longitude)."""
        lat, lon, _ = self._geodetic(points)
        return self.image.sample(*self._to_crs(lat, lon, self.image.crs))

    def values(self) -> np.ndarray:
        """The orthoimage's valid pixels (the noise estimate's sample)."""
        return self.image.data[np.isfinite(self.image.data)]

    def surface_down(self, points) -> np.ndarray:
        """Down [m] of the surface on the local vertical of each NED point (..., 3): the DEM's height at its
        latitude and longitude (NaN outside the DEM), or 0 without a DEM (the origin's tangent plane)."""
        p = np.asarray(points, dtype=np.float64)
        if self.dem is None:
            return np.zeros(p.shape[:-1])
        import pymap3d

        lat, lon, _ = self._geodetic(p)
        h = self.dem.sample(*self._to_crs(lat, lon, self.dem.crs))
        return np.asarray(pymap3d.geodetic2ned(lat, lon, h, *self.origin)[2])
