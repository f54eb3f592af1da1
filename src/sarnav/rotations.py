"""Quaternions, direction-cosine matrices, Euler angles and the skew operator.

Convention (docs/conventions.md; thesis §2.2 of the extraction, eqs. 4.8-4.9, A.4-A.6):

* quaternions are scalar first, ``q = [w, x, y, z]``, Hamilton product (thesis L1985)
  ``[r; s] (x) [q; t] = [r q - s.t ; r t + q s + s x t]``;
* ``q_b^n`` rotates body vectors into the navigation frame, ``v^n = q (x) [0; v^b] (x) q*``,
  and ``dcm(q1 (x) q2) = dcm(q1) @ dcm(q2)``;
* kinematics ``q_dot = 1/2 q (x) [0; omega_b]``;
* attitude error ``T_true = (I - [dtheta x]) T_est`` i.e. ``q = [1; -dtheta/2] (x) q_est``.

All functions accept stacked inputs: a leading batch shape ``(..., 4)`` / ``(..., 3)``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def skew(v):
    """Cross-product matrix: ``skew(a) @ b == cross(a, b)``. Shape (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack(
        [np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2
    )


def quat_multiply(q1, q2):
    """Hamilton product q1 (x) q2, scalar first."""
    q1 = np.asarray(q1, dtype=float)
    q2 = np.asarray(q2, dtype=float)
    r, s = q1[..., :1], q1[..., 1:]
    q, t = q2[..., :1], q2[..., 1:]
    scal = r * q - np.sum(s * t, axis=-1, keepdims=True)
    vec = r * t + q * s + np.cross(s, t)
    return np.concatenate([scal, vec], axis=-1)


def quat_conjugate(q):
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def quat_normalize(q):
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_identity(shape=()):
    q = np.zeros(tuple(np.atleast_1d(shape)) + (4,) if shape != () else (4,))
    q[..., 0] = 1.0
    return q


def quat_to_dcm(q):
    """DCM T such that v^n = T v^b for q = q_b^n (Hamilton, scalar first)."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    return np.stack(
        [
            np.stack([ww + xx - yy - zz, 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), ww - xx + yy - zz, 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), ww - xx - yy + zz], -1),
        ],
        -2,
    )


def dcm_to_quat(T):
    """Inverse of :func:`quat_to_dcm`; returns the quaternion with non-negative scalar part.

    ``scipy.spatial.transform.Rotation`` (Hamilton, same DCM as :func:`quat_to_dcm`) does the work.
    """
    T = np.asarray(T, dtype=float)
    q = np.roll(Rotation.from_matrix(T.reshape((-1, 3, 3))).as_quat(), 1, axis=-1)  # [x,y,z,w] -> [w,x,y,z]
    q = np.where(q[:, :1] < 0, -q, q)
    return q.reshape(T.shape[:-2] + (4,))


def quat_rotate(q, v):
    """Rotate body vector(s) v into the navigation frame: dcm(q) @ v."""
    return np.einsum("...ij,...j->...i", quat_to_dcm(q), np.asarray(v, dtype=float))


def rotvec_to_quat(phi):
    """Quaternion of a rotation vector phi (axis * angle): [cos(|phi|/2); sin(|phi|/2) phi/|phi|]."""
    phi = np.asarray(phi, dtype=float)
    ang = np.linalg.norm(phi, axis=-1, keepdims=True)
    half = 0.5 * ang
    # sin(x/2)/x, with its Taylor series near zero
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(ang > 1e-8, np.sin(half) / np.where(ang > 0, ang, 1.0), 0.5 - ang**2 / 48.0)
    return np.concatenate([np.cos(half), k * phi], axis=-1)


def quat_to_rotvec(q):
    q = quat_normalize(q)
    q = np.where(q[..., :1] < 0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    ang = 2.0 * np.arctan2(s, q[..., :1])
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(s > 1e-12, ang / np.where(s > 0, s, 1.0), 2.0)
    return k * q[..., 1:]


def euler_to_dcm(roll, pitch, yaw):
    """Body-to-NED DCM from 3-2-1 (yaw, pitch, roll) Euler angles: T = Rz(yaw) Ry(pitch) Rx(roll)."""
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (roll, pitch, yaw)))
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.stack(
        [
            np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], -1),
            np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], -1),
            np.stack([-sp, cp * sr, cp * cr], -1),
        ],
        -2,
    )


def dcm_to_euler(T):
    """(roll, pitch, yaw) of a body-to-NED DCM, 3-2-1 sequence."""
    T = np.asarray(T, dtype=float)
    roll = np.arctan2(T[..., 2, 1], T[..., 2, 2])
    pitch = -np.arcsin(np.clip(T[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(T[..., 1, 0], T[..., 0, 0])
    return roll, pitch, yaw


def euler_to_quat(roll, pitch, yaw):
    """q_b^n for 3-2-1 Euler angles (Hamilton, scalar first)."""
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (roll, pitch, yaw)))
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.stack(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ],
        -1,
    )


def quat_to_euler(q):
    return dcm_to_euler(quat_to_dcm(q))


# --- attitude error mappings (thesis App. A, eqs. A.4-A.6) -------------------------------

def attitude_error(q_true, q_est):
    """n(): delta-theta from truth and estimate, dtheta = -2 (q (x) q_est*)_{2:4} (eq. A.6).

    Defined so that T_true = (I - [dtheta x]) T_est to first order (eq. 4.9).
    """
    dq = quat_multiply(q_true, quat_conjugate(q_est))
    dq = np.where(dq[..., :1] < 0, -dq, dq)
    return -2.0 * dq[..., 1:]


def apply_attitude_error(q_est, dtheta):
    """l(): truth from estimate and error, q = [1; -dtheta/2] (x) q_est, normalised (eq. A.4)."""
    dtheta = np.asarray(dtheta, dtype=float)
    dq = np.concatenate([np.ones(dtheta.shape[:-1] + (1,)), -0.5 * dtheta], axis=-1)
    return quat_normalize(quat_multiply(dq, q_est))


def corrupt_attitude(q_true, dtheta):
    """m(): estimate from truth and error, q_est = [1; +dtheta/2] (x) q, normalised (eq. A.5)."""
    dtheta = np.asarray(dtheta, dtype=float)
    dq = np.concatenate([np.ones(dtheta.shape[:-1] + (1,)), 0.5 * dtheta], axis=-1)
    return quat_normalize(quat_multiply(dq, q_true))


# --- Shuster scalar-last quaternions (Pogorelsky et al. 2022, eqs. 4-7, 29, 41) ---------------------------------
#
# The spacecraft source writes q_a^b = [q_v; q_s] (scalar LAST, eq. 4), composes with Shuster's product (eq. 5)
#     p (x)_S q = [p_s q_v + q_s p_v - p_v x q_v ; p_s q_s - p_v . q_v]
# and maps a quaternion to the passive DCM (eq. 6) T(q) = (q_s^2 - q_v.q_v) I + 2 q_v q_v^T - 2 q_s [q_v x],
# v^b = T(q_a^b) v^a. The ONE mapping onto sarnav's scalar-first Hamilton convention is
#     shuster_to_hamilton([q_v; q_s]) = [q_s; -q_v]
# It keeps the DCM, shuster_dcm(q) == quat_to_dcm(shuster_to_hamilton(q)), so the Hamilton quaternion "rotates a-frame
# vectors into b" exactly as q_b^n does for body -> nav, and it is a homomorphism:
#     shuster_to_hamilton(p (x)_S q) = shuster_to_hamilton(p) (x)_H shuster_to_hamilton(q),
# hence T(p (x)_S q) = T(p) T(q) in both conventions (claim T2). The paper's error quaternion (eq. 41)
# dq = [dmu/|dmu| sin(|dmu|/2); cos(|dmu|/2)] maps to rotvec_to_quat(-dmu), and T(dq) = I - [dmu x] + O(dmu^2)
# (eq. 29): the same small-angle convention as attitude_error / apply_attitude_error above.


def shuster_to_hamilton(q):
    """[q_v; q_s] (Shuster, scalar last) -> [q_s; -q_v] (Hamilton, scalar first); same DCM. Shape (..., 4)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 3:], -q[..., :3]], axis=-1)


def hamilton_to_shuster(q):
    """Inverse of :func:`shuster_to_hamilton`: [w; x] -> [-x; w]."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([-q[..., 1:], q[..., :1]], axis=-1)


def shuster_product(p, q):
    """Shuster's (passive) product p (x)_S q of scalar-last quaternions (paper eq. 5)."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    pv, ps = p[..., :3], p[..., 3:]
    qv, qs = q[..., :3], q[..., 3:]
    vec = ps * qv + qs * pv - np.cross(pv, qv)
    scal = ps * qs - np.sum(pv * qv, axis=-1, keepdims=True)
    return np.concatenate([vec, scal], axis=-1)


def shuster_dcm(q):
    """Passive DCM of a scalar-last quaternion (paper eq. 6): (q_s^2 - q_v.q_v) I + 2 q_v q_v^T - 2 q_s [q_v x]."""
    q = np.asarray(q, dtype=float)
    qv, qs = q[..., :3], q[..., 3]
    a = (qs * qs - np.sum(qv * qv, axis=-1))[..., None, None]
    return a * np.eye(3) + 2.0 * qv[..., :, None] * qv[..., None, :] - 2.0 * qs[..., None, None] * skew(qv)


def shuster_error_quaternion(dmu):
    """Paper eq. 41: [dmu/|dmu| sin(|dmu|/2); cos(|dmu|/2)] (scalar last); the limit [dmu/2; 1] at dmu = 0."""
    return hamilton_to_shuster(rotvec_to_quat(-np.asarray(dmu, dtype=float)))
