"""Reference (b) of an exported recording (docs/recording.md §6b, §9): the reference pass imaged by sarnav on the
ground, written as a GeoTIFF orthoimage per aperture (``reference/NNNN.tif``), and the terrain as a DEM
(``reference/dem.tif``, terrain scenes only).

Each aperture's tile is a north-up WGS-84 (EPSG:4326) grid of ``ORTHO_SPACING_M`` around its reference targets
(``ORTHO_MARGIN_M`` beyond them); each pixel is the amplitude of the back-projection (``imaging.backprojection``)
of the reference pass's pulses along its trusted track onto the ground point at the pixel's latitude and longitude,
on the terrain (the world's ``HillTerrain``, down = -height) or on the origin's tangent plane (down = 0). The
product's geolocation error is drawn per tile, N(0, diag(sigma^2)) with sigma the horizontal part of
``scene.geolocation_sigma_m`` (``horizontal``; the product's heights are exact), from the run's seed: the
tile shows the ground point (n - dn, e - de) at the pixel of (n, e), and the reference points' file puts each point
where the product does (anchor = map = target + (dn, de, 0)); the manifest states the sigma, which enters R. The
DEM holds the terrain's heights above the WGS-84 ellipsoid on ``DEM_SPACING_M`` over the swath.
"""

from __future__ import annotations

import numpy as np
import pymap3d

from sarnav.imaging.backprojection import backproject_points
from sarnav.recording.ortho import write_geotiff

__all__ = ["write_ortho_tile", "write_dem", "geolocation_errors", "horizontal", "ORTHO_SPACING_M", "ORTHO_MARGIN_M",
           "DEM_SPACING_M"]

#: orthoimage pixel [m]: a third of the nav-paper radar's 0.3-m ground-range cell (the amplitude is resampled)
ORTHO_SPACING_M = 0.1
#: the tile reaches this far beyond its targets [m]: the chip (a few metres) plus the estimate's errors
ORTHO_MARGIN_M = 20.0
#: DEM pixel [m] (the hills are tens of metres wide)
DEM_SPACING_M = 2.0
#: fixed-point iterations of a pixel's height onto the surface
_HEIGHT_ITERATIONS = 3


def geolocation_errors(seed, apertures: int, sigma) -> np.ndarray:
    """(U, 3) the product's geolocation error of each aperture's tile [m] (NED), from the run's ``seed``
    (``SeedSequence``; its state read, not spawned: the campaign's draws are untouched) and the 1-sigma (3,)."""
    rng = np.random.default_rng(np.random.SeedSequence([*seed.generate_state(4).tolist(), 26]))
    return rng.standard_normal((apertures, 3)) * horizontal(sigma)


def horizontal(sigma) -> np.ndarray:
    """The product's geolocation 1-sigma the export realises: the horizontal part of ``scene.geolocation_sigma_m``
    (the tile is shifted; its heights, the DEM or the tangent plane, are the world's: down 0)."""
    s = np.array(sigma, dtype=np.float64)
    s[2] = 0.0
    return s


def _lattice(box, origin, spacing: float):
    """(lat (H,), lon (W,), west, north, dlon, dlat) of a north-up grid covering the NED ``box`` ((n0, n1), (e0, e1))."""
    (n0, n1), (e0, e1) = box
    lat_a, lon_a, _ = pymap3d.ned2geodetic(n0, e0, 0.0, *origin)
    lat_b, lon_b, _ = pymap3d.ned2geodetic(n1, e1, 0.0, *origin)
    dlat = (lat_b - lat_a) / (n1 - n0) * spacing
    dlon = (lon_b - lon_a) / (e1 - e0) * spacing
    h, w = int(np.ceil((n1 - n0) / spacing)) + 1, int(np.ceil((e1 - e0) / spacing)) + 1
    north, west = lat_b + 0.5 * dlat, lon_a - 0.5 * dlon
    lat = north - (np.arange(h) + 0.5) * dlat
    lon = west + (np.arange(w) + 0.5) * dlon
    return lat, lon, west, north, dlon, dlat


def _surface(lat, lon, origin, terrain):
    """(NED points (H, W, 3), heights above the ellipsoid (H, W)) of the surface at each latitude and longitude."""
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    h = np.zeros(la.shape)
    for _ in range(_HEIGHT_ITERATIONS):
        n, e, d = pymap3d.geodetic2ned(la, lo, h, *origin)
        want = np.zeros(la.shape) if terrain is None else -terrain.height(n, e)
        h = h + (d - want)
    n, e, d = pymap3d.geodetic2ned(la, lo, h, *origin)
    return np.stack([n, e, d], axis=-1), h


def write_ortho_tile(path, ref, targets, origin, terrain, error) -> None:
    """Write the orthoimage of one aperture (module docstring): ``ref`` its ``ReferencePulses`` (trusted track),
    ``targets`` (T, 3), ``origin`` (lat, lon, h), ``terrain`` (``HillTerrain`` or None), ``error`` (3,) the tile's
    geolocation error [m]."""
    lo, hi = targets[:, :2].min(axis=0) - ORTHO_MARGIN_M, targets[:, :2].max(axis=0) + ORTHO_MARGIN_M
    lat, lon, west, north, dlon, dlat = _lattice(((lo[0], hi[0]), (lo[1], hi[1])), origin, ORTHO_SPACING_M)
    pts, _ = _surface(lat, lon, origin, terrain)
    true = pts.copy()
    true[..., :2] -= np.asarray(error, dtype=np.float64)[:2]
    if terrain is not None:
        true[..., 2] = -terrain.height(true[..., 0], true[..., 1])
    amp = np.abs(backproject_points(ref.pulses, true, positions=ref.positions))
    write_geotiff(path, amp, west, north, dlon, dlat)


def write_dem(path, box, origin, terrain) -> None:
    """Write the terrain's heights above the WGS-84 ellipsoid over the NED ``box`` ((n0, n1), (e0, e1)) [m]."""
    (n0, n1), (e0, e1) = box
    m = 4.0 * DEM_SPACING_M
    lat, lon, west, north, dlon, dlat = _lattice(((n0 - m, n1 + m), (e0 - m, e1 + m)), origin, DEM_SPACING_M)
    _, h = _surface(lat, lon, origin, terrain)
    write_geotiff(path, h, west, north, dlon, dlat)
