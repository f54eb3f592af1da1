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


# --- Sun (2022) T1 and T2 (issue 29): the source's printed matrices, element by element -----------------------------

def _sun_c_bn(phi, theta, psi):
    """(2.34)-(2.42) as printed (L426-442), in the source's own symbols."""
    c, s = np.cos, np.sin
    return np.array([[c(phi) * c(theta), c(phi) * s(theta) * s(psi) - c(psi) * s(phi),
                      s(phi) * s(psi) + c(phi) * c(psi) * s(theta)],
                     [c(theta) * s(phi), c(phi) * c(psi) + s(phi) * s(theta) * s(psi),
                      c(psi) * s(phi) * s(theta) - c(phi) * s(psi)],
                     [-s(theta), c(theta) * s(psi), c(theta) * c(psi)]])


def _sun_c_xyz(theta, phi, psi):
    """(2.13)-(2.21) as printed (L374-396), labelled C_xyz = C_x C_y C_z with theta inside C_x and phi inside C_y."""
    c, s = np.cos, np.sin
    return np.array([[c(phi) * c(psi), -c(theta) * s(psi) + s(theta) * s(phi) * c(psi),
                      s(theta) * s(psi) + c(theta) * c(psi) * s(phi)],
                     [c(phi) * s(psi), c(theta) * c(psi) + s(theta) * s(phi) * s(psi),
                      -s(theta) * c(psi) + c(theta) * s(phi) * s(psi)],
                     [-s(phi), c(phi) * s(theta), c(theta) * c(phi)]])


def _cx(a):
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def _cy(a):
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _cz(a):
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def test_sun_t1_the_printed_c_bn_is_the_zyx_dcm_with_yaw_phi_and_roll_psi():
    """Sun T1: (2.34)-(2.42) equal sarnav's body-to-NED DCM Rz(yaw) Ry(pitch) Rx(roll) with yaw = phi, pitch = theta,
    roll = psi (the source names phi roll and psi yaw, L474: its printed matrix swaps them); orthonormal, det +1,
    identity at zero."""
    rng = np.random.default_rng(2022)
    for phi, theta, psi in rng.uniform(-np.pi, np.pi, (50, 3)) * np.array([1.0, 0.49, 1.0]):
        printed = _sun_c_bn(phi, theta, psi)
        np.testing.assert_allclose(rot.euler_to_dcm(psi, theta, phi), printed, atol=1e-15)
        np.testing.assert_allclose(printed @ printed.T, np.eye(3), atol=1e-15)
        assert np.linalg.det(printed) == pytest.approx(1.0, abs=1e-14)
        assert not np.allclose(rot.euler_to_dcm(phi, theta, psi), printed, atol=1e-6)  # the stated naming does not hold
    np.testing.assert_allclose(_sun_c_bn(0.0, 0.0, 0.0), np.eye(3), atol=0)


def test_sun_t2_the_printed_c_xyz_is_c_z_c_y_c_x():
    """Sun T2: the elements printed as C_xyz = C_x(theta) C_y(phi) C_z(psi) are C_z(psi) C_y(phi) C_x(theta), the ZYX
    product; (2.24)-(2.32), printed as C_zyx, are that same matrix (but for (2.25)'s typo)."""
    rng = np.random.default_rng(13)
    for theta, phi, psi in rng.uniform(-np.pi, np.pi, (50, 3)):
        printed = _sun_c_xyz(theta, phi, psi)
        np.testing.assert_allclose(printed, _cz(psi) @ _cy(phi) @ _cx(theta), atol=1e-15)
        assert not np.allclose(printed, _cx(theta) @ _cy(phi) @ _cz(psi), atol=1e-6)
