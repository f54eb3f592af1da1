"""The polar images' points on the image's plane (sarnav.imaging.ffbp_surface): geometry against its definition.

The images these points carry are tested in tests/imaging/test_ffbp.py (any track within the polar stages' error) and
tests/imaging/test_ffbp_merge.py (the two-pass merge on the plane against the 2-D merge).
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sarnav.imaging.ffbp_surface import plane_point, plane_points, surface_constants


def frame(seed: int, tilt: float):
    """A subaperture centre ``c`` 2-6 km from a plane through ``o`` (normal tilted ``tilt`` rad from vertical), a track
    direction ``v`` in a random horizontal direction, ``w`` its perpendicular towards the scene centre ``o`` (as
    ``ffbp._polar_grid`` builds it)."""
    rng = np.random.default_rng(seed)
    az = rng.uniform(0, 2 * np.pi)
    n = np.array([np.sin(tilt) * np.cos(az + 1.0), np.sin(tilt) * np.sin(az + 1.0), np.cos(tilt)])
    o = rng.uniform(-100, 100, 3)
    v = np.array([np.cos(az), np.sin(az), rng.uniform(-0.05, 0.05)])
    v /= np.linalg.norm(v)
    side = np.cross(n, v)
    side /= np.linalg.norm(side)
    c = o + rng.uniform(2e3, 6e3) * (0.5 * n - np.sqrt(0.75) * side) + rng.uniform(-50, 50) * v
    off = o - c
    w = off - np.dot(off, v) * v
    return c, v, w / np.linalg.norm(w), o, n


def test_a_plane_point_has_its_range_direction_cosine_and_lies_on_the_plane_on_the_scenes_side():
    """Property (hypothesis, derandomised): for any frame and (r, u) whose ring meets the plane, the point is on the
    plane (to 1e-7 m), at range r (1e-8 m) and direction cosine u (1e-12), and of the ring's two points on the plane
    the one nearer the half-plane towards w (the mirror root lies at least as far round the ring)."""
    @settings(max_examples=60, deadline=None, derandomize=True)
    @given(st.integers(0, 2**32 - 1), st.floats(0.0, 0.4), st.floats(-0.3, 0.3), st.floats(0.02, 0.98))
    def check(seed, tilt, u, depth):
        c, v, w, o, n = frame(seed, tilt)
        h = abs(np.dot(n, c - o))
        r = h / depth                                         # beyond the plane's nearest point: the ring meets it
        sc = surface_constants(c, v, w, o, n)
        q = np.array(plane_point(c, v, w, sc, r, u))
        s = np.sqrt(1 - u * u)
        b = np.cross(v, w)
        phi = np.arctan2(np.dot(q - c, b), np.dot(q - c, w))
        ring = c + r * (u * v + s * (np.cos(np.linspace(-np.pi, np.pi, 3601))[:, None] * w
                                     + np.sin(np.linspace(-np.pi, np.pi, 3601))[:, None] * b))
        height = (ring - o) @ n
        crossings = np.flatnonzero(np.sign(height[1:]) != np.sign(height[:-1]))
        if crossings.size < 2:                                # the ring grazes the plane: no pair of roots
            return
        assert abs(np.dot(n, q - o)) < 1e-7, np.dot(n, q - o)
        assert abs(np.linalg.norm(q - c) - r) < 1e-8
        assert abs(np.dot(q - c, v) / r - u) < 1e-12
        roots = np.linspace(-np.pi, np.pi, 3601)[crossings]
        assert abs(phi) <= np.min(np.abs(roots)) + 2 * np.pi / 3600 + 1e-9, (phi, roots)

    check()


def test_on_a_straight_track_the_plane_point_has_the_half_planes_range_to_every_pulse():
    """The equivalence ``ffbp`` relies on for straight tracks: for pulses on the line through c along v, the plane's
    point of (r, u) and the half-plane's point of (r, u) are at the same range from every pulse (to 1e-9 m), so the
    polar image is the same on either surface; off the line they are not."""
    c, v, w, o, n = frame(7, 0.2)
    sc = surface_constants(c, v, w, o, n)
    s_k = np.linspace(-200, 200, 41)
    straight = c + s_k[:, None] * v
    bent = straight + 0.1 * np.sin(s_k / 50)[:, None] * np.cross(v, w)
    for r, u in ((np.linalg.norm(o - c), 0.0), (np.linalg.norm(o - c) + 300.0, 0.05)):
        q = np.array(plane_point(c, v, w, sc, r, u))
        half = c + r * (u * v + np.sqrt(1 - u * u) * w)
        assert np.max(np.abs(np.linalg.norm(q - straight, axis=1) - np.linalg.norm(half - straight, axis=1))) < 1e-9
        assert np.max(np.abs(np.linalg.norm(q - bent, axis=1) - np.linalg.norm(half - bent, axis=1))) > 1e-4


def test_plane_points_lists_each_lines_points_in_order():
    """``plane_points``: index j nr + i holds the point of (r0 + i dr, u0 + j du), the same as ``plane_point``'s."""
    c, v, w, o, n = frame(11, 0.1)
    sc = surface_constants(c, v, w, o, n)
    r0, dr, nr, u0, du, nu = np.linalg.norm(o - c) - 20.0, 0.5, 80, -0.01, 0.0005, 40
    pts = np.empty((3, nr * nu))
    plane_points(c, v, w, sc, r0, dr, nr, u0, du, nu, *pts)
    for j, i in ((0, 0), (3, 17), (nu - 1, nr - 1)):
        assert np.allclose(pts[:, j * nr + i], plane_point(c, v, w, sc, r0 + i * dr, u0 + j * du), rtol=0, atol=1e-9)
    assert np.all(np.abs((pts.T - o) @ n) < 1e-7)
