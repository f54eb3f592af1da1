"""Truth trajectories: :class:`StraightLevel`, :class:`Maneuvering` (see ``base.Trajectory``)."""

from sarnav.trajectory.base import Trajectory, TrajectoryState
from sarnav.trajectory.maneuver import Maneuvering
from sarnav.trajectory.rate_profile import RateProfile
from sarnav.trajectory.straight import StraightLevel

__all__ = ["Trajectory", "TrajectoryState", "StraightLevel", "Maneuvering", "RateProfile"]
