"""Lever arms between IMUs on one rigid body (multi-IMU rigs, Sun 2022 §5; Bancroft & Lachapelle 2011).

An IMU at body-frame offset ``r`` from the reference point of a rigid body senses (all vectors in body axes,
IMU axes aligned with the body)::

    f_r = f_ref + omega_dot x r + omega x (omega x r)        (Euler and centripetal terms)
    omega_r = omega                                          (one rigid body, one rate)

with omega = omega_ib^b the inertial rate and omega_dot its derivative; its position and velocity are
``p_r = p_ref + C_b^n r`` and ``v_r = v_ref + C_b^n (omega_eb^b x r)`` (omega_eb^b = omega_ib^b - C_n^b omega_ie^n,
about omega_nb^b for an aircraft). Fusion translates each IMU's estimate back to the reference point with
:func:`offset_position`.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import InputDataError


def _vec3(name, a):
    a = np.asarray(a, dtype=float)
    if a.shape[-1:] != (3,):
        raise InputDataError(name, f"must end in a 3-vector axis, got shape {a.shape}")
    return a


def lever_arm_specific_force(f_ref, omega, omega_dot, r):
    """Specific force (..., 3) [m/s^2] at body offset ``r`` (..., 3) [m] from the reference point, given the
    reference specific force, inertial body rate [rad/s] and its derivative [rad/s^2] (module docstring)."""
    f_ref, omega, omega_dot, r = (_vec3(n, a) for n, a in
                                  (("f_ref", f_ref), ("omega", omega), ("omega_dot", omega_dot), ("lever_arm", r)))
    return f_ref + np.cross(omega_dot, r) + np.cross(omega, np.cross(omega, r))


def offset_position(p_ref_ned, C_bn, r):
    """Position (..., 3) of the point at body offset ``r`` [m]: ``p_ref + C_b^n r`` (NED metres)."""
    return _vec3("p_ref", p_ref_ned) + np.einsum("...ij,...j->...i", np.asarray(C_bn, dtype=float), _vec3("lever_arm", r))


def offset_velocity(v_ref_ned, C_bn, omega_eb_b, r):
    """Velocity (..., 3) of the point at body offset ``r``: ``v_ref + C_b^n (omega_eb^b x r)`` [m/s]."""
    return _vec3("v_ref", v_ref_ned) + np.einsum("...ij,...j->...i", np.asarray(C_bn, dtype=float),
                                                 np.cross(_vec3("omega", omega_eb_b), _vec3("lever_arm", r)))


def rate_derivative(omega, dt: float):
    """omega_dot (..., M, 3) of rate samples (..., M, 3) every ``dt`` s by central differences (one-sided at
    the ends); what a rig's processor can compute from its own gyro samples."""
    omega = _vec3("omega", omega)
    if omega.shape[-2] < 3:
        raise InputDataError("omega", "need at least 3 samples to differentiate")
    return np.gradient(omega, dt, axis=-2, edge_order=2)
