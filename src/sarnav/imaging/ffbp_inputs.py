"""FFBP's inputs (``imaging.ffbp``): the grid's bounding pixels and a uniform sample of them, the checked pulses, their
band and the track's direction, read once for the plan and the formation."""

from __future__ import annotations

import math

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import check_pulses, grid_points, plane_of, wavelength_of
from sarnav.imaging.ffbp_plan import track_error
from sarnav.imaging.grid import as_grid
from sarnav.imaging.interpolation_choice import data_oversampling

__all__ = ["FfbpInputs", "hull_points", "plane_hull"]

_C = 299792458.0


def hull_points(pts: np.ndarray) -> np.ndarray:
    """Pixels that bound the image's (r, u) extent: the border of a (Ny, Nx) grid plus a coarse interior."""
    if pts.ndim == 3 and min(pts.shape[:2]) >= 2:
        step = max(1, min(pts.shape[:2]) // 32)
        parts = [pts[0], pts[-1], pts[:, 0], pts[:, -1], pts[::step, ::step].reshape(-1, 3)]
        return np.concatenate([p.reshape(-1, 3) for p in parts])
    return pts.reshape(-1, 3)


def plane_hull(origin, e_row, e_col, ny, nx) -> np.ndarray:
    """:func:`hull_points` of the plane grid origin + i e_row + j e_col (i < ny, j < nx), without listing its pixels.
    The edges at most 257 points each, ends included: between two of them a range or direction cosine can pass its
    sampled extreme by at most (step x pixel)^2 / (8 r), 1e-4 m for 2-m steps at 5 km, against the polar grids' margin
    of POLAR_MARGIN samples (every subaperture's polar grid is sized from these points: 0.1 s at 2048^2 with every
    edge pixel)."""
    step = max(1, min(ny, nx) // 32) if min(ny, nx) >= 2 else 1
    iy, ix = np.arange(ny, dtype=np.float64), np.arange(nx, dtype=np.float64)
    ey = np.append(iy[::max(1, -(-ny // 256))], ny - 1.0)
    ex = np.append(ix[::max(1, -(-nx // 256))], nx - 1.0)
    parts = [(np.zeros(ex.size), ex), (np.full(ex.size, ny - 1.0), ex), (ey, np.zeros(ey.size)),
             (ey, np.full(ey.size, nx - 1.0))]
    a, b = np.meshgrid(iy[::step], ix[::step], indexing="ij")
    parts.append((a.ravel(), b.ravel()))
    i = np.concatenate([q[0] for q in parts])
    j = np.concatenate([q[1] for q in parts])
    return origin + i[:, None] * e_row + j[:, None] * e_col


class FfbpInputs:
    """What ``ffbp.ffbp`` reads of its inputs: the grid (a plane's (origin, e_row, e_col, ny, nx) or its points), the
    pixels that bound its polar extent (``hull``) and a uniform sample of them (for :func:`ffbp_plan.track_error`), the
    checked pulses, their band and the track's direction."""

    def __init__(self, rc, grid, positions, wavelength, bandwidth):
        g = as_grid(grid)
        self.plane = plane_of(g)
        if self.plane is not None:               # a plane grid: its pixels are never listed (hull and centre from it)
            origin, e_row, e_col, ny, nx = self.plane
            if not all(np.all(np.isfinite(a)) for a in (origin, e_row, e_col)):
                raise InputDataError("grid", "pixel positions must be finite (found NaN/inf)")
            self.shape, self.flat = (ny, nx), None
            self.hull = plane_hull(origin, e_row, e_col, ny, nx)
            iy, ix = np.meshgrid(np.linspace(0, ny - 1, min(ny, 17)), np.linspace(0, nx - 1, min(nx, 17)),
                                 indexing="ij")
            self.sample = origin + iy.reshape(-1, 1) * e_row + ix.reshape(-1, 1) * e_col
            self.centre = origin + 0.5 * (ny - 1) * e_row + 0.5 * (nx - 1) * e_col
            self.n_pix = ny * nx
        else:
            g, pts = grid_points(g)
            self.shape = pts.shape[:-1]
            self.hull = hull_points(pts)
            self.flat = pts.reshape(-1, 3)
            self.centre = self.flat.mean(axis=0)
            self.n_pix = self.flat.shape[0]
            self.sample = self.flat[::max(1, self.n_pix // 289)]
        self.grid = g
        self.data, self.rng, self.pos = check_pulses(rc, positions)
        self.lam = wavelength_of(rc, wavelength)
        dr_data = float(self.rng[1] - self.rng[0])
        # default: the band back-projection's "auto" sees (rc.bandwidth, else the pulses' spectrum), not the sample
        # rate: on CPHD pulses (fs/B 4) the sample rate made every polar grid 4x finer in range and FFBP 4-6x slower
        self.bw = _C / (2.0 * dr_data) / data_oversampling(rc) if bandwidth is None else float(bandwidth)
        if not (math.isfinite(self.bw) and self.bw > 0):
            raise ConfigError("bandwidth", f"must be finite and > 0 Hz, got {bandwidth!r}")
        self.p = self.data.shape[0]
        if self.p < 2:
            raise InputDataError("rc.data", "FFBP needs >= 2 pulses (use backproject)")
        chord = self.pos[-1] - self.pos[0]
        if np.linalg.norm(chord) == 0:
            raise InputDataError("positions", "first and last antenna positions coincide: no track direction")
        self.v = chord / np.linalg.norm(chord)
        self.spacing = float(np.linalg.norm(chord)) / (self.p - 1)
        self.fc = _C / self.lam
        self.lam_eff = self.lam / (1.0 + self.bw / (2.0 * self.fc))
        self._bent = {}

    def track(self, n: int) -> float:
        """The track's error (linear) with last-level subapertures of ``n`` pulses (``ffbp_plan.track_error``)."""
        if n not in self._bent:
            self._bent[n] = track_error(self.pos, self.sample, self.v, self.centre, self.lam, n)
        return self._bent[n]
