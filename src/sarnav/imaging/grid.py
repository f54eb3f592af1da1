"""Image grids for back-projection: where each pixel is in 3-D (NED, metres, float64).

A grid is any object with

* ``points() -> (Ny, Nx, 3) float64`` pixel positions in the navigation frame (NED, m);
* ``axes() -> (y, x, y_name, x_name)`` the coordinates of rows and columns for the ``SarImage``;
* ``metadata() -> dict`` JSON-serialisable description stored in ``SarImage.metadata``.

The thesis leaves the BPA grid open ("a grid of pixels in a chosen geographic region", Lindstrom
2020 L909; notes/seed-000 §8 gap): :class:`GroundGrid` is the usual choice (a horizontal plane at a
given down coordinate, rows along north, columns along east), :class:`SlantGrid` is the plane that
contains a straight track and a look point (rows = along-track distance, columns = distance from the
track, i.e. range of closest approach — the axes an RDA image has), and :class:`PointGrid` wraps any
``(Ny, Nx, 3)`` array (e.g. points on a DEM).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError

__all__ = ["GroundGrid", "SlantGrid", "PlaneGrid", "PointGrid", "as_grid", "regular_axis", "check_resampled"]


def regular_axis(center: float, spacing: float, n: int, name: str = "axis") -> np.ndarray:
    """``n`` float64 samples ``center + (i - (n-1)/2) * spacing``, i = 0..n-1 (centred, symmetric).

    Raises
    ------
    ConfigError
        when ``spacing`` is not finite and > 0 or ``n`` is not an integer >= 2.
    """
    spacing = float(spacing)
    if not np.isfinite(spacing) or spacing <= 0:
        raise ConfigError(f"{name}.spacing", f"must be finite and > 0 m, got {spacing!r}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ConfigError(f"{name}.n", f"must be an integer >= 2, got {n!r}")
    if not np.isfinite(center):
        raise ConfigError(f"{name}.center", f"must be finite, got {center!r}")
    return float(center) + (np.arange(n, dtype=np.float64) - 0.5 * (n - 1)) * spacing


def _positive_length(name: str, v) -> float:
    v = float(v) if isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool) else math.nan
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(name, f"must be finite and > 0 m, got {v!r}")
    return v


def _check_axis(name: str, values) -> np.ndarray:
    a = np.asarray(values, dtype=np.float64)
    if a.ndim != 1 or a.size < 2:
        raise InputDataError(name, f"must be a 1-D axis with >= 2 samples, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputDataError(name, "must be finite (found NaN/inf)")
    d = np.diff(a)
    if not (np.all(d > 0) and np.allclose(d, d[0], rtol=1e-9, atol=0.0)):
        raise InputDataError(name, "must be strictly increasing and uniformly spaced")
    return a


def _check_vector(name: str, v) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputDataError(name, f"must be a finite 3-vector (NED, m), got {np.asarray(v)!r}")
    return a


@dataclass(frozen=True)
class GroundGrid:
    """Horizontal plane ``down = const`` sampled on a north × east lattice.

    Parameters
    ----------
    north : (Ny,) uniformly increasing north coordinates of the rows [m].
    east : (Nx,) uniformly increasing east coordinates of the columns [m].
    down : down coordinate of the plane [m] (0 = the flat ground of the scenarios).
    """

    north: np.ndarray
    east: np.ndarray
    down: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "north", _check_axis("grid.north", self.north))
        object.__setattr__(self, "east", _check_axis("grid.east", self.east))
        d = float(self.down)
        if not np.isfinite(d):
            raise ConfigError("grid.down", f"must be finite [m], got {self.down!r}")
        object.__setattr__(self, "down", d)

    @classmethod
    def centered(cls, center_north: float, center_east: float, spacing: float, shape: tuple[int, int],
                 down: float = 0.0, spacing_east: float | None = None) -> "GroundGrid":
        """Grid of ``shape = (Ny, Nx)`` pixels centred on (north, east) with the given spacing [m]."""
        ny, nx = shape
        return cls(regular_axis(center_north, spacing, ny, "grid.north"),
                   regular_axis(center_east, spacing if spacing_east is None else spacing_east, nx, "grid.east"),
                   down)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.north.size, self.east.size)

    def points(self) -> np.ndarray:
        """(Ny, Nx, 3) float64 NED pixel positions."""
        p = np.empty(self.shape + (3,), dtype=np.float64)
        p[..., 0] = self.north[:, None]
        p[..., 1] = self.east[None, :]
        p[..., 2] = self.down
        return p

    def axes(self):
        return self.north, self.east, "north", "east"

    def metadata(self) -> dict:
        return {"grid": "ground", "grid_down": self.down}


@dataclass(frozen=True)
class SlantGrid:
    """The plane through a straight track and a look point, sampled along-track × distance from track.

    Pixel (i, j) is at ``origin + along_track[i] * u + slant_range[j] * n`` with ``u`` the unit
    track direction and ``n`` the unit vector perpendicular to ``u`` in the plane, pointing at
    ``look_point``. For a straight track through ``origin`` along ``u``, ``slant_range[j]`` is the
    range of closest approach of the pixel and ``along_track[i]`` its along-track position at
    closest approach (zero-Doppler coordinates, the axes of an RDA image).

    Parameters
    ----------
    origin : (3,) a point on the track (NED, m).
    direction : (3,) track direction (any length > 0).
    look_point : (3,) a point off the track on the imaged side (e.g. the scene centre).
    along_track : (Ny,) uniformly increasing along-track coordinates [m].
    slant_range : (Nx,) uniformly increasing ranges of closest approach [m], > 0.
    """

    origin: np.ndarray
    direction: np.ndarray
    look_point: np.ndarray
    along_track: np.ndarray
    slant_range: np.ndarray

    def __post_init__(self):
        o = _check_vector("grid.origin", self.origin)
        d = _check_vector("grid.direction", self.direction)
        lp = _check_vector("grid.look_point", self.look_point)
        if np.linalg.norm(d) == 0:
            raise InputDataError("grid.direction", "must be non-zero")
        u = d / np.linalg.norm(d)
        off = (lp - o) - np.dot(lp - o, u) * u
        if np.linalg.norm(off) <= 1e-9 * max(1.0, np.linalg.norm(lp - o)):
            raise InputDataError("grid.look_point", "must lie off the track line")
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "direction", u)
        object.__setattr__(self, "look_point", lp)
        object.__setattr__(self, "along_track", _check_axis("grid.along_track", self.along_track))
        r = _check_axis("grid.slant_range", self.slant_range)
        if r[0] <= 0:
            raise InputDataError("grid.slant_range", f"must be > 0 m, got first value {r[0]!r}")
        object.__setattr__(self, "slant_range", r)

    @property
    def normal_in_plane(self) -> np.ndarray:
        """Unit vector perpendicular to the track, in the slant plane, towards ``look_point``."""
        off = (self.look_point - self.origin)
        off = off - np.dot(off, self.direction) * self.direction
        return off / np.linalg.norm(off)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.along_track.size, self.slant_range.size)

    def points(self) -> np.ndarray:
        """(Ny, Nx, 3) float64 NED pixel positions."""
        n = self.normal_in_plane
        return (self.origin[None, None, :]
                + self.along_track[:, None, None] * self.direction[None, None, :]
                + self.slant_range[None, :, None] * n[None, None, :])

    def axes(self):
        return self.along_track, self.slant_range, "along_track", "slant_range"

    def metadata(self) -> dict:
        return {"grid": "slant", "grid_origin": self.origin.tolist(), "grid_direction": self.direction.tolist(),
                "grid_normal": self.normal_in_plane.tolist()}


@dataclass(frozen=True)
class PlaneGrid:
    """A plane through ``origin`` spanned by two orthogonal unit vectors, in any Cartesian frame.

    Pixel (i, j) is at ``origin + rows[i] * row_direction + cols[j] * col_direction`` (float64). The
    frame is the one of the pulses' antenna positions: ECEF for CPHD data (the CPHD image area plane,
    IARP + x uIAX + y uIAY; the SICD image plane, SCP + xrow uRow + ycol uCol).

    Parameters
    ----------
    origin : (3,) the point at row = col = 0 [m].
    row_direction, col_direction : (3,) directions of increasing row / column coordinate (normalised;
        must be orthogonal to 1e-9).
    rows, cols : uniformly increasing coordinates [m] along them.
    row_name, col_name : names for the ``SarImage`` axes.
    """

    origin: np.ndarray
    row_direction: np.ndarray
    col_direction: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    row_name: str = "row"
    col_name: str = "col"

    def __post_init__(self):
        o = _check_vector("grid.origin", self.origin)
        a = _check_vector("grid.row_direction", self.row_direction)
        b = _check_vector("grid.col_direction", self.col_direction)
        if np.linalg.norm(a) == 0 or np.linalg.norm(b) == 0:
            raise InputDataError("grid.row_direction", "row and column directions must be non-zero")
        a = a / np.linalg.norm(a)
        b = b / np.linalg.norm(b)
        if abs(float(np.dot(a, b))) > 1e-9:
            raise InputDataError("grid.col_direction", f"must be orthogonal to row_direction (cosine {np.dot(a, b):.3g})")
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "row_direction", a)
        object.__setattr__(self, "col_direction", b)
        object.__setattr__(self, "rows", _check_axis("grid.rows", self.rows))
        object.__setattr__(self, "cols", _check_axis("grid.cols", self.cols))

    @property
    def shape(self) -> tuple[int, int]:
        return (self.rows.size, self.cols.size)

    def points(self) -> np.ndarray:
        """(Ny, Nx, 3) float64 pixel positions."""
        return (self.origin[None, None, :] + self.rows[:, None, None] * self.row_direction[None, None, :]
                + self.cols[None, :, None] * self.col_direction[None, None, :])

    def axes(self):
        return self.rows, self.cols, self.row_name, self.col_name

    def metadata(self) -> dict:
        return {"grid": "plane", "grid_origin": self.origin.tolist(), "grid_row_direction": self.row_direction.tolist(),
                "grid_col_direction": self.col_direction.tolist()}

    def resampled(self, spacing=None, extent=None) -> "PlaneGrid":
        """This grid (a CPHD's image grid, ``io.cphd.read_collect``) resampled on the same plane about the same
        centre.

        spacing : pixel spacing [m] along both axes (default: the grid's own row and column spacings).
        extent : (x, y) full size [m] along the row and column axes (uIAX, uIAY), or one number for both
            (default: the grid's own extent). The pixels are ``centre + (i - (n-1)/2) spacing`` with
            ``n = floor(extent / spacing) + 1``.
        """
        rows, cols = np.asarray(self.rows), np.asarray(self.cols)
        if spacing is None:
            sp = (float(rows[1] - rows[0]), float(cols[1] - cols[0]))
        else:
            sp = (_positive_length("spacing", spacing),) * 2
        if extent is None:
            ext = (float(rows[-1] - rows[0]), float(cols[-1] - cols[0]))
        else:
            ext = tuple(extent) if np.ndim(extent) == 1 else (extent, extent)
            if len(ext) != 2:
                raise ConfigError("extent", f"must be one or two sizes [m], got {extent!r}")
            ext = tuple(_positive_length("extent", e) for e in ext)
        n = [int(math.floor(e / s + 1e-9)) + 1 for e, s in zip(ext, sp)]
        if min(n) < 2:
            raise ConfigError("extent", f"must span at least two pixels of {sp[0]:g} m, got {ext[0]:g} x {ext[1]:g} m")
        new_rows = regular_axis(0.5 * float(rows[0] + rows[-1]), sp[0], n[0], "grid.rows")
        new_cols = regular_axis(0.5 * float(cols[0] + cols[-1]), sp[1], n[1], "grid.cols")
        return PlaneGrid(self.origin, self.row_direction, self.col_direction, new_rows, new_cols, self.row_name,
                         self.col_name)


@dataclass(frozen=True)
class PointGrid:
    """Arbitrary pixel positions, ``(Ny, Nx, 3)`` NED [m]; image axes are the pixel indices."""

    positions: np.ndarray

    def __post_init__(self):
        p = np.asarray(self.positions, dtype=np.float64)
        if p.ndim != 3 or p.shape[-1] != 3 or p.shape[0] < 1 or p.shape[1] < 1:
            raise InputDataError("grid", f"points must have shape (Ny, Nx, 3), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise InputDataError("grid", "points must be finite (found NaN/inf)")
        object.__setattr__(self, "positions", p)

    @property
    def shape(self) -> tuple[int, int]:
        return self.positions.shape[:2]

    def points(self) -> np.ndarray:
        return self.positions

    def axes(self):
        ny, nx = self.shape
        return np.arange(ny, dtype=np.float64), np.arange(nx, dtype=np.float64), "row_index", "column_index"

    def metadata(self) -> dict:
        return {"grid": "points"}


def as_grid(grid) -> GroundGrid | SlantGrid | PointGrid:
    """A grid object unchanged, or an ``(Ny, Nx, 3)`` / ``(M, 3)`` array wrapped in a :class:`PointGrid`
    (an ``(M, 3)`` array becomes one row of M pixels)."""
    if hasattr(grid, "points") and hasattr(grid, "axes"):
        return grid
    a = np.asarray(grid, dtype=np.float64)
    if a.ndim == 2 and a.shape[-1] == 3:
        a = a[None, :, :]
    return PointGrid(a)


def _flag_number(name: str, value) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(name, f"must be a number [m], got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(name, f"must be finite and > 0 m, got {value!r}")
    return v


def _extent(value, field: str):
    if value is None:
        return None
    parts = [p for p in str(value).replace("x", ",").split(",") if p.strip()]
    if len(parts) not in (1, 2):
        raise ConfigError(field, f"must be X or X,Y [m], got {value!r}")
    return tuple(_flag_number(field, p) for p in parts) if len(parts) == 2 else _flag_number(field, parts[0])


def check_resampled(default, spacing, extent, max_pixels: int, fields=("spacing", "extent")):
    """``default`` (a :class:`PlaneGrid`) resampled at ``spacing`` [m] over ``extent`` (X or (Y, X) [m], or text 'X'
    / 'Y,X'; None: the grid's own), at most ``max_pixels``; ConfigError naming ``fields`` (spacing, extent)."""
    sp, ext = _flag_number(fields[0], spacing), _extent(extent, fields[1])
    rows, cols = default.rows, default.cols
    dy, dx = (sp, sp) if sp is not None else (rows[1] - rows[0], cols[1] - cols[0])
    ey, ex = (ext if isinstance(ext, tuple) else (ext, ext)) if ext is not None else (np.ptp(rows), np.ptp(cols))
    n = (math.floor(ey / dy + 1e-9) + 1) * (math.floor(ex / dx + 1e-9) + 1)
    if n > max_pixels:
        raise ConfigError(fields[1] if ext is not None else fields[0],
                          f"{ey:g} x {ex:g} m at {dy:g} x {dx:g} m spacing is {n:.3g} pixels (at most {max_pixels:.3g}): "
                          f"raise {fields[0]} or lower {fields[1]}")
    if min(math.floor(ey / dy + 1e-9), math.floor(ex / dx + 1e-9)) < 1:
        raise ConfigError(fields[1], f"must span at least two pixels of the spacing, got {ey:g} x {ex:g} m")
    return default.resampled(sp, ext)
