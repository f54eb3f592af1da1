"""``radar.antenna``: the uniformly illuminated aperture (Cumming & Wong 2005 eq. 4.27): one-way amplitude
sinc(L sin(theta) / lambda), so the two-way amplitude sinc^2 is 1/2 at the one-way -3 dB half-width
sin(theta) = 0.443 lambda / L and has its first null at lambda / L; the look geometry puts boresight to the right of
the velocity (NED: down x u) or to the left."""

import numpy as np
import pytest

from sarnav.radar.antenna import along_track_directions, gain, look_vectors, two_way_gain

LAM, L = 0.03, 0.5


def test_pattern_half_power_and_null():
    g = two_way_gain(np.array([0.0, 0.443 * LAM / L, -0.443 * LAM / L, LAM / L]), L, LAM)
    assert g[0] == 1.0
    np.testing.assert_allclose(g[1:3], 0.5, rtol=2e-3)  # 0.886 is the 3-digit rounding of the half-power width
    assert abs(g[3]) < 1e-15


def test_gain_geometry_for_a_north_flying_antenna():
    t = np.linspace(0.0, 1.0, 5)
    pos = np.c_[60.0 * t, np.zeros(5), np.full(5, -1000.0)]
    u = along_track_directions(pos, t)
    np.testing.assert_allclose(u, np.tile([1.0, 0.0, 0.0], (5, 1)), atol=1e-15)
    np.testing.assert_allclose(look_vectors(u, "right"), np.tile([0.0, 1.0, 0.0], (5, 1)), atol=1e-15)  # east
    east, west = np.array([[30.0, 1800.0, 0.0]]), np.array([[30.0, -1800.0, 0.0]])
    g_r = gain(pos, u, east, L, LAM, "right")[:, 0]
    assert g_r[2] == pytest.approx(1.0)  # abeam at t = 0.5 s
    d = east[0] - pos
    sin_theta = d[:, 0] / np.linalg.norm(d, axis=1)  # independent: the along-track cosine of the line of sight
    np.testing.assert_allclose(g_r, np.sinc(L * sin_theta / LAM) ** 2, rtol=1e-12)
    assert np.all(gain(pos, u, west, L, LAM, "right") == 0.0)
    np.testing.assert_allclose(gain(pos, u, west, L, LAM, "left")[:, 0], g_r, rtol=1e-12)  # mirror image
