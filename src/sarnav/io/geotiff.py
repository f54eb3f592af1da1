"""GeoTIFF orthoimages and DEMs, read and written through rasterio (GDAL; the optional extra ``sarnav[geo]``).

* :func:`read_orthoimage` -> :class:`Orthoimage` (values with NaN at nodata, CRS, geotransform, nodata;
  ``pixel_of(lat, lon)``, ``latlon_of(rows, cols)``, ``sample(lat, lon)`` by bilinear interpolation);
* :func:`read_dem` -> :class:`Dem` (the same, heights [m]; ``height(lat, lon)``);
* :func:`write_geotiff` (values, CRS, geotransform, nodata) and :func:`write_plane_geotiff` (an image formed on a
  plane, ``imaging.grid.PlaneGrid`` in ECEF, geocoded onto a north-up UTM map: ``sarnav image --geotiff``).

Pixel convention: ``values[i, j]`` covers the map cell whose upper-left corner is ``transform * (j, i)``; fractional
pixel coordinates (row, col) are integers at pixel *centres* (GDAL's PixelIsPoint files are shifted to this by GDAL
itself). Latitude and longitude are WGS-84 geodetic degrees; map coordinates go through GDAL/PROJ
(``rasterio.warp.transform``). Only the GTiff driver is allowed (no VRT or other formats that can name other files).
Bad files raise :class:`sarnav.errors.InputDataError` naming ``geotiff`` or ``geotiff.<field>``, the file and the
valid range; nothing is read beyond :data:`MAX_PIXELS`.
"""

from __future__ import annotations

import contextlib
import logging
import math
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sarnav.errors import InputDataError

__all__ = ["check_geo_extra", "GEO_EXTRA", "MAX_PIXELS", "DEM_HEIGHT_RANGE", "MAX_TILT_DEG", "Orthoimage", "Dem", "read_orthoimage", "read_dem",
           "write_geotiff", "write_plane_geotiff", "utm_crs", "bilinear"]

#: the install hint of the optional extra
GEO_EXTRA = "pip install 'sarnav[geo]'"
#: the largest raster read or written [pixels] (float64 values: 1 GiB)
MAX_PIXELS = 2**27
#: the largest tilt of an image plane from the horizontal that :func:`write_plane_geotiff` geocodes [deg]
MAX_TILT_DEG = 1.0
#: heights of a DEM outside this range [m] are voids (NaN): below the deepest trench, above the highest peak
DEM_HEIGHT_RANGE = (-11_500.0, 9_000.0)


def rasterio_module(field: str = "geotiff"):
    """rasterio, or a one-line error (naming ``field``) with the extra that installs it."""
    try:
        import rasterio
        import rasterio.warp  # noqa: F401
    except ImportError:
        raise InputDataError(field, f"reading and writing GeoTIFF needs rasterio: {GEO_EXTRA}") from None
    return rasterio


def check_geo_extra(field: str = "geotiff") -> None:
    """Raise the one-line error of :func:`rasterio_module` now when rasterio is missing (before an image is formed)."""
    rasterio_module(field)


def bilinear(values: np.ndarray, rows, cols) -> np.ndarray:
    """``values`` (H, W) at fractional (rows, cols) (integers at pixel centres) by bilinear interpolation.

    NaN where the point is outside ``[0, H-1] x [0, W-1]`` or a neighbour with a non-zero weight is NaN (nodata);
    a point on a pixel centre returns that pixel exactly."""
    v = np.asarray(values)
    r, c = np.broadcast_arrays(np.asarray(rows, dtype=np.float64), np.asarray(cols, dtype=np.float64))
    h, w = v.shape
    inside = (r >= 0) & (r <= h - 1) & (c >= 0) & (c <= w - 1)          # False for NaN coordinates too
    r0 = np.clip(np.floor(np.where(inside, r, 0.0)), 0, max(h - 2, 0)).astype(np.intp)
    c0 = np.clip(np.floor(np.where(inside, c, 0.0)), 0, max(w - 2, 0)).astype(np.intp)
    fr, fc = np.where(inside, r - r0, 0.0), np.where(inside, c - c0, 0.0)
    r1, c1 = np.minimum(r0 + 1, h - 1), np.minimum(c0 + 1, w - 1)
    out = np.zeros(r.shape, dtype=np.result_type(v.dtype, np.float64))
    for rr, cc, wt in ((r0, c0, (1 - fr) * (1 - fc)), (r0, c1, (1 - fr) * fc), (r1, c0, fr * (1 - fc)), (r1, c1, fr * fc)):
        out += np.where(wt > 0, v[rr, cc], 0.0) * wt
    return np.where(inside, out, np.nan)


def _apply(t, x, y) -> tuple[np.ndarray, np.ndarray]:
    """The affine map ``t`` (x' = a x + b y + c, y' = d x + e y + f) on arrays."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    return t.a * x + t.b * y + t.c, t.d * x + t.e * y + t.f


@dataclass(frozen=True)
class Orthoimage:
    """A georeferenced raster band: ``values`` (H, W) float64 (complex128 for a complex band) with NaN at nodata,
    ``crs`` (a ``rasterio.crs.CRS``), ``transform`` (an ``affine.Affine``: pixel (col, row) corner -> map x, y),
    ``nodata`` (the file's nodata value, or None), ``path``."""

    values: np.ndarray
    crs: object
    transform: object
    nodata: float | None
    path: str = ""

    @property
    def shape(self) -> tuple[int, int]:
        return self.values.shape

    def map_xy(self, lat, lon) -> tuple[np.ndarray, np.ndarray]:
        """Map coordinates (x, y) in :attr:`crs` of geodetic ``lat``, ``lon`` [deg] (broadcast)."""
        warp = rasterio_module().warp
        la, lo = np.broadcast_arrays(np.asarray(lat, dtype=np.float64), np.asarray(lon, dtype=np.float64))
        x, y = warp.transform("EPSG:4326", self.crs, lo.ravel(), la.ravel())
        return np.reshape(x, la.shape), np.reshape(y, la.shape)

    def pixel_of(self, lat, lon) -> tuple[np.ndarray, np.ndarray]:
        """Fractional (rows, cols) of geodetic ``lat``, ``lon`` [deg]: integers at pixel centres."""
        x, y = self.map_xy(lat, lon)
        col, row = _apply(~self.transform, x, y)
        return row - 0.5, col - 0.5

    def latlon_of(self, rows, cols) -> tuple[np.ndarray, np.ndarray]:
        """Geodetic (lat, lon) [deg] of fractional pixel (rows, cols) (integers at pixel centres)."""
        warp = rasterio_module().warp
        r, c = np.broadcast_arrays(np.asarray(rows, dtype=np.float64), np.asarray(cols, dtype=np.float64))
        x, y = _apply(self.transform, c.ravel() + 0.5, r.ravel() + 0.5)
        lon, lat = warp.transform(self.crs, "EPSG:4326", x, y)
        return np.reshape(lat, r.shape), np.reshape(lon, r.shape)

    def sample(self, lat, lon) -> np.ndarray:
        """The values at geodetic ``lat``, ``lon`` [deg] by bilinear interpolation (:func:`bilinear`: NaN outside the
        pixel centres' hull or next to nodata)."""
        return bilinear(self.values, *self.pixel_of(lat, lon))


@dataclass(frozen=True)
class Dem(Orthoimage):
    """A digital elevation model: ``values`` are heights [m] as stored in the file (height above the WGS-84
    ellipsoid for an ellipsoidal DEM; above the geoid for EGM96/EGM2008 DEMs such as SRTM or Copernicus GLO-30, whose
    geoid undulation the caller adds for SICD projection); voids and nodata are NaN."""

    def height(self, lat, lon) -> np.ndarray:
        """Heights [m] at geodetic ``lat``, ``lon`` [deg] by bilinear interpolation; NaN outside the DEM or next to
        a void."""
        return self.sample(lat, lon)


def _fail(path, field: str, message: str):
    raise InputDataError(f"geotiff{'.' + field if field else ''}", f"{message} ({str(path)!r})")


def _first_line(err: Exception) -> str:
    text = str(err).strip().splitlines()
    return (text[0] if text else type(err).__name__)[:200]


def _check_header(src, path, band: int):
    if not isinstance(band, (int, np.integer)) or isinstance(band, bool) or not 1 <= band <= src.count:
        _fail(path, "band", f"must be an integer in [1, {src.count}], got {band!r}")
    h, w = src.height, src.width
    if h < 2 or w < 2 or h * w > MAX_PIXELS:
        _fail(path, "size", f"must be at least 2 x 2 and at most {MAX_PIXELS:.3g} pixels, got {h} x {w}")
    if src.crs is None:
        _fail(path, "crs", "CRS missing: the file has no coordinate reference system (GeoKeys or WKT)")
    t = src.transform
    coef = np.array([t.a, t.b, t.c, t.d, t.e, t.f], dtype=np.float64)
    if t.is_identity:
        _fail(path, "transform", "geotransform missing: the file maps pixels to no map coordinates")
    det = t.a * t.e - t.b * t.d
    if not np.all(np.isfinite(coef)) or not (math.isfinite(det) and abs(det) > 0):
        _fail(path, "transform", f"must be finite and invertible, got {tuple(coef)}")
    if src.dtypes[band - 1] not in _DTYPES:
        _fail(path, "dtype", f"must be one of {sorted(_DTYPES)}, got {src.dtypes[band - 1]!r}")


_DTYPES = {"uint8", "int8", "uint16", "int16", "uint32", "int32", "uint64", "int64", "float16", "float32",
           "float64", "complex64", "complex128", "complex_int16"}


def read_orthoimage(path, band: int = 1) -> Orthoimage:
    """Read band ``band`` of the GeoTIFF ``path`` (module doc). Errors name ``geotiff.crs``, ``geotiff.transform``,
    ``geotiff.size``, ``geotiff.band``, ``geotiff.dtype`` or ``geotiff`` (not a readable GeoTIFF)."""
    return _read(path, band, Orthoimage)


@contextlib.contextmanager
def _quiet_gdal():
    """GDAL's messages about a damaged file go to rasterio's error handler, which raises on bytes that are not UTF-8
    inside a callback: Python prints that (``sys.excepthook`` and ``sys.unraisablehook``: "Exception ignored in ...",
    a traceback). Such UnicodeDecodeErrors are dropped while a file is read (the one-line error says what is wrong);
    anything else is passed on."""
    previous, previous_except = sys.unraisablehook, sys.excepthook

    def hook(unraisable):
        if not isinstance(unraisable.exc_value, UnicodeDecodeError):
            previous(unraisable)

    def excepthook(kind, value, tb):
        if not isinstance(value, UnicodeDecodeError):
            previous_except(kind, value, tb)

    log = logging.getLogger("rasterio")              # GDAL's warnings about the damage, logged by rasterio
    level = log.level
    sys.unraisablehook, sys.excepthook = hook, excepthook
    log.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        sys.unraisablehook, sys.excepthook = previous, previous_except
        log.setLevel(level)


def _read(path, band: int, cls):
    rasterio = rasterio_module()
    path = Path(path)
    if not path.is_file():
        _fail(path, "", "not a readable file")
    try:
        with _quiet_gdal(), warnings.catch_warnings(action="ignore"), np.errstate(all="ignore"), \
                rasterio.Env(GDAL_DISABLE_READDIR_ON_OPEN="EMPTY_DIR"), \
                rasterio.open(path, driver="GTiff") as src:   # NotGeoreferencedWarning & co.: the checks say it
            _check_header(src, path, band)
            data = src.read(band, masked=True)
            crs, transform, nodata = src.crs, src.transform, src.nodata
            kind = np.complex128 if np.iscomplexobj(data) else np.float64
            values = np.ma.filled(data.astype(kind), np.nan)
            values[~np.isfinite(values)] = np.nan
    except InputDataError:
        raise
    except Exception as err:   # GDAL reports a damaged file through several exception types
        _fail(path, "", f"not a readable GeoTIFF: {_first_line(err)}")
    return cls(values, crs, transform, None if nodata is None else float(nodata), str(path))


def read_dem(path, band: int = 1) -> Dem:
    """Read a DEM GeoTIFF (a real band of heights [m]): nodata and heights outside :data:`DEM_HEIGHT_RANGE` are NaN."""
    dem = _read(path, band, Dem)
    if np.iscomplexobj(dem.values):
        _fail(path, "dtype", "a DEM holds real heights, got a complex band")
    lo, hi = DEM_HEIGHT_RANGE
    with np.errstate(invalid="ignore"):
        dem.values[(dem.values < lo) | (dem.values > hi)] = np.nan
    return dem


def _as_affine(transform):
    from rasterio.transform import Affine

    if isinstance(transform, Affine):
        coef = tuple(transform)[:6]
    else:
        coef = tuple(np.asarray(transform, dtype=np.float64).ravel())
        if len(coef) != 6:
            raise InputDataError("transform", f"must be an affine.Affine or its 6 coefficients (a, b, c, d, e, f), "
                                 f"got {len(coef)} numbers")
    det = coef[0] * coef[4] - coef[1] * coef[3]
    if not (np.all(np.isfinite(coef)) and math.isfinite(det) and det != 0):
        raise InputDataError("transform", f"must be finite and invertible, got {coef}")
    return Affine(*coef)


def write_geotiff(path, values, crs, transform, nodata=None, *, tags: dict | None = None) -> Path:
    """Write ``values`` ((H, W) or (bands, H, W), real or complex) as a GeoTIFF with ``crs`` (EPSG code, ``"EPSG:n"``,
    WKT or a rasterio CRS), ``transform`` (``affine.Affine`` or its 6 coefficients: pixel (col, row) corner -> map
    x, y) and ``nodata`` (None or a number; NaN allowed for float data). Deflate-compressed, tiled when large."""
    rasterio = rasterio_module()
    arr = np.asarray(values)
    arr3 = arr[None] if arr.ndim == 2 else arr
    if arr3.ndim != 3 or min(arr3.shape[1:]) < 1 or arr3.shape[1] * arr3.shape[2] > MAX_PIXELS:
        raise InputDataError("values", f"must be (H, W) or (bands, H, W) with at most {MAX_PIXELS:.3g} pixels, "
                             f"got shape {arr.shape}")
    if arr3.dtype.kind not in "uifc":
        raise InputDataError("values", f"must be numeric, got {arr3.dtype}")
    if arr3.dtype == np.float16 or arr3.dtype.kind == "b":
        arr3 = arr3.astype(np.float32)
    try:
        crs_obj = rasterio.crs.CRS.from_user_input(crs)
    except Exception as err:
        raise InputDataError("crs", f"not a coordinate reference system: {_first_line(err)}") from None
    if nodata is not None and not (isinstance(nodata, (int, float, np.number)) and not isinstance(nodata, bool)):
        raise InputDataError("nodata", f"must be None or a number, got {nodata!r}")
    profile = {"driver": "GTiff", "height": arr3.shape[1], "width": arr3.shape[2], "count": arr3.shape[0],
               "dtype": arr3.dtype.name, "crs": crs_obj, "transform": _as_affine(transform), "nodata": nodata,
               "compress": "deflate"}
    if min(arr3.shape[1:]) >= 512:
        profile |= {"tiled": True, "blockxsize": 256, "blockysize": 256}
    path = Path(path)
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(arr3)
        if tags:
            dst.update_tags(**{str(k): str(v) for k, v in tags.items()})
    return path


def utm_crs(lat: float, lon: float) -> str:
    """The WGS-84 UTM zone's CRS (``"EPSG:326zz"`` north, ``"EPSG:327zz"`` south) of a point (standard 6° zones)."""
    zone = int(math.floor((((lon + 180.0) % 360.0)) / 6.0)) + 1
    return f"EPSG:{(32600 if lat >= 0 else 32700) + min(zone, 60)}"


def write_plane_geotiff(path, data, grid, *, spacing: float | None = None, crs=None) -> Path:
    """Geocode an image formed on a plane and write it as GeoTIFF (``sarnav image --geotiff``).

    data : (Ny, Nx) image (complex or real) on ``grid``, an ``imaging.grid.PlaneGrid`` in ECEF.
    spacing : map pixel size [m] (default: the finer of the grid's two spacings).
    crs : the map's CRS (default: the UTM zone of the image centre, :func:`utm_crs`).

    Each map pixel centre (x, y) -> geodetic (lat, lon) -> the point of the image plane on that point's ellipsoid
    normal (the line through the WGS-84 point at the plane's height along its local up, intersected with the plane)
    -> its fractional pixel on the grid -> |data| there by bilinear interpolation. Written as float32 amplitude,
    north up, nodata NaN outside the image; the plane's height above the ellipsoid at its centre is the tag
    ``SARNAV_PLANE_HAE_M``."""
    from scipy.ndimage import map_coordinates
    import sarkit.wgs84 as wgs84

    warp = rasterio_module().warp
    amp = np.abs(np.asarray(data)).astype(np.float64)
    rows, cols = np.asarray(grid.rows), np.asarray(grid.cols)
    if amp.shape != (rows.size, cols.size):
        raise InputDataError("data", f"shape {amp.shape} differs from the grid's {(rows.size, cols.size)}")
    dr, dc = float(rows[1] - rows[0]), float(cols[1] - cols[0])
    ps = min(dr, dc) if spacing is None else float(spacing)
    if not (math.isfinite(ps) and ps > 0):
        raise InputDataError("spacing", f"must be finite and > 0 m, got {spacing!r}")
    pts = grid.points()
    centre = wgs84.cartesian_to_geodetic(pts[rows.size // 2, cols.size // 2])
    normal = np.cross(grid.row_direction, grid.col_direction)
    tilt = math.degrees(math.acos(min(1.0, abs(float(normal @ wgs84.up(centre))))))
    if tilt > MAX_TILT_DEG:
        raise InputDataError("grid", f"a GeoTIFF is written of an image on a ground plane: this one is tilted "
                             f"{tilt:.3g} deg from the horizontal at its centre (at most {MAX_TILT_DEG:g} deg)")
    crs = crs or utm_crs(centre[0], centre[1])
    corners = wgs84.cartesian_to_geodetic(pts[[0, 0, -1, -1], [0, -1, 0, -1]])
    cx, cy = warp.transform("EPSG:4326", crs, corners[:, 1], corners[:, 0])
    x0, y1 = math.floor(min(cx) / ps) * ps, math.ceil(max(cy) / ps) * ps
    w, h = int(math.ceil(max(cx) / ps - x0 / ps)) + 1, int(math.ceil(y1 / ps - min(cy) / ps)) + 1
    if w * h > MAX_PIXELS:
        raise InputDataError("spacing", f"a {w} x {h} map ({ps:g} m pixels) exceeds {MAX_PIXELS:.3g} pixels")
    xs, ys = np.meshgrid(x0 + (np.arange(w) + 0.5) * ps, y1 - (np.arange(h) + 0.5) * ps)
    lon, lat = warp.transform(crs, "EPSG:4326", xs.ravel(), ys.ravel())
    llh = np.column_stack([lat, lon, np.full(len(lat), centre[2])])
    p0, up = wgs84.geodetic_to_cartesian(llh), wgs84.up(llh)
    t = ((grid.origin - p0) @ normal) / (up @ normal)
    on_plane = p0 + t[:, None] * up - grid.origin
    fr = (on_plane @ grid.row_direction - rows[0]) / dr
    fc = (on_plane @ grid.col_direction - cols[0]) / dc
    out = map_coordinates(amp, [fr, fc], order=1, mode="constant", cval=np.nan, prefilter=False)
    out = np.where((fr >= 0) & (fr <= rows.size - 1) & (fc >= 0) & (fc <= cols.size - 1), out, np.nan)
    from rasterio.transform import Affine

    return write_geotiff(path, out.reshape(h, w).astype(np.float32), crs, Affine(ps, 0.0, x0, 0.0, -ps, y1),
                         nodata=float("nan"), tags={"SARNAV_PLANE_HAE_M": f"{centre[2]:.3f}",
                                                    "SARNAV_VALUES": "amplitude |image| on the image plane"})
