"""FFBP's inputs (sarnav.imaging.ffbp_inputs): the grid's bounds and sample, the pulses' checks, the track's error."""

from __future__ import annotations

import numpy as np
import pytest
from test_ffbp import BW, LAM, scene

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import grid_points
from sarnav.imaging.ffbp_inputs import FfbpInputs, hull_points, plane_hull
from sarnav.imaging.ffbp_plan import track_error
from sarnav.imaging.grid import as_grid
from sarnav.signal.data import PulseData


def polar(pts, c, v):
    d = pts.reshape(-1, 3) - c
    r = np.linalg.norm(d, axis=1)
    return r, d @ v / r


def test_the_hull_bounds_every_pixels_range_and_direction_cosine_and_the_sample_spans_the_grid():
    """The plane grid's hull (``plane_hull``, its pixels never listed) and a point grid's (``hull_points``) reach each
    pixel's extreme range and direction cosine about a subaperture centre (within (step x pixel)^2 / 8 r); the plane
    grid's sample is 17 x 17 pixels from corner to corner; centre and pixel count are the grid's."""
    rc, grid = scene(100, 64, 5e3, n_targets=5)
    g = as_grid(grid)
    pts = grid_points(g)[1]
    s = FfbpInputs(rc, grid, None, None, BW)
    assert s.n_pix == 100 * 100 and s.shape == (100, 100) and s.sample.shape == (17 * 17, 3)
    assert np.allclose(s.sample[[0, 16, -17, -1]], pts[[0, 0, -1, -1], [0, -1, 0, -1]], rtol=0, atol=1e-6)
    assert np.allclose(s.centre, pts.reshape(-1, 3).mean(axis=0), rtol=0, atol=1e-6)
    c, v = rc.positions.mean(axis=0), s.v
    r_all, u_all = polar(pts, c, v)
    for hull in (s.hull, hull_points(pts)):
        r_h, u_h = polar(hull, c, v)
        assert r_h.min() <= r_all.min() + 1e-6 and r_h.max() >= r_all.max() - 1e-6
        assert u_h.min() <= u_all.min() + 1e-9 and u_h.max() >= u_all.max() - 1e-9
    assert plane_hull(pts[0, 0], pts[1, 0] - pts[0, 0], pts[0, 1] - pts[0, 0], 100, 100).shape[1] == 3


def test_bad_pulses_and_band_are_named():
    rc, grid = scene(16, 8, 5e3, n_targets=2)
    with pytest.raises(ConfigError, match=r"^bandwidth: must be finite and > 0 Hz"):
        FfbpInputs(rc, grid, None, None, -1.0)
    one = PulseData(rc.data[:1], rc.slant_range, rc.pulse_times[:1], rc.positions[:1], None, compressed=True,
                    wavelength=LAM)
    with pytest.raises(InputDataError, match=r"^rc.data: FFBP needs >= 2 pulses"):
        FfbpInputs(one, grid, None, None, BW)
    still = np.repeat(rc.positions[:1], rc.n_pulses, axis=0)
    with pytest.raises(InputDataError, match=r"^positions: first and last antenna positions coincide"):
        FfbpInputs(rc, grid, still, None, BW)


def test_the_tracks_error_is_track_error_on_the_sample_and_zero_on_a_straight_track():
    """``track(n)`` is ``ffbp_plan.track_error`` of the positions on the uniform sample (computed once per n); a straight
    track's is zero, a bent one's grows with the last level's subaperture."""
    k = np.arange(64)
    bent = 5e-3 * np.sin(2 * np.pi * k / 64)[:, None] * np.array([0.0, -0.5, np.sqrt(0.75)])[None]
    for offset, zero in ((None, True), (bent, False)):
        rc, grid = scene(48, 64, 5e3, n_targets=5, offset=offset)
        s = FfbpInputs(rc, grid, None, None, BW)
        for n in (8, 32, 64):
            assert s.track(n) == track_error(rc.positions, s.sample, s.v, s.centre, LAM, n)
        assert (s.track(64) == 0.0) == zero
        assert zero or s.track(8) < s.track(32) < s.track(64)
