"""Truth trajectories: p, v, q, nu^b, omega^b mutually consistent (central differences)."""

import numpy as np
import pytest
from scipy.integrate import quad

from sarnav.errors import ConfigError, InputDataError
from sarnav.frames import GRAVITY_NED
from sarnav.rotations import quat_multiply, quat_to_dcm, quat_to_euler
from sarnav.trajectory import Maneuvering, RateProfile, StraightLevel

H = 1e-3  # central-difference step [s]; truncation error ~ H^2/6 * third derivative


def _trajectories():
    return [
        StraightLevel([0.0, -200.0, -500.0], 50.0, np.radians(30.0), 60.0),
        Maneuvering.s_turn_climb([0.0, -200.0, -500.0], 50.0, 0.3, 60.0),
    ]


@pytest.mark.parametrize("traj", _trajectories(), ids=["straight", "maneuver"])
def test_kinematic_consistency(traj):
    t = np.linspace(0.01, traj.duration - 0.01, 700)
    s, sp, sm = traj.state(t), traj.state(t + H), traj.state(t - H)
    # p_dot = v
    np.testing.assert_allclose((sp.position - sm.position) / (2 * H), s.velocity, atol=2e-6)
    # v_dot = a^n = T nu^b + g^n  (thesis eq. 3.1)
    a_fd = (sp.velocity - sm.velocity) / (2 * H)
    np.testing.assert_allclose(a_fd, traj.acceleration(t), atol=2e-6)
    f_n = np.einsum("...ij,...j->...i", quat_to_dcm(s.quaternion), traj.specific_force(t))
    np.testing.assert_allclose(f_n + GRAVITY_NED, a_fd, atol=2e-6)
    # q_dot = 1/2 q (x) [0; omega^b]
    qd = (sp.quaternion - sm.quaternion) / (2 * H)
    w = np.concatenate([np.zeros((t.size, 1)), traj.angular_rate(t)], axis=-1)
    np.testing.assert_allclose(qd, 0.5 * quat_multiply(s.quaternion, w), atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(s.quaternion, axis=-1), 1.0, atol=1e-14)


def test_straight_level_closed_form():
    traj = StraightLevel([10.0, 20.0, -500.0], 50.0, np.radians(90.0), 30.0)
    s = traj.state(np.array([0.0, 10.0]))
    np.testing.assert_allclose(s.position[1], [10.0, 520.0, -500.0], atol=1e-9)
    np.testing.assert_allclose(traj.specific_force(5.0), [0.0, 0.0, -9.81], atol=1e-12)
    np.testing.assert_allclose(traj.angular_rate(5.0), 0.0, atol=1e-15)
    roll, pitch, yaw = quat_to_euler(s.quaternion[0])
    assert abs(roll) < 1e-15 and abs(pitch) < 1e-15 and yaw == pytest.approx(np.pi / 2)


def test_maneuver_position_against_adaptive_quadrature():
    traj = Maneuvering.s_turn_climb([0.0, 0.0, -500.0], 50.0, 0.0, 60.0)
    for t in (7.3, 19.99, 33.3, 45.0, 60.0):
        psi = lambda s: traj.heading + traj.turn_rate.integral(s)  # noqa: E731
        n = quad(lambda s: 50.0 * np.cos(psi(s)), 0.0, t, epsabs=1e-12, limit=200)[0]
        e = quad(lambda s: 50.0 * np.sin(psi(s)), 0.0, t, epsabs=1e-12, limit=200)[0]
        h = quad(lambda s: traj.climb_rate.rate(s), 0.0, t, epsabs=1e-12, limit=200)[0]
        np.testing.assert_allclose(traj.state(t).position, [n, e, -500.0 - h], atol=1e-8)


def test_maneuver_really_turns_and_climbs():
    traj = Maneuvering.s_turn_climb([0.0, 0.0, -500.0], 50.0, 0.0, 60.0)
    # heading after the right turn (10 s to 20 s at 3 deg/s, transitions symmetric) = 30 deg
    _, _, yaw = quat_to_euler(traj.state(25.0).quaternion)
    assert np.degrees(yaw) == pytest.approx(30.0, abs=1e-9)
    # climb 3 m/s for 10 s then descend 3 m/s for 10 s: back to 500 m
    assert traj.state(60.0).position[2] == pytest.approx(-500.0, abs=1e-9)
    # at 30 s: 3 m/s held from 20 s, minus half the 4 s transition: 3 * (10 - 2) = 24 m
    assert traj.state(30.0).position[2] == pytest.approx(-524.0, abs=1e-9)
    # coordinated bank in the steady turn: tan(phi) = V psi_dot / g
    roll, _, _ = quat_to_euler(traj.state(15.0).quaternion)
    assert np.tan(roll) == pytest.approx(50.0 * np.radians(3.0) / 9.81, rel=1e-12)


def test_rate_profile_integral_matches_rate():
    prof = RateProfile((0.0, 5.0, 12.0), (1.0, -2.0, 0.5), 3.0)
    t = np.linspace(0.0, 20.0, 9)
    ref = [quad(prof.rate, 0.0, x, epsabs=1e-13)[0] for x in t]
    np.testing.assert_allclose(prof.integral(t), ref, atol=1e-11)
    tt = np.linspace(0.1, 19.9, 50)
    np.testing.assert_allclose(prof.rate_derivative(tt), (prof.rate(tt + 1e-5) - prof.rate(tt - 1e-5)) / 2e-5, atol=1e-8)


def test_bad_inputs_name_the_field():
    with pytest.raises(ConfigError, match="trajectory.speed"):
        StraightLevel([0, 0, 0], -1.0, 0.0, 10.0)
    with pytest.raises(ConfigError, match="trajectory.start_ned"):
        StraightLevel([0, np.nan, 0], 50.0, 0.0, 10.0)
    with pytest.raises(ConfigError, match="trajectory.duration"):
        StraightLevel([0, 0, 0], 50.0, 0.0, 0.0)
    with pytest.raises(ConfigError, match="rate_profile.transition"):
        RateProfile((0.0, 5.0), (0.0, 1.0), 0.0)
    traj = StraightLevel([0, 0, 0], 50.0, 0.0, 10.0)
    with pytest.raises(InputDataError, match="t"):
        traj.state(11.0)
    with pytest.raises(InputDataError, match="t"):
        traj.state(np.nan)
