"""The NED tangent frame's constants (``sarnav.frames.ned``): gravity and the Earth's rate against their closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarnav.frames.ned import earth_rate_or_zero, earth_rate_tangent, gravity_ned

OMEGA = 7.292115e-5  # WGS-84 Earth rate [rad/s]


def test_gravity_points_down_and_is_a_fresh_copy():
    g = gravity_ned()
    assert g[0] == 0.0 and g[1] == 0.0 and g[2] == pytest.approx(9.81, abs=0.01)
    g[2] = 0.0
    assert gravity_ned()[2] > 9.0  # the module constant was not changed through the copy


@pytest.mark.parametrize("lat_deg", [-90.0, -30.0, 0.0, 45.0, 90.0])
def test_earth_rate_in_the_tangent_frame(lat_deg):
    """omega_ie^t = Omega [cos L, 0, -sin L]: north and up components, magnitude Omega at every latitude."""
    lat = math.radians(lat_deg)
    w = earth_rate_tangent(lat)
    np.testing.assert_allclose(w, OMEGA * np.array([math.cos(lat), 0.0, -math.sin(lat)]), rtol=1e-6, atol=1e-15)
    assert np.linalg.norm(w) == pytest.approx(OMEGA, rel=1e-6)


def test_earth_rate_or_zero():
    """None means a non-rotating Earth (zero); a vector is passed through as float64."""
    assert np.array_equal(earth_rate_or_zero(None), np.zeros(3))
    w = earth_rate_or_zero([1, 2, 3])
    assert w.dtype == np.float64 and np.array_equal(w, [1.0, 2.0, 3.0])


def test_bad_latitude_and_rate_are_named():
    """A latitude past the poles or a malformed rate is one ConfigError naming the key and the valid range."""
    from sarnav.errors import ConfigError

    with pytest.raises(ConfigError, match=r"earth.latitude_deg.*\[-90, 90\]"):
        earth_rate_tangent(math.radians(91.0))
    with pytest.raises(ConfigError, match="earth_rate"):
        earth_rate_or_zero([1.0, np.nan, 0.0])
    with pytest.raises(ConfigError, match="earth_rate"):
        earth_rate_or_zero([1.0, 2.0])
