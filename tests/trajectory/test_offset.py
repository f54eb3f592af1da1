"""``trajectory.offset.OffsetTrack``: the closed-form geometry of a pass shifted sideways and upward (parallel track
of a straight flight, concentric circle of a steady turn), its velocity and attitude, and its one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.trajectory.maneuver import Maneuvering
from sarnav.trajectory.offset import OffsetTrack
from sarnav.trajectory.rate_profile import RateProfile
from sarnav.trajectory.straight import StraightLevel


@pytest.mark.parametrize("heading_deg, right", [(0.0, (0.0, 1.0)), (90.0, (-1.0, 0.0)), (180.0, (0.0, -1.0)),
                                                (-90.0, (1.0, 0.0)), (45.0, (-0.5**0.5, 0.5**0.5))])
def test_straight_track_is_shifted_to_the_right_and_up(heading_deg, right):
    """Straight level flight: p = p_base + across (right unit normal) - up e_D, the velocity and attitude unchanged."""
    base = StraightLevel([100.0, -50.0, -1000.0], 60.0, np.radians(heading_deg), 20.0)
    off = OffsetTrack(base, across=120.0, up=35.0)
    t = np.array([0.0, 3.3, 10.0, 20.0])
    b, o = base.state(t), off.state(t)
    shift = np.array([120.0 * right[0], 120.0 * right[1], -35.0])
    np.testing.assert_allclose(o.position - b.position, np.tile(shift, (4, 1)), atol=1e-9)
    np.testing.assert_allclose(o.velocity, b.velocity, atol=1e-6)  # ends included (one-sided differences)
    np.testing.assert_array_equal(o.quaternion, b.quaternion)
    assert off.duration == base.duration


def test_negative_across_is_the_left_side_and_zero_offset_is_the_base():
    """across < 0 moves left of the velocity; (0, 0) reproduces the base exactly."""
    base = StraightLevel([0.0, 0.0, -500.0], 50.0, 0.0, 10.0)
    t = np.linspace(0.0, 10.0, 7)
    np.testing.assert_allclose(OffsetTrack(base, -80.0, 0.0).state(t).position[:, 1], -80.0, atol=1e-12)
    np.testing.assert_allclose(OffsetTrack(base, 0.0, 0.0).state(t).position, base.state(t).position, atol=0)


@pytest.mark.parametrize("rate_deg_s", [4.0, -4.0])
def test_steady_turn_offset_is_a_concentric_circle(rate_deg_s):
    """A steady level turn at rate w (radius R = V/|w|): the offset track lies on the circle of radius R - across sign(w)
    about the same centre, and its speed is V (1 - across w / V) (the right normal points into a right turn).
    The class docstring writes the factor as ``1 + across x turn rate / V``: that holds with the opposite sign
    convention for the turn rate (left turns positive); here w > 0 turns right (heading increasing)."""
    V, w, across = 50.0, np.radians(rate_deg_s), 150.0
    turn = RateProfile((0.0,), (w,), 1.0)
    base = Maneuvering([0.0, 0.0, -800.0], V, 0.0, turn, RateProfile((0.0,), (0.0,), 1.0), 30.0)
    off = OffsetTrack(base, across=across, up=0.0)
    t = np.linspace(0.5, 29.5, 30)
    R = V / abs(w)
    centre = np.array([0.0, np.sign(w) * R])  # starting north at the origin: the centre is on the inside
    b, o = base.state(t), off.state(t)
    np.testing.assert_allclose(np.hypot(*(b.position[:, :2] - centre).T), R, rtol=1e-6)
    np.testing.assert_allclose(np.hypot(*(o.position[:, :2] - centre).T), R - np.sign(w) * across, rtol=1e-6)
    speed = np.linalg.norm(o.velocity, axis=1)
    np.testing.assert_allclose(speed, V * (1.0 - across * w / V), rtol=1e-5)
    np.testing.assert_allclose(o.position[:, 2], b.position[:, 2], atol=1e-9)


def test_velocity_is_the_derivative_of_position():
    """On an S-turn with climb, the returned velocity matches a fine central difference of the returned positions."""
    base = Maneuvering.s_turn_climb([0.0, 0.0, -1000.0], 60.0, 0.2, 60.0)
    off = OffsetTrack(base, across=-200.0, up=25.0, dt=1e-3)
    t = np.linspace(2.0, 58.0, 40)
    h = 1e-2
    fd = (off.state(t + h).position - off.state(t - h).position) / (2 * h)
    np.testing.assert_allclose(off.state(t).velocity, fd, atol=2e-3)


def test_times_keep_their_shape():
    """state() of (2, 3) times gives (2, 3, 3) positions and velocities and (2, 3, 4) quaternions."""
    off = OffsetTrack(StraightLevel([0.0, 0.0, -100.0], 40.0, 0.0, 5.0), 10.0, 1.0)
    st = off.state(np.full((2, 3), 1.5))
    assert st.position.shape == st.velocity.shape == (2, 3, 3) and st.quaternion.shape == (2, 3, 4)


@pytest.mark.parametrize("across, up", [(float("nan"), 0.0), (0.0, float("inf")), (-float("inf"), 1.0)])
def test_non_finite_offsets_are_config_errors(across, up):
    """A non-finite offset is one ConfigError naming scene.reference_offset_m."""
    base = StraightLevel([0.0, 0.0, -100.0], 40.0, 0.0, 5.0)
    with pytest.raises(ConfigError) as err:
        OffsetTrack(base, across, up)
    assert err.value.field == "scene.reference_offset_m" and "must be finite" in str(err.value)
    assert "\n" not in str(err.value)
