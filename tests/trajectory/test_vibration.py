"""Vibrating: the tones' derivatives against finite differences, the IMU it implies, the geodetic flight over it, and
its one-line errors."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.rotations import quat_to_dcm
from sarnav.trajectory import Maneuvering, RateProfile, StraightLevel
from sarnav.trajectory.geodetic import GeodeticFlight
from sarnav.trajectory.vibration import MAX_VIBRATION_HZ, Vibrating, check_tones
from sarnav.frames.wgs84 import geodetic_difference_ned

TONES = dict(frequencies=[2.0, 7.0], amplitudes=[[0.0, 2e-3, 1e-3], [5e-4, 1e-3, 1e-3]], phases=[0.3, -1.1])


def _turning():
    return Maneuvering([0.0, 0.0, -50.0], 5.0, 0.4, RateProfile((0.0, 3.0), (0.0, 0.2), 1.0),
                       RateProfile((0.0,), (0.0,), 1.0), 10.0)


def test_velocity_and_acceleration_are_the_derivatives_of_the_vibrating_position():
    base = _turning()
    v = Vibrating(base, **TONES)
    h, t0 = 1e-3, np.array([1.234, 4.5, 8.01])
    k = np.arange(-2, 3)
    p = v.state(t0[:, None] + h * k).position  # (3, 5, 3)
    dp = (p[:, 0] - 8 * p[:, 1] + 8 * p[:, 3] - p[:, 4]) / (12 * h)
    vel = v.state(t0[:, None] + h * k).velocity
    dv = (vel[:, 0] - 8 * vel[:, 1] + 8 * vel[:, 3] - vel[:, 4]) / (12 * h)
    np.testing.assert_allclose(v.state(t0).velocity, dp, atol=1e-8)
    np.testing.assert_allclose(v.acceleration(t0), dv, atol=1e-6)
    # the vibration itself: its acceleration is A (2 pi f)^2 at the peak, 3.9 m/s^2 for 2 mm at 7 Hz
    d2 = v.acceleration(t0) - base.acceleration(t0)
    assert 0.05 < np.max(np.abs(d2)) < 2e-3 * (2 * np.pi * 7.0) ** 2 + 1e-3 * (2 * np.pi * 2.0) ** 2


def test_specific_force_adds_the_vibration_in_the_body_frame_and_attitude_is_the_base():
    base = _turning()
    v = Vibrating(base, **TONES)
    t = np.linspace(0.0, 10.0, 41)
    C = quat_to_dcm(base.state(t).quaternion)
    d2 = v.acceleration(t) - base.acceleration(t)
    np.testing.assert_allclose(v.specific_force(t) - base.specific_force(t), np.einsum("tji,tj->ti", C, d2),
                               atol=1e-12)
    np.testing.assert_array_equal(v.state(t).quaternion, base.state(t).quaternion)
    np.testing.assert_array_equal(v.angular_rate(t), base.angular_rate(t))


@pytest.mark.parametrize("hz", [3.0, MAX_VIBRATION_HZ])
def test_the_geodetic_flight_follows_the_vibration_to_a_hundredth_of_its_amplitude(hz):
    """GeodeticFlight integrates latitude and longitude every 20 ms: at the highest tone allowed its cubic Hermite
    interpolant is within A (2 pi f 0.02)^4 / 384 (0.65 % at 10 Hz) of the tone (both flights start at the geodetic
    origin, so the offset is d(t) - d(0))."""
    base = StraightLevel([0.0, 0.0, -1000.0], 1.0, 0.0, 20.0)
    amp = np.array([[1e-3, 2e-3, 1e-3]])
    lat0, lon0 = np.radians(35.2), np.radians(-97.44)
    plain = GeodeticFlight(base, lat0, lon0, 1000.0)
    shaken = GeodeticFlight(Vibrating(base, [hz], amp, [0.7]), lat0, lon0, 1000.0)
    t = np.linspace(0.0, 20.0, 4001)
    a, b = plain.state(t), shaken.state(t)
    d = geodetic_difference_ned(b.lat, b.lon, b.h, a.lat, a.lon, a.h)
    want = amp[0] * (np.sin(2 * np.pi * hz * t + 0.7) - np.sin(0.7))[:, None]  # both flights start at the origin
    bound = 2e-3 * (2 * np.pi * hz * 0.02) ** 4 / 384 + 1e-7
    assert np.max(np.abs(d - want)) < max(bound, 1e-6) * 1.5
    assert np.max(np.abs(d - want)) < 0.01 * 2e-3


@pytest.mark.parametrize("kw, key", [
    (dict(frequencies=[0.0], amplitudes=[[0.0, 1e-3, 0.0]]), "cart.vibration_hz"),
    (dict(frequencies=[MAX_VIBRATION_HZ * 1.01], amplitudes=[[0.0, 1e-3, 0.0]]), "cart.vibration_hz"),
    (dict(frequencies=[2.0, 3.0], amplitudes=[[0.0, 1e-3, 0.0]]), "cart.vibration_m"),
    (dict(frequencies=[2.0], amplitudes=[[0.0, 0.5, 0.0]]), "cart.vibration_m"),
    (dict(frequencies=[2.0], amplitudes=[[0.0, np.nan, 0.0]]), "cart.vibration_m"),
])
def test_bad_tones_name_their_key(kw, key):
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        Vibrating(StraightLevel([0.0, 0.0, 0.0], 1.0, 0.0, 5.0), **kw)


def test_check_tones_returns_the_tones_and_none_for_empty_lists():
    assert check_tones([], []) == ()
    assert check_tones([2.0], [[0.0, 1e-3, 0.0]]) == ((2.0, (0.0, 1e-3, 0.0), 0.0),)
    with pytest.raises(ConfigError, match=r"cart\.vibration_m"):
        check_tones([], [[0.0, 1e-3, 0.0]])
