"""The truth-trajectory interface.

A :class:`Trajectory` gives the true kinematics of the vehicle as smooth functions of time, all
vectorised over ``t`` (any shape ``(...)``):

* :meth:`Trajectory.state` -> position ``p^n`` (..., 3) [m], velocity ``v^n`` (..., 3) [m/s],
  attitude ``q_b^n`` (..., 4) (Hamilton, scalar first, body -> NED);
* :meth:`Trajectory.specific_force` -> ``nu^b = T^T (a^n - g^n)`` (..., 3) [m/s^2] (thesis eq. 3.1);
* :meth:`Trajectory.angular_rate` -> ``omega^b`` (..., 3) [rad/s] with ``q_dot = 1/2 q (x) [0; omega^b]``.

The three are mutually consistent: they are what an ideal IMU on the vehicle would measure.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from sarnav.errors import InputDataError


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

    def specific_force(self, t) -> np.ndarray:
        """Specific force in the body frame nu^b = T^T (a^n - g^n) (..., 3) [m/s^2]."""
        return self._kin(self._times(t))[3]

    def angular_rate(self, t) -> np.ndarray:
        """Body angular rate omega^b (..., 3) [rad/s] (q_dot = 1/2 q (x) [0; omega^b])."""
        return self._kin(self._times(t))[4]
