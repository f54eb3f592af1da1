"""Telemetry measurements to one known ground target (thesis eq. 3.13-3.17, extraction §5.1).

With d = r - p (target minus vehicle position, NED)::

    altimeter  z = -p_D + b_alt + n                 dz/dp = [0, 0, -1]
    range      z = |d| + b_range + n                dz/dp = -d^T/|d|
    range rate z = -v^T d/|d| + b_rate + n          dz/dp = v^T/|d| - (v^T d) d^T/|d|^3,  dz/dv = -d^T/|d|

(range rate is positive when the range grows). Each bias enters H with +1 (eq. 3.16).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters.layout import ErrorStateLayout
from sarnav.measurements.base import Measurement


def _target(target):
    t = np.asarray(target, dtype=float)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise ConfigError("target.position_ned", f"must be 3 finite numbers [m], got {np.ravel(t).tolist()}")
    return t


class AltimeterMeasurement(Measurement):
    """Altitude above the flat Earth, ``-p_D`` [m] (eq. 3.13, first row)."""

    name = "alt"

    def __init__(self, sigma: float, layout: ErrorStateLayout, bias: str = "b_alt"):
        super().__init__(sigma, layout, bias)

    def model(self, p, v):
        p = np.asarray(p, dtype=float)
        dp = np.zeros_like(p)
        dp[:, 2] = -1.0
        return -p[:, 2], dp, np.zeros_like(p)


class RangeMeasurement(Measurement):
    """Slant range to the known target ``|r - p|`` [m] (eq. 3.13, second row)."""

    name = "range"

    def __init__(self, target, sigma: float, layout: ErrorStateLayout, bias: str = "b_range"):
        self.target = _target(target)
        super().__init__(sigma, layout, bias)

    def model(self, p, v):
        d = self.target - np.asarray(p, dtype=float)
        rng = np.sqrt(np.sum(d * d, axis=1))
        return rng, -d / rng[:, None], np.zeros_like(d)


class RangeRateMeasurement(Measurement):
    """Range rate to the known target ``-v^T (r - p)/|r - p|`` [m/s] (eq. 3.13, third row)."""

    name = "rate"

    def __init__(self, target, sigma: float, layout: ErrorStateLayout, bias: str = "b_rate"):
        self.target = _target(target)
        super().__init__(sigma, layout, bias)

    def model(self, p, v):
        v = np.asarray(v, dtype=float)
        d = self.target - np.asarray(p, dtype=float)
        rng = np.sqrt(np.sum(d * d, axis=1))
        vd = np.sum(v * d, axis=1)
        h = -vd / rng
        dp = v / rng[:, None] - (vd / rng**3)[:, None] * d  # eq. 3.17 / B.28
        dv = -d / rng[:, None]
        return h, dp, dv
