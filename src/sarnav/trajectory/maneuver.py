"""A maneuvering flight: turns, climbs and descents joined by smooth transitions.

Heading follows a turn-rate :class:`~sarnav.trajectory.rate_profile.RateProfile`, altitude a
climb-rate profile; horizontal speed is constant. Heading and altitude are closed forms; the
horizontal position ``int V [cos psi, sin psi] dt`` is integrated by 16-point Gauss-Legendre
quadrature between knots placed at every transition boundary and at least every second, where
the integrand is analytic (error at the 1e-12 m level, checked in tests/test_trajectory.py).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import require_positive
from sarnav.trajectory.base import Trajectory, TrajectoryState, set_track
from sarnav.trajectory.flight_path import path_kinematics
from sarnav.trajectory.rate_profile import RateProfile

_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)


class Maneuvering(Trajectory):
    """Constant-speed flight with a turn-rate and a climb-rate profile.

    Parameters
    ----------
    start : (3,) initial position p^n [m].
    speed : horizontal speed [m/s], > 0.
    heading : initial heading [rad].
    turn_rate : RateProfile of heading rate [rad/s].
    climb_rate : RateProfile of climb rate hdot = -v_D [m/s].
    duration : length [s], > 0.
    """

    def __init__(self, start, speed, heading, turn_rate: RateProfile, climb_rate: RateProfile, duration):
        set_track(self, start, speed, heading, duration)
        self.turn_rate = turn_rate
        self.climb_rate = climb_rate
        brk = np.concatenate([turn_rate.breakpoints(), climb_rate.breakpoints(), np.arange(0.0, self.duration, 1.0)])
        knots = np.unique(np.concatenate([brk[(brk > 0) & (brk < self.duration)], [0.0, self.duration]]))
        self._knots = knots
        pieces = self._gauss_legendre(knots[:-1], knots[1:])
        self._cum = np.concatenate([np.zeros((1, 2)), np.cumsum(pieces, axis=0)])

    @classmethod
    def s_turn_climb(cls, start, speed, heading, duration):
        """The default maneuver used by the ``maneuver`` trajectory type.

        Fractions of ``duration``: straight until 1/6, turn right at 3 deg/s until 2/6, climb at
        3 m/s while straight until 3/6, turn left at 3 deg/s while descending at 3 m/s until 4/6,
        then straight and level. Transitions last min(4 s, duration/12).
        """
        duration = require_positive("trajectory.duration", duration, "s")
        d = np.radians(3.0)
        tr = min(4.0, duration / 12.0)
        s = [0.0, duration / 6, 2 * duration / 6, 3 * duration / 6, 4 * duration / 6]
        turn = RateProfile(tuple(s), (0.0, d, 0.0, -d, 0.0), tr)
        climb = RateProfile(tuple(s), (0.0, 0.0, 3.0, -3.0, 0.0), tr)
        return cls(start, speed, heading, turn, climb, duration)

    @classmethod
    def s_turn(cls, start, speed, heading, duration, rate_deg_s: float = 3.0):
        """A level S-turn (the ``turning`` trajectory type): straight until 1/6 of ``duration``, turn right at
        ``rate_deg_s`` until 2/6, straight until 3/6, turn left at the same rate until 4/6, then straight; no climb.
        Transitions last min(4 s, duration/12)."""
        duration = require_positive("trajectory.duration", duration, "s")
        d = np.radians(rate_deg_s)
        tr = min(4.0, duration / 12.0)
        s = [0.0, duration / 6, 2 * duration / 6, 3 * duration / 6, 4 * duration / 6]
        turn = RateProfile(tuple(s), (0.0, d, 0.0, -d, 0.0), tr)
        climb = RateProfile(tuple(s), (0.0, 0.0, 0.0, 0.0, 0.0), tr)
        return cls(start, speed, heading, turn, climb, duration)

    def _heading(self, t):
        return self.heading + self.turn_rate.integral(t)

    def _gauss_legendre(self, a, b):
        """int_a^b V [cos psi, sin psi] dt, (..., 2)."""
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        half = 0.5 * (b - a)
        s = 0.5 * (a + b)[..., None] + half[..., None] * _GL_X
        psi = self._heading(s)
        w = _GL_W * half[..., None]
        return self.speed * np.stack([np.sum(w * np.cos(psi), -1), np.sum(w * np.sin(psi), -1)], -1)

    def _kin(self, t):
        psi = self._heading(t)
        return path_kinematics(
            self.speed,
            psi,
            self.turn_rate.rate(t),
            self.turn_rate.rate_derivative(t),
            self.climb_rate.rate(t),
            self.climb_rate.rate_derivative(t),
        )

    def state(self, t) -> TrajectoryState:
        t = self._times(t)
        k = np.clip(np.searchsorted(self._knots, t, side="right") - 1, 0, len(self._knots) - 2)
        horiz = self._cum[k] + self._gauss_legendre(self._knots[k], t)
        down = self.start[2] - self.climb_rate.integral(t)
        pos = np.concatenate([self.start[:2] + horiz, down[..., None]], -1)
        vel, q, _, _, _ = self._kin(t)
        return TrajectoryState(pos, vel, q)
