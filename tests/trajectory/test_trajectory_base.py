"""The trajectory contract (``sarnav.trajectory.base``): the time check every trajectory applies, the Coriolis and
Earth-rate terms added to the body-frame outputs, and the validation of a straight track's parameters."""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.trajectory.base import Trajectory, TrajectoryState, set_track
from sarnav.trajectory.straight import StraightLevel


class _Still(Trajectory):
    """A vehicle flying north at 10 m/s, level, attitude identity: body = NED."""

    duration = 5.0

    def state(self, t):
        t = self._times(t)
        return TrajectoryState(np.zeros(t.shape + (3,)), np.broadcast_to([10.0, 0, 0], t.shape + (3,)),
                               np.broadcast_to([1.0, 0, 0, 0], t.shape + (4,)))

    def _kin(self, t):
        v = np.broadcast_to([10.0, 0.0, 0.0], t.shape + (3,))
        q = np.broadcast_to([1.0, 0.0, 0.0, 0.0], t.shape + (4,))
        nu = np.broadcast_to([0.0, 0.0, -9.81], t.shape + (3,))
        return v, q, np.zeros(t.shape + (3,)), nu, np.zeros(t.shape + (3,))


def test_times_outside_the_trajectory_are_refused():
    traj = _Still()
    traj.state(np.array([0.0, 5.0]))
    with pytest.raises(InputDataError, match=r"\[0, 5.0\]"):
        traj.state(np.array([5.1]))
    with pytest.raises(InputDataError, match="finite"):
        traj.acceleration(np.array([np.nan]))


def test_earth_rate_adds_coriolis_and_the_inertial_rate():
    """nu^b + T^T (2 w x v) and omega^b + T^T w with T = I: closed form for v = 10 m/s north."""
    traj, w = _Still(), np.array([7e-5, 0.0, -3e-5])
    t = np.array([1.0])
    np.testing.assert_allclose(traj.specific_force(t, w)[0], [0, 0, -9.81] + np.cross(2 * w, [10.0, 0, 0]),
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(traj.angular_rate(t, w)[0], w, rtol=0, atol=0)
    np.testing.assert_array_equal(traj.specific_force(t), [[0, 0, -9.81]])


def test_set_track_names_the_bad_key():
    traj = StraightLevel([0.0, 0.0, -1000.0], 10.0, 0.0, 5.0)
    set_track(traj, [1.0, 2.0, -3.0], 20.0, 0.5, 7.0)
    assert np.array_equal(traj.start, [1.0, 2.0, -3.0]) and traj.speed == 20.0 and traj.duration == 7.0
    with pytest.raises(ConfigError, match="trajectory.start_ned"):
        set_track(traj, [0.0, 0.0], 10.0, 0.0, 5.0)
    with pytest.raises(ConfigError, match="trajectory.speed"):
        set_track(traj, [0.0, 0.0, 0.0], 0.0, 0.0, 5.0)
    with pytest.raises(ConfigError, match="trajectory.heading"):
        set_track(traj, [0.0, 0.0, 0.0], 10.0, 7.0, 5.0)
    with pytest.raises(ConfigError, match="trajectory.duration"):
        set_track(traj, [0.0, 0.0, 0.0], 10.0, 0.0, -1.0)
