"""Shuster scalar-last quaternions (Pogorelsky et al. eqs. 4-7, 29, 41) mapped onto sarnav's scalar-first Hamilton
convention (end of rotations.py): claim T2 of extraction seed-002."""

import numpy as np

from sarnav.rotations import (hamilton_to_shuster, quat_multiply, quat_normalize, quat_to_dcm, rotvec_to_quat,
                              shuster_dcm, shuster_error_quaternion, shuster_product, shuster_to_hamilton, skew)

RNG = np.random.default_rng(3)


def _random_shuster(n):
    return quat_normalize(RNG.normal(size=(n, 4)))


def test_t2_shuster_product_composes_dcms():
    p, q = _random_shuster(50), _random_shuster(50)
    assert np.allclose(shuster_dcm(shuster_product(p, q)), shuster_dcm(p) @ shuster_dcm(q), atol=1e-14)
    # Hamilton's product in the SAME scalar-last storage composes the other way round (eq. 5's remark)
    ham_same_storage = hamilton_to_shuster(quat_multiply(shuster_to_hamilton(q), shuster_to_hamilton(p)))
    assert not np.allclose(shuster_dcm(ham_same_storage), shuster_dcm(p) @ shuster_dcm(q), atol=1e-3)


def test_mapping_keeps_dcm_and_is_a_homomorphism():
    p, q = _random_shuster(50), _random_shuster(50)
    assert np.allclose(shuster_dcm(q), quat_to_dcm(shuster_to_hamilton(q)), atol=1e-14)
    assert np.allclose(shuster_to_hamilton(shuster_product(p, q)),
                       quat_multiply(shuster_to_hamilton(p), shuster_to_hamilton(q)), atol=1e-14)
    assert np.allclose(hamilton_to_shuster(shuster_to_hamilton(q)), q)
    # eq. 6 is orthonormal with det +1
    T = shuster_dcm(q)
    assert np.allclose(T @ np.swapaxes(T, -1, -2), np.eye(3), atol=1e-14)
    assert np.allclose(np.linalg.det(T), 1.0)


def test_eq29_small_angle_and_eq41():
    for scale in (1e-2, 1e-3, 1e-4):
        dmu = RNG.normal(size=(20, 3)) * scale
        dq = shuster_error_quaternion(dmu)
        assert np.allclose(np.linalg.norm(dq, axis=-1), 1.0)
        err = np.max(np.abs(shuster_dcm(dq) - (np.eye(3) - skew(dmu))))
        assert err < 2.0 * (3 * scale) ** 2  # O(dmu^2): second-order remainder, shrinking 100x per decade
        assert err > 1e-3 * scale**2
    # eq. 41 literally (scalar last) and its Hamilton image rotvec_to_quat(-dmu)
    dmu = np.array([0.3, -0.2, 0.1])
    a = np.linalg.norm(dmu)
    lit = np.concatenate([dmu / a * np.sin(a / 2), [np.cos(a / 2)]])
    assert np.allclose(shuster_error_quaternion(dmu), lit)
    assert np.allclose(shuster_to_hamilton(lit), rotvec_to_quat(-dmu))
    assert np.allclose(shuster_error_quaternion(np.zeros(3)), [0, 0, 0, 1])
