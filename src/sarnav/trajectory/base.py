"""The truth-trajectory interface.

A :class:`Trajectory` gives the true kinematics of the vehicle as smooth functions of time, all
vectorised over ``t`` (any shape ``(...)``):

* :meth:`Trajectory.state` -> position ``p^n`` (..., 3) [m], velocity ``v^n`` (..., 3) [m/s],
  attitude ``q_b^n`` (..., 4) (Hamilton, scalar first, body -> NED);
* :meth:`Trajectory.specific_force` -> ``nu^b = T^T (a^n - g^n)`` (..., 3) [m/s^2] (thesis eq. 3.1);
* :meth:`Trajectory.angular_rate` -> ``omega^b`` (..., 3) [rad/s] with ``q_dot = 1/2 q (x) [0; omega^b]``.

The three are mutually consistent: they are what an ideal IMU on the vehicle would measure over the sources'
non-rotating Earth. With ``earth_rate = omega_ie^t`` (``frames.earth_rate_tangent``) the motion is read as relative
to an Earth-fixed tangent frame that turns at ``omega_ie^t``, and the ideal IMU senses the Earth's rotation too
(Groves 2008 eqs. 5.24/5.28 in a local tangent frame)::

    nu^b = T^T (a^t + 2 omega_ie^t x v^t - g^t),   omega_ib^b = omega^b + T^T omega_ie^t
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError, require_finite, require_positive
from sarnav.frames import earth_rate_or_zero
from sarnav.rotations import quat_to_dcm


@dataclass(frozen=True)
class TrajectoryState:
    """Truth position (..., 3) [m], velocity (..., 3) [m/s] and attitude q_b^n (..., 4)."""

    position: np.ndarray
    velocity: np.ndarray
    quaternion: np.ndarray


class Trajectory(ABC):
    """Truth motion of the vehicle in the NED tangent frame (``sarnav.frames``).

    Attributes
    ----------
    duration : float
        Length of the trajectory [s]; times outside ``[0, duration]`` are rejected.
    """

    duration: float

    def _times(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise InputDataError("t", "trajectory times must be finite")
        tol = 1e-9 * max(1.0, self.duration)
        if np.any(t < -tol) or np.any(t > self.duration + tol):
            raise InputDataError("t", f"must lie in [0, {self.duration}] s, got [{t.min()}, {t.max()}]")
        return t

    @abstractmethod
    def state(self, t) -> TrajectoryState:
        """Position, velocity and attitude q_b^n at times ``t`` (any shape)."""

    @abstractmethod
    def _kin(self, t) -> tuple:
        """``sarnav.trajectory.flight_path.path_kinematics`` at checked times ``t``: (velocity,
        quaternion, acceleration, specific force, angular rate)."""

    def acceleration(self, t) -> np.ndarray:
        """Kinematic acceleration a^n = dv^n/dt (..., 3) [m/s^2]."""
        return self._kin(self._times(t))[2]

    def specific_force(self, t, earth_rate=None) -> np.ndarray:
        """Specific force in the body frame nu^b = T^T (a^n - g^n) (..., 3) [m/s^2]; with ``earth_rate``
        (omega_ie^t, (3,) rad/s) plus the Coriolis term T^T (2 omega_ie^t x v^t) (module docstring)."""
        v, q, _, nu, _ = self._kin(self._times(t))
        if earth_rate is None:
            return nu
        w = earth_rate_or_zero(earth_rate)
        return nu + _to_body(q, np.cross(2.0 * w, v))

    def angular_rate(self, t, earth_rate=None) -> np.ndarray:
        """Body angular rate omega^b (..., 3) [rad/s] (q_dot = 1/2 q (x) [0; omega^b]); with ``earth_rate``
        the inertial rate omega_ib^b = omega^b + T^T omega_ie^t (module docstring)."""
        _, q, _, _, om = self._kin(self._times(t))
        if earth_rate is None:
            return om
        return om + _to_body(q, np.broadcast_to(earth_rate_or_zero(earth_rate), om.shape))


def set_track(traj, start, speed, heading, duration) -> None:
    """Validate and set the start NED position [m], ground speed [m/s], heading [rad] and duration [s] of a flight
    path (``StraightLevel``, ``Maneuvering``); errors name the ``trajectory.*`` key."""
    start = np.asarray(start, dtype=float)
    if start.shape != (3,) or not np.all(np.isfinite(start)):
        raise ConfigError("trajectory.start_ned", f"must be 3 finite numbers [m], got {start.tolist()}")
    traj.start = start
    traj.speed = require_finite("trajectory.speed", speed, lo=1e-3, hi=1e5, unit="m/s")  # 1e-300 gave NaN rates
    traj.heading = require_finite("trajectory.heading", heading, lo=-2 * np.pi, hi=2 * np.pi, unit="rad")
    traj.duration = require_positive("trajectory.duration", duration, "s")


def _to_body(q, x_n):
    """T^T x for attitudes q_b^n (..., 4) and nav-frame vectors x_n (..., 3)."""
    T = quat_to_dcm(q)
    return np.einsum("...ji,...j->...i", T, x_n)
