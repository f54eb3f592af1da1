"""Lever arms between IMUs on one rigid body: centripetal and Euler terms (GTSAM ScenarioRunner check) and an
independent finite-difference check on a maneuvering trajectory."""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.sensors.lever_arm import lever_arm_specific_force, offset_position, offset_velocity, rate_derivative


def test_lever_arm_centripetal_and_euler_terms():
    """GTSAM ScenarioRunner check: omega = 2 rad/s about z, r = 1 m along x -> -4 m/s^2 along x; an angular
    acceleration of 1 rad/s^2 about z adds +1 m/s^2 along y."""
    f = lever_arm_specific_force(np.zeros(3), [0.0, 0.0, 2.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(f, [-4.0, 1.0, 0.0], atol=1e-15)


def test_lever_arm_matches_differentiated_offset_trajectory():
    """An IMU 0.5 m off the reference of a maneuvering aircraft (flat world, omega_ib = omega_nb): its specific
    force from lever_arm_specific_force equals C^T (d2/dt2 (p + C r) - g) by finite differences."""
    from sarnav.frames import GRAVITY_NED
    from sarnav.rotations import quat_to_dcm
    from sarnav.trajectory import Maneuvering

    traj = Maneuvering.s_turn_climb([0.0, 0.0, -500.0], 60.0, 0.0, 60.0)
    r = np.array([0.3, -0.5, 0.2])
    h, t0 = 1e-3, 12.3  # inside the right turn's transition (angular acceleration non-zero)
    t = t0 + h * np.arange(-2, 3)
    s = traj.state(t)
    p = offset_position(s.position, quat_to_dcm(s.quaternion), r)
    acc = (-p[4] + 16 * p[3] - 30 * p[2] + 16 * p[1] - p[0]) / (12 * h * h)
    want = quat_to_dcm(s.quaternion[2]).T @ (acc - GRAVITY_NED)
    w = traj.angular_rate(t)
    got = lever_arm_specific_force(traj.specific_force(t0), w[2], rate_derivative(w, h)[2], r)
    np.testing.assert_allclose(got, want, atol=2e-5)
    assert np.linalg.norm(got - traj.specific_force(t0)) > 1e-3  # the lever-arm terms matter here



def test_offset_velocity_is_the_derivative_of_offset_position():
    from sarnav.rotations import quat_to_dcm
    from sarnav.trajectory import Maneuvering

    traj = Maneuvering.s_turn_climb([0.0, 0.0, -500.0], 60.0, 0.0, 60.0)
    r, h, t0 = np.array([0.3, -0.5, 0.2]), 1e-4, 12.3
    s = traj.state(np.array([t0 - h, t0, t0 + h]))
    p = offset_position(s.position, quat_to_dcm(s.quaternion), r)
    v = offset_velocity(s.velocity[1], quat_to_dcm(s.quaternion[1]), traj.angular_rate(t0), r)
    np.testing.assert_allclose(v, (p[2] - p[0]) / (2 * h), atol=1e-6)


def test_bad_lever_arm_shapes_are_named():
    with pytest.raises(InputDataError, match="lever_arm"):
        lever_arm_specific_force(np.zeros(3), np.zeros(3), np.zeros(3), [1.0, 2.0])
    with pytest.raises(InputDataError, match="omega"):
        rate_derivative(np.zeros((2, 3)), 0.01)
