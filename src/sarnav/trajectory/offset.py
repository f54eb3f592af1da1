"""Another pass over the same ground: a trajectory shifted sideways and in height (a reference pass, repeat pass)."""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError
from sarnav.trajectory.base import Trajectory, TrajectoryState

__all__ = ["OffsetTrack"]


class OffsetTrack:
    """``base`` shifted by ``across`` [m] horizontally to the right of its velocity and by ``up`` [m] upward, at the
    same times: ``p(t) = p_base(t) + across w(t) - up e_D`` with w the horizontal unit normal right of v_base(t). For
    a straight track it is the parallel track; on a turn the offset follows the normal (the speed then differs from
    the base's by a factor 1 - across x turn rate / V: a positive turn rate turns right, so an offset to the
    right lies inside the turn). Velocity by a central difference of the positions
    (``dt`` [s]); attitude that of the base. Only :meth:`state` is offered (the echoes and the reference image need
    nothing else)."""

    def __init__(self, base: Trajectory, across: float, up: float, dt: float = 1e-3):
        for name, v in (("scene.reference_offset_m", across), ("scene.reference_offset_m", up)):
            if not np.isfinite(v):
                raise ConfigError(name, f"must be finite [m], got {v!r}")
        self.base, self.across, self.up, self.dt = base, float(across), float(up), float(dt)
        self.duration = base.duration

    def _position(self, t):
        st = self.base.state(t)
        v = st.velocity
        vh = np.hypot(v[..., 0], v[..., 1])
        w = np.stack([-v[..., 1] / vh, v[..., 0] / vh, np.zeros_like(vh)], axis=-1)
        p = st.position + self.across * w
        p[..., 2] -= self.up
        return p, st.quaternion

    def state(self, t) -> TrajectoryState:
        t = np.asarray(t, dtype=np.float64)
        p, q = self._position(t)
        lo = np.clip(t - self.dt, 0.0, self.duration)
        hi = np.clip(t + self.dt, 0.0, self.duration)
        v = (self._position(hi)[0] - self._position(lo)[0]) / (hi - lo)[..., None]
        return TrajectoryState(p, v, q)
