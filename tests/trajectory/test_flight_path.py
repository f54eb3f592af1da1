"""``trajectory.flight_path.path_kinematics``: the attitude and inertial quantities of a flight path against closed
forms (level flight, steady climb, coordinated turn) and against the kinematic equation q_dot = 1/2 q (x) [0, omega]
evaluated by finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from sarnav.frames import GRAVITY_NED
from sarnav.rotations import quat_multiply, quat_to_dcm
from sarnav.trajectory.flight_path import path_kinematics

G = float(GRAVITY_NED[2])


@pytest.mark.parametrize("psi", [0.0, 0.7, -2.5])
def test_straight_level_flight_senses_only_gravity(psi):
    """Level, straight: v = V (cos psi, sin psi, 0), a = 0, nu^b = (0, 0, -g), omega = 0, body x along v."""
    V = 55.0
    vel, q, acc, nu, om = path_kinematics(V, psi, 0.0, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(vel, [V * np.cos(psi), V * np.sin(psi), 0.0], atol=1e-12)
    np.testing.assert_allclose(acc, 0.0, atol=1e-12)
    np.testing.assert_allclose(nu, [0.0, 0.0, -G], atol=1e-12)
    np.testing.assert_allclose(om, 0.0, atol=1e-15)
    np.testing.assert_allclose(quat_to_dcm(q)[:, 0], vel / V, atol=1e-12)  # nose along the velocity
    np.testing.assert_allclose(np.linalg.norm(q), 1.0, atol=1e-14)


def test_steady_climb_pitches_by_the_flight_path_angle():
    """Constant climb rate hdot: pitch gamma = atan(hdot/V), v_D = -hdot, nu^b = g (sin gamma, 0, -cos gamma)."""
    V, hdot = 40.0, 5.0
    gam = np.arctan2(hdot, V)
    vel, q, acc, nu, om = path_kinematics(V, 0.0, 0.0, 0.0, hdot, 0.0)
    np.testing.assert_allclose(vel, [V, 0.0, -hdot], atol=1e-12)
    np.testing.assert_allclose(nu, [G * np.sin(gam), 0.0, -G * np.cos(gam)], atol=1e-12)
    T = quat_to_dcm(q)
    np.testing.assert_allclose(T[:, 0], vel / np.linalg.norm(vel), atol=1e-12)
    np.testing.assert_allclose(om, 0.0, atol=1e-15)


@pytest.mark.parametrize("psi_dot", [np.radians(3.0), -np.radians(6.0)])
def test_coordinated_turn_has_no_side_force(psi_dot):
    """Level turn at rate psi_dot: centripetal a = V psi_dot, bank atan(V psi_dot / g), specific force purely along
    body -z with magnitude sqrt(g^2 + (V psi_dot)^2) (no side slip), body rate psi_dot about the NED vertical."""
    V, psi = 60.0, 0.3
    vel, q, acc, nu, om = path_kinematics(V, psi, psi_dot, 0.0, 0.0, 0.0)
    a_c = V * psi_dot
    np.testing.assert_allclose(np.linalg.norm(acc), abs(a_c), rtol=1e-12)
    np.testing.assert_allclose(acc @ vel, 0.0, atol=1e-9)  # perpendicular to the velocity
    np.testing.assert_allclose(nu, [0.0, 0.0, -np.hypot(G, a_c)], atol=1e-12)
    T = quat_to_dcm(q)
    np.testing.assert_allclose(T @ om, [0.0, 0.0, psi_dot], atol=1e-14)  # omega^n = psi_dot e_D
    bank = np.arctan2(T[2, 1], T[2, 2])  # roll of the 3-2-1 sequence from C_b^n (right turn: right wing down)
    np.testing.assert_allclose(bank, np.arctan(a_c / G), atol=1e-12)


def test_body_rate_matches_the_attitude_derivative():
    """On a path with varying heading, climb and bank, omega^b equals 2 q^* (x) dq/dt (finite differences of the
    returned quaternions): the Euler-rate relation and the derivatives of roll and pitch are consistent."""
    V = 50.0
    t = np.linspace(0.0, 10.0, 2001)
    h = t[1] - t[0]
    psi = 0.4 * np.sin(0.3 * t)
    psi_d, psi_dd = 0.12 * np.cos(0.3 * t), -0.036 * np.sin(0.3 * t)
    hdot, hddot = 4.0 * np.sin(0.5 * t), 2.0 * np.cos(0.5 * t)
    _, q, _, _, om = path_kinematics(V, psi, psi_d, psi_dd, hdot, hddot)
    qdot = (q[2:] - q[:-2]) / (2 * h)
    conj = q[1:-1] * np.array([1.0, -1.0, -1.0, -1.0])
    om_fd = 2.0 * quat_multiply(conj, qdot)
    np.testing.assert_allclose(om_fd[:, 0], 0.0, atol=1e-6)
    np.testing.assert_allclose(om_fd[:, 1:], om[1:-1], atol=2e-6)


def test_acceleration_is_the_derivative_of_velocity():
    """a^n equals the finite-difference derivative of v^n along a turning, climbing path."""
    V = 30.0
    t = np.linspace(0.0, 5.0, 10001)
    h = t[1] - t[0]
    psi, psi_d = 0.2 * t**2, 0.4 * t
    hdot, hddot = np.sin(t), np.cos(t)
    vel, _, acc, _, _ = path_kinematics(V, psi, psi_d, 0.4, hdot, hddot)
    np.testing.assert_allclose((vel[2:] - vel[:-2]) / (2 * h), acc[1:-1], atol=1e-4)


def test_specific_force_is_acceleration_minus_gravity_in_body_axes():
    """nu^b = T^T (a^n - g^n) for arbitrary inputs (rotated back to NED with the returned attitude)."""
    rng = np.random.default_rng(4)
    args = [rng.uniform(20, 80, 7), rng.uniform(-3, 3, 7), rng.uniform(-0.1, 0.1, 7), rng.uniform(-0.01, 0.01, 7),
            rng.uniform(-5, 5, 7), rng.uniform(-1, 1, 7)]
    _, q, acc, nu, _ = path_kinematics(*args)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", quat_to_dcm(q), nu), acc - GRAVITY_NED, atol=1e-10)


def test_inputs_broadcast():
    """A scalar speed with (2, 3) headings gives (2, 3, 3) vectors and (2, 3, 4) quaternions."""
    psi = np.zeros((2, 3))
    vel, q, acc, nu, om = path_kinematics(20.0, psi, 0.0, 0.0, 0.0, 0.0)
    assert vel.shape == acc.shape == nu.shape == om.shape == (2, 3, 3) and q.shape == (2, 3, 4)
