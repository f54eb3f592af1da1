"""``imaging.grid``: pixel positions against independent geometry. A ``SlantGrid`` pixel (i, j) has, relative to the
straight track through ``origin`` along ``direction``, the along-track coordinate along_track[i] and the range of
closest approach slant_range[j] (the axes of an RDA image), in the plane of the track and the look point."""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.grid import GroundGrid, PlaneGrid, PointGrid, SlantGrid, as_grid, regular_axis


def test_slant_grid_pixels_have_their_zero_doppler_coordinates():
    origin, d = np.array([10.0, -5.0, -1000.0]), np.array([3.0, 1.0, 0.2])
    look = np.array([200.0, 1800.0, 0.0])
    g = SlantGrid(origin, d, look, np.linspace(-6.0, 6.0, 5), np.linspace(2040.0, 2060.0, 7))
    u = d / np.linalg.norm(d)
    q = g.points() - origin
    along = q @ u  # closest approach to the line origin + s u is at s = (q . u)
    perp = np.linalg.norm(q - along[..., None] * u, axis=-1)
    np.testing.assert_allclose(along, np.broadcast_to(g.along_track[:, None], g.shape), rtol=0, atol=1e-9)
    np.testing.assert_allclose(perp, np.broadcast_to(g.slant_range[None, :], g.shape), rtol=1e-13)
    normal = np.cross(u, look - origin)  # every pixel lies in the plane of the track and the look point
    np.testing.assert_allclose(q @ normal / np.linalg.norm(normal), 0.0, atol=1e-8)
    assert np.all((q - along[..., None] * u) @ (look - origin) > 0)  # on the look point's side


def test_ground_and_plane_grids():
    g = GroundGrid.centered(100.0, 1800.0, 0.5, (4, 6), down=-2.0, spacing_east=0.25)
    p = g.points()
    np.testing.assert_allclose(p.reshape(-1, 3).mean(axis=0), [100.0, 1800.0, -2.0])
    np.testing.assert_allclose(np.diff(p[:, 0, 0]), 0.5)
    np.testing.assert_allclose(np.diff(p[0, :, 1]), 0.25)
    plane = PlaneGrid(np.zeros(3), [0.0, 2.0, 0.0], [0.0, 0.0, -3.0], [0.0, 1.0, 2.0], [5.0, 6.0])
    np.testing.assert_allclose(plane.points()[2, 1], [0.0, 2.0, -6.0])  # unit directions
    np.testing.assert_allclose(regular_axis(1.0, 0.5, 4), [0.25, 0.75, 1.25, 1.75])


def test_point_arrays_become_point_grids():
    pts = np.arange(12.0).reshape(4, 3)
    g = as_grid(pts)
    assert isinstance(g, PointGrid) and g.shape == (1, 4)
    np.testing.assert_array_equal(g.points()[0], pts)
    ground = GroundGrid.centered(0.0, 0.0, 1.0, (2, 2))
    assert as_grid(ground) is ground


@pytest.mark.parametrize("make, err, field", [
    (lambda: GroundGrid([0.0, 1.0, 3.0], [0.0, 1.0]), InputDataError, "grid.north"),
    (lambda: GroundGrid([0.0, 1.0], [0.0, 1.0], down=np.inf), ConfigError, "grid.down"),
    (lambda: SlantGrid([0, 0, 0], [1, 0, 0], [5, 0, 0], [0, 1], [1, 2]), InputDataError, "grid.look_point"),
    (lambda: SlantGrid([0, 0, 0], [1, 0, 0], [0, 5, 0], [0, 1], [-1, 0]), InputDataError, "grid.slant_range"),
    (lambda: PlaneGrid([0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1], [0, 1]), InputDataError, "grid.col_direction"),
    (lambda: regular_axis(0.0, 0.0, 3), ConfigError, "axis.spacing"),
    (lambda: PointGrid(np.full((1, 2, 3), np.nan)), InputDataError, "grid"),
])
def test_bad_grids_are_named(make, err, field):
    with pytest.raises(err, match=field):
        make()
