"""The BPA ground lattice and the focusing track of the image-aided flight (measurements.ground_grid)."""

import numpy as np
import pytest

from sarnav.measurements.ground_grid import BpaGrid, focusing_track, ground_frame


@pytest.mark.parametrize("look, sign", [("right", 1.0), ("left", -1.0)])
def test_the_ground_frame_is_horizontal_and_points_to_the_look_side(look, sign):
    v = np.array([3.0, 4.0, -0.7])  # climbing: the frame stays horizontal
    along, across = ground_frame(v, look)
    assert along == pytest.approx([0.6, 0.8, 0.0])
    # NED: the right of a vehicle heading north is east (z down), so across = z x along for a right look
    assert across == pytest.approx(sign * np.cross([0.0, 0.0, 1.0], along))
    assert np.linalg.norm(across) == pytest.approx(1.0)


def test_every_node_of_the_grid_is_its_point_and_fractions_interpolate():
    along, across = ground_frame(np.array([0.0, 1.0, 0.0]), "right")
    g = BpaGrid(np.array([10.0, 20.0, 0.0]), along, across, 0.05, 0.7, (5, 7))
    pts = g.points()
    assert pts.shape == (5, 7, 3)
    for i in range(5):
        for j in range(7):
            assert g.point(i, j) == pytest.approx(pts[i, j], abs=1e-12)
    assert g.point(2, 3) == pytest.approx(g.centre)  # the centre node is the centre
    # half a pixel across: the midpoint of two neighbours, exactly dg / 2 from the centre
    assert g.point(2, 3.5) == pytest.approx(0.5 * (pts[2, 3] + pts[2, 4]))
    assert np.linalg.norm(g.point(2, 3.5) - g.centre) == pytest.approx(0.35)


def test_a_straight_track_is_the_centre_state_carried_at_constant_velocity():
    ap_t = np.linspace(4.0, 5.0, 11)
    v = np.tile([9.0, 1.0, -0.2], (11, 1))
    p = np.array([100.0, -5.0, -1000.0]) + (ap_t - ap_t[5])[:, None] * v
    p_noisy = p + np.random.default_rng(1).normal(0.0, 0.3, p.shape)  # INS wander off the centre is not followed
    p_noisy[5] = p[5]
    times = np.linspace(4.0, 5.0, 301)
    track = focusing_track(times, ap_t, p_noisy, v)
    expected = p[5] + (times - ap_t[5])[:, None] * v[5]
    assert np.max(np.abs(track - expected)) < 1e-9


def test_a_level_turn_measured_in_heading_is_followed():
    """A level turn of radius 2292 m at 10 m/s (0.25 deg/s): the track from the centre state and the heading change
    stays on the circle to a millimetre over the second (trapezoid steps between the 11 epochs and the pulses)."""
    rho, V = 2292.0, 10.0
    w = V / rho
    circle = lambda t: np.stack([rho * np.sin(w * t), rho * (1 - np.cos(w * t)), 0 * t], axis=-1)  # noqa: E731
    ap_t = np.linspace(-0.5, 0.5, 11)
    v = np.stack([V * np.cos(w * ap_t), V * np.sin(w * ap_t), 0 * ap_t], axis=-1)
    times = np.linspace(-0.5, 0.5, 401)
    track = focusing_track(times, ap_t, circle(ap_t), v)
    assert np.max(np.linalg.norm(track - circle(times), axis=1)) < 1e-3
    straight = circle(np.zeros(1)) + times[:, None] * v[5]  # without the turn the ends would be rho (w t)^2 / 2 off
    assert np.max(np.linalg.norm(straight - circle(times), axis=1)) > 5e-3
