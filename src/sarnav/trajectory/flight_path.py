"""Attitude, acceleration, specific force and body rate of an aircraft flying along a path.

Given horizontal speed ``V`` (constant), heading ``psi(t)`` and climb rate ``hdot(t)`` with their
derivatives, the vehicle points its nose along the velocity with a coordinated-turn bank:

* yaw ``psi``; pitch = flight-path angle ``gamma = atan2(hdot, V)``;
  roll ``phi = atan(V psi_dot / g)`` (bank of a level coordinated turn);
* ``v^n = [V cos psi, V sin psi, -hdot]``, ``a^n = [-V sin psi psi_dot, V cos psi psi_dot, -hddot]``;
* ``nu^b = T^T (a^n - g^n)`` (thesis eq. 3.1 rearranged);
* ``omega^b`` from the 3-2-1 Euler-angle rates (the standard kinematic relation, e.g. Farrell,
  *Aided Navigation*, eq. 2.74): ``[phi_dot - psi_dot sin th, th_dot cos phi + psi_dot sin phi cos th,
  -th_dot sin phi + psi_dot cos phi cos th]``.
"""

from __future__ import annotations

import numpy as np

from sarnav.frames import GRAVITY_NED
from sarnav.rotations import euler_to_dcm, euler_to_quat


def path_kinematics(speed, psi, psi_dot, psi_ddot, hdot, hddot):
    """Attitude and inertial quantities of the path (all inputs broadcast, shape (...)).

    Returns
    -------
    velocity (..., 3), quaternion q_b^n (..., 4), acceleration a^n (..., 3),
    specific force nu^b (..., 3), angular rate omega^b (..., 3).
    """
    g = GRAVITY_NED[2]
    speed, psi, psi_dot, psi_ddot, hdot, hddot = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (speed, psi, psi_dot, psi_ddot, hdot, hddot))
    )
    cpsi, spsi = np.cos(psi), np.sin(psi)
    vel = np.stack([speed * cpsi, speed * spsi, -hdot], -1)
    acc = np.stack([-speed * spsi * psi_dot, speed * cpsi * psi_dot, -hddot], -1)

    theta = np.arctan2(hdot, speed)
    theta_dot = speed * hddot / (speed**2 + hdot**2)
    lat = speed * psi_dot / g
    phi = np.arctan(lat)
    phi_dot = (speed * psi_ddot / g) / (1.0 + lat**2)

    q = euler_to_quat(phi, theta, psi)
    T = euler_to_dcm(phi, theta, psi)
    nu_b = np.einsum("...ji,...j->...i", T, acc - GRAVITY_NED)

    sphi, cphi = np.sin(phi), np.cos(phi)
    sth, cth = np.sin(theta), np.cos(theta)
    omega = np.stack(
        [
            phi_dot - psi_dot * sth,
            theta_dot * cphi + psi_dot * sphi * cth,
            -theta_dot * sphi + psi_dot * cphi * cth,
        ],
        -1,
    )
    return vel, q, acc, nu_b, omega
