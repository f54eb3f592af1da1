"""Synthetic terrain for the simulated spacecraft closed loop (issue 11; Pogorelsky et al. 2022 §IV needs a DEM and
a geocoded reference of real terrain, which a simulation replaces): a map grid regular in geodetic latitude and
longitude, a DEM on it (sum of Gaussian hills: tens to hundreds of metres of relief), and a scene of point
scatterers on the DEM: distributed clutter (a jittered grid, complex Gaussian amplitudes whose power follows the
local incidence angle) plus a few bright stable scatterers.

Backscatter model (a choice, not from the source): clutter power sigma0 = max(cos theta_loc, 0.05) with theta_loc the
angle between the local terrain normal and the direction to the radar (slopes facing the radar are brighter, which
gives the amplitude image texture tied to the DEM). A later pass of the same terrain (the reference) keeps the bright
scatterers and redraws the clutter with coherence ``coherence``: z_ref = gamma z + sqrt(1 - gamma^2) z'.

SI units, angles in rad, heights above the WGS-84 ellipsoid; geodesy through ``frames.earth`` (pymap3d).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from sarnav.errors import ConfigError, InputDataError
from sarnav.frames.wgs84 import geodetic_to_ecef
from sarnav.frames.wgs84 import ned_to_ecef_dcm, radii_of_curvature

__all__ = ["MapGrid", "Terrain", "map_grid_around", "synthetic_terrain", "TerrainScene", "terrain_scene"]


@dataclass(frozen=True)
class MapGrid:
    """A geocoded raster: row i, column j at latitude lat0 + i dlat, longitude lon0 + j dlon [rad] (rows northward,
    columns eastward); ``shape`` (rows, cols); ``spacing`` the nominal cell size [m]."""

    lat0: float
    lon0: float
    dlat: float
    dlon: float
    shape: tuple
    spacing: float

    def latlon(self, rows, cols):
        """(lat, lon) [rad] of fractional (row, col) indices."""
        return self.lat0 + np.asarray(rows, float) * self.dlat, self.lon0 + np.asarray(cols, float) * self.dlon

    def index(self, lat, lon):
        """Fractional (row, col) of (lat, lon) [rad]."""
        return (np.asarray(lat, float) - self.lat0) / self.dlat, (np.asarray(lon, float) - self.lon0) / self.dlon

    def cell_latlon(self):
        """(lat, lon) (rows, cols) of every cell."""
        i, j = np.meshgrid(np.arange(self.shape[0]), np.arange(self.shape[1]), indexing="ij")
        return self.latlon(i, j)


def map_grid_around(lat, lon, half_north: float, half_east: float, spacing: float) -> MapGrid:
    """A grid of ``spacing`` [m] cells covering +-half_north, +-half_east [m] around (lat, lon) [rad]."""
    if not (spacing > 0 and half_north > spacing and half_east > spacing):
        raise ConfigError("terrain.map_spacing", f"must be > 0 m and smaller than the map, got {spacing!r}")
    rn, re = radii_of_curvature(lat)
    dlat, dlon = spacing / rn, spacing / (re * math.cos(lat))
    n_i, n_j = int(round(2 * half_north / spacing)) + 1, int(round(2 * half_east / spacing)) + 1
    return MapGrid(float(lat - (n_i - 1) / 2 * dlat), float(lon - (n_j - 1) / 2 * dlon), float(dlat), float(dlon),
                   (n_i, n_j), float(spacing))


@dataclass(frozen=True)
class Terrain:
    """A DEM: heights (rows, cols) [m above WGS-84] on ``grid``; :meth:`height` interpolates it."""

    grid: MapGrid
    heights: np.ndarray

    def height(self, lat, lon, order: int = 1):
        """DEM height [m] at (lat, lon) [rad]: bilinear (order 1) or nearest cell (order 0), edges continued."""
        i, j = self.grid.index(lat, lon)
        shape = np.shape(i)
        coords = np.vstack([np.ravel(i), np.ravel(j)])
        if order == 0:
            coords = np.rint(coords)
        return ndimage.map_coordinates(self.heights, coords, order=1, mode="nearest").reshape(shape)

    def ecef(self, lat, lon):
        """ECEF (..., 3) [m] of the terrain surface at (lat, lon) [rad]."""
        return geodetic_to_ecef(lat, lon, self.height(lat, lon))


def synthetic_terrain(grid: MapGrid, rng: np.random.Generator, relief: float, n_hills: int = 12,
                      scale=(600.0, 2500.0), base_height: float = 100.0) -> Terrain:
    """Sum of ``n_hills`` Gaussian hills and hollows (centres uniform over the grid, widths uniform in ``scale`` [m],
    heights N(0, relief^2)) on ``base_height`` [m]; ``relief`` [m] (tens to hundreds)."""
    if not (math.isfinite(relief) and 0 <= relief <= 2000):
        raise ConfigError("terrain.relief", f"must be in [0, 2000] m, got {relief!r}")
    n_i, n_j = grid.shape
    y = (np.arange(n_i) - (n_i - 1) / 2)[:, None] * grid.spacing
    x = (np.arange(n_j) - (n_j - 1) / 2)[None, :] * grid.spacing
    h = np.full(grid.shape, float(base_height))
    for _ in range(n_hills):
        cy, cx = rng.uniform(y.min(), y.max()), rng.uniform(x.min(), x.max())
        w = rng.uniform(*scale)
        h += rng.normal(0.0, relief) * np.exp(-((y - cy) ** 2 + (x - cx) ** 2) / (2 * w * w))
    return Terrain(grid, h)


@dataclass(frozen=True)
class TerrainScene:
    """Scatterers on a terrain: ECEF positions (K, 3) [m]; ``amplitude`` (K,) complex of this pass, ``reference``
    (K,) complex of the earlier pass; ``bright`` (K,) bool."""

    positions: np.ndarray
    amplitude: np.ndarray
    reference: np.ndarray
    bright: np.ndarray

    def local(self, origin_ecef, lat, lon):
        """Positions in the NED frame at (lat, lon) with origin ``origin_ecef`` (for the echo simulator)."""
        C = ned_to_ecef_dcm(lat, lon)
        return (self.positions - np.asarray(origin_ecef)) @ C


def terrain_scene(terrain: Terrain, rng: np.random.Generator, radar_ecef, spacing: float, extent, n_bright: int,
                  bright_amplitude: float, coherence: float, reference_ecef=None) -> TerrainScene:
    """Clutter on a jittered grid of ``spacing`` [m] inside ``extent`` = (row0, row1, col0, col1) of the terrain grid,
    plus ``n_bright`` bright scatterers of amplitude ``bright_amplitude`` (x the clutter's unit rms), as seen from
    ``radar_ecef`` (3,) (module docstring: backscatter and the reference pass); the reference pass's clutter power
    from ``reference_ecef`` (3,) where it looks from elsewhere (default: the same place; the same random draws)."""
    if not 0.0 <= coherence <= 1.0:
        raise ConfigError("terrain.coherence", f"must be in [0, 1], got {coherence!r}")
    g = terrain.grid
    r0, r1, c0, c1 = extent
    step = spacing / g.spacing
    ii, jj = np.meshgrid(np.arange(r0, r1, step), np.arange(c0, c1, step), indexing="ij")
    ii = ii.ravel() + rng.uniform(-0.5, 0.5, ii.size) * step
    jj = jj.ravel() + rng.uniform(-0.5, 0.5, jj.size) * step
    bi, bj = rng.uniform(r0, r1, n_bright), rng.uniform(c0, c1, n_bright)
    lat, lon = g.latlon(np.r_[ii, bi], np.r_[jj, bj])
    pos = terrain.ecef(lat, lon)
    if not np.all(np.isfinite(pos)):
        raise InputDataError("terrain", "scatterer positions are not finite")
    power = _backscatter(terrain, lat, lon, pos, np.asarray(radar_ecef, float))
    z = (rng.standard_normal(pos.shape[0]) + 1j * rng.standard_normal(pos.shape[0])) / math.sqrt(2)
    z2 = (rng.standard_normal(pos.shape[0]) + 1j * rng.standard_normal(pos.shape[0])) / math.sqrt(2)
    amp = np.sqrt(power) * z
    ref_power = power if reference_ecef is None else _backscatter(terrain, lat, lon, pos,
                                                                   np.asarray(reference_ecef, float))
    ref = np.sqrt(ref_power) * (coherence * z + math.sqrt(1.0 - coherence**2) * z2)
    bright = np.zeros(pos.shape[0], bool)
    bright[ii.size:] = True
    phase = np.exp(2j * np.pi * rng.uniform(size=n_bright))
    amp[bright] = ref[bright] = bright_amplitude * phase
    return TerrainScene(pos, amp, ref, bright)


def _backscatter(terrain: Terrain, lat, lon, pos, radar):
    """Clutter power max(cos theta_loc, 0.05): theta_loc between the DEM normal and the line of sight to the radar."""
    g = terrain.grid
    dh_di, dh_dj = np.gradient(terrain.heights, g.spacing)  # per metre north, east
    i, j = g.index(lat, lon)
    coords = np.vstack([i, j])
    sn = ndimage.map_coordinates(dh_di, coords, order=1, mode="nearest")
    se = ndimage.map_coordinates(dh_dj, coords, order=1, mode="nearest")
    n_ned = np.stack([-sn, -se, -np.ones_like(sn)], axis=1)  # up-pointing normal in NED: (-dh/dN, -dh/dE, -1)
    n_ned /= np.linalg.norm(n_ned, axis=1, keepdims=True)
    C = ned_to_ecef_dcm(lat, lon)  # (K, 3, 3)
    n_ecef = np.einsum("kij,kj->ki", C, n_ned)
    los = radar - pos
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    return np.maximum(np.einsum("ki,ki->k", n_ecef, los), 0.05)


