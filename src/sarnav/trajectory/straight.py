"""Straight-and-level flight at constant speed and heading (the sources' baseline trajectory)."""

from __future__ import annotations

import numpy as np

from sarnav.trajectory.base import Trajectory, TrajectoryState, set_track
from sarnav.trajectory.flight_path import path_kinematics


class StraightLevel(Trajectory):
    """Constant-velocity level flight, body x along the velocity, wings level.

    Parameters
    ----------
    start : (3,) initial position p^n [m] (NED; altitude = -start[2]).
    speed : ground speed [m/s], > 0.
    heading : heading [rad] from north towards east.
    duration : length [s], > 0.
    """

    def __init__(self, start, speed: float, heading: float, duration: float):
        set_track(self, start, speed, heading, duration)

    def _kin(self, t):
        z = np.zeros_like(t)
        return path_kinematics(self.speed, self.heading + z, z, z, z, z)

    def state(self, t) -> TrajectoryState:
        t = self._times(t)
        vel, q, _, _, _ = self._kin(t)
        return TrajectoryState(self.start + vel * t[..., None], vel, q)
