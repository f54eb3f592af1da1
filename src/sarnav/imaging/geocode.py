"""Zero-Doppler geometry of a spaceborne image and its resampling onto a map grid (geocoding).

An image formed by a zero-squint range-Doppler processor has rows at the zero-Doppler times t_k = t_first + k / PRF
and columns at slant ranges R_j = r_first + j dr. A ground point p (ECEF, fixed) appears at the time t0 where
(p - r(t0)) . v(t0) = 0 and the range |p - r(t0)| (stop-and-hop). :class:`OrbitArc` is a polynomial fit of the
antenna positions over the block (from the truth: the reference pass; or from the navigation estimate: the
area-correlation registration); :func:`zero_doppler` solves for t0 by Newton's method
(f(t) = (p - r) . v, f'(t) = -|v|^2 + (p - r) . a); :func:`geocode` samples the amplitude image at every map cell
(lat, lon, DEM height) -> (t0, R) (bilinear interpolation; cells outside the image are 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from sarnav.errors import InputDataError
from sarnav.frames.wgs84 import geodetic_to_ecef

__all__ = ["OrbitArc", "zero_doppler", "geocode", "image_coordinates"]


@dataclass(frozen=True)
class OrbitArc:
    """ECEF position r(t) = sum_k c_k (t - t0)^k over a block; ``coeffs`` (deg + 1, 3), lowest order first."""

    t0: float
    coeffs: np.ndarray

    @classmethod
    def fit(cls, t, r, t0: float, degree: int = 5) -> "OrbitArc":
        """Least-squares polynomial fit of positions r (N, 3) at times t (N,)."""
        t = np.asarray(t, float) - t0
        r = np.asarray(r, float)
        if r.shape != (t.size, 3) or t.size <= degree:
            raise InputDataError("positions", f"need (N > {degree}, 3) positions for the arc, got {r.shape}")
        scale = max(float(np.max(np.abs(t))), 1e-9)
        V = np.vander(t / scale, degree + 1, increasing=True)
        c, *_ = np.linalg.lstsq(V, r, rcond=None)
        return cls(float(t0), c / scale ** np.arange(degree + 1)[:, None])

    @classmethod
    def from_state(cls, t0: float, r, v, a) -> "OrbitArc":
        """Second-order arc r + v dt + a dt^2 / 2 from a state and its acceleration (the navigation estimate)."""
        return cls(float(t0), np.stack([np.asarray(r, float), np.asarray(v, float), 0.5 * np.asarray(a, float)]))

    def derivatives(self, t):
        """(r, v, a) (N, 3) at times t (N,)."""
        dt = (np.asarray(t, float) - self.t0)[:, None]
        c = self.coeffs
        r, v, a = np.zeros((dt.shape[0], 3)), np.zeros((dt.shape[0], 3)), np.zeros((dt.shape[0], 3))
        for k in range(c.shape[0] - 1, -1, -1):  # Horner for the polynomial and its first two derivatives
            a = a * dt + 2.0 * v
            v = v * dt + r
            r = r * dt + c[k]
        return r, v, a


def zero_doppler(arc: OrbitArc, points, iterations: int = 6):
    """Zero-Doppler time t0 (N,) [s] and slant range (N,) [m] of ECEF points (N, 3) on the arc (Newton from t0)."""
    p = np.asarray(points, float).reshape(-1, 3)
    t = np.full(p.shape[0], arc.t0)
    for _ in range(iterations):
        r, v, a = arc.derivatives(t)
        d = p - r
        f = np.einsum("ni,ni->n", d, v)
        fp = -np.einsum("ni,ni->n", v, v) + np.einsum("ni,ni->n", d, a)
        t = t - f / fp
    r, _, _ = arc.derivatives(t)
    return t, np.linalg.norm(p - r, axis=1)


def image_coordinates(arc: OrbitArc, points, t_first: float, prf: float, r_first: float, dr: float):
    """Fractional (row, col) of ECEF points (N, 3) in an image with rows at t_first + k/prf, columns r_first + j dr."""
    t, rng = zero_doppler(arc, points)
    return (t - t_first) * prf, (rng - r_first) / dr


def geocode(amplitude, t_first: float, prf: float, r_first: float, dr: float, arc: OrbitArc, grid, terrain):
    """The amplitude image resampled onto the map grid (``radar.terrain.MapGrid``, heights from ``terrain``):
    (rows, cols) float, 0 outside the image."""
    lat, lon = grid.cell_latlon()
    p = geodetic_to_ecef(lat, lon, terrain.height(lat, lon)).reshape(-1, 3)
    row, col = image_coordinates(arc, p, t_first, prf, r_first, dr)
    img = np.asarray(amplitude, float)
    out = ndimage.map_coordinates(img, np.vstack([row, col]), order=1, mode="constant", cval=0.0)
    return out.reshape(grid.shape)
