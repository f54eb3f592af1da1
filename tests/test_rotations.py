import numpy as np
import pytest

from sarnav import rotations as rot
from sarnav import units


def _rand_quat(rng, n):
    return rot.quat_normalize(rng.standard_normal((n, 4)))


def test_dcm_of_product_is_product_of_dcms():
    rng = np.random.default_rng(1)
    q1, q2 = _rand_quat(rng, 50), _rand_quat(rng, 50)
    lhs = rot.quat_to_dcm(rot.quat_multiply(q1, q2))
    rhs = rot.quat_to_dcm(q1) @ rot.quat_to_dcm(q2)
    np.testing.assert_allclose(lhs, rhs, atol=1e-14)


def test_rotation_matches_sandwich_product():
    rng = np.random.default_rng(2)
    q = _rand_quat(rng, 20)
    v = rng.standard_normal((20, 3))
    pure = np.concatenate([np.zeros((20, 1)), v], axis=1)
    sandwich = rot.quat_multiply(rot.quat_multiply(q, pure), rot.quat_conjugate(q))[:, 1:]
    np.testing.assert_allclose(rot.quat_rotate(q, v), sandwich, atol=1e-14)


def test_dcm_quat_round_trip_and_euler_round_trip():
    rng = np.random.default_rng(3)
    q = _rand_quat(rng, 100)
    q = np.where(q[:, :1] < 0, -q, q)
    np.testing.assert_allclose(rot.dcm_to_quat(rot.quat_to_dcm(q)), q, atol=1e-12)
    roll, pitch, yaw = rng.uniform(-3, 3, 100), rng.uniform(-1.5, 1.5, 100), rng.uniform(-3, 3, 100)
    qe = rot.euler_to_quat(roll, pitch, yaw)
    np.testing.assert_allclose(rot.quat_to_dcm(qe), rot.euler_to_dcm(roll, pitch, yaw), atol=1e-14)
    r2, p2, y2 = rot.quat_to_euler(qe)
    np.testing.assert_allclose([r2, p2, y2], [roll, pitch, yaw], atol=1e-10)


def test_skew_is_cross_product():
    rng = np.random.default_rng(4)
    a, b = rng.standard_normal((2, 10, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", rot.skew(a), b), np.cross(a, b), atol=1e-15)


def test_rotvec_round_trip_and_small_angle():
    rng = np.random.default_rng(5)
    phi = rng.standard_normal((30, 3))
    np.testing.assert_allclose(rot.quat_to_rotvec(rot.rotvec_to_quat(phi)), phi, atol=1e-12)
    tiny = np.array([1e-10, -2e-10, 3e-10])
    np.testing.assert_allclose(rot.rotvec_to_quat(tiny), [1, 0.5e-10, -1e-10, 1.5e-10], atol=1e-20)


def test_attitude_error_convention_first_order():
    """T_true = (I - [dtheta x]) T_est to second order (thesis eq. 4.9)."""
    rng = np.random.default_rng(6)
    q_est = _rand_quat(rng, 10)
    dth = 1e-4 * rng.standard_normal((10, 3))
    q_true = rot.apply_attitude_error(q_est, dth)
    T_lin = (np.eye(3) - rot.skew(dth)) @ rot.quat_to_dcm(q_est)
    assert np.max(np.abs(rot.quat_to_dcm(q_true) - T_lin)) < 1e-7
    np.testing.assert_allclose(rot.attitude_error(q_true, q_est), dth, rtol=1e-7, atol=1e-14)


def test_table_a2_attitude_entry():
    """Thesis Table A.2: m(q=[1,0,0,0], dtheta=(0.018,0.021,0.020)) = (0.99990, 0.0090, 0.0105, 0.0100)."""
    q = rot.corrupt_attitude(np.array([1.0, 0, 0, 0]), np.array([0.018, 0.021, 0.020]))
    np.testing.assert_allclose(q, [0.99990, 0.0090, 0.0105, 0.0100], atol=5e-5)


def test_units():
    assert units.three_sigma_to_sigma(0.3) == pytest.approx(0.1)
    assert units.deg_per_hr_to_rad_per_s(1.0) == pytest.approx(np.pi / 180 / 3600)
    assert units.m_per_s_per_sqrt_hr_to_si(0.06) == pytest.approx(0.001)
    assert units.g_to_m_per_s2(0.001) == pytest.approx(0.00981)
    assert units.deg_per_sqrt_hr_to_rad_per_sqrt_s(60.0) == pytest.approx(np.pi / 180)
