"""Telemetry measurements to one known ground target (thesis eq. 3.13-3.17, extraction §5.1).

With d = r - p (target minus vehicle position, NED)::

    altimeter  z = -p_D + b_alt + n                 dz/dp = [0, 0, -1]
    range      z = |d| + b_range + n                dz/dp = -d^T/|d|
    range rate z = -v^T d/|d| + b_rate + n          dz/dp = v^T/|d| - (v^T d) d^T/|d|^3,  dz/dv = -d^T/|d|

(range rate is positive when the range grows). Each bias enters H with +1 (eq. 3.16).

Hessians (for second-order strategies), with rho = |d|, u = d/rho, Pi = I - u u^T, w = Pi v::

    range       d2h/dp2 = Pi / rho
    range rate  d2h/dp2 = (u w^T + w u^T + (v.u) Pi) / rho^2,   d2h/dp dv = Pi / rho,   d2h/dv2 = 0
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters.layout import ErrorStateLayout
from sarnav.measurements.base import ScalarBiasedMeasurement


def _target(target):
    t = np.asarray(target, dtype=float)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise ConfigError("target.position_ned", f"must be 3 finite numbers [m], got {np.ravel(t).tolist()}")
    return t


def _zeros3(p):
    return np.zeros(np.shape(p)[:-1] + (3, 3))


def _geometry(target, p):
    """d = target - p (R, 3), rho = |d| (R,), u = d / rho (R, 3), Pi = I - u u^T (R, 3, 3)."""
    d = target - np.asarray(p, dtype=float)
    rho = np.sqrt(np.sum(d * d, axis=1))
    u = d / rho[:, None]
    return d, rho, u, np.eye(3) - u[:, :, None] * u[:, None, :]


class AltimeterMeasurement(ScalarBiasedMeasurement):
    """Altitude above the flat Earth, ``-p_D`` [m] (eq. 3.13, first row)."""

    names = ("alt",)
    units = ("m",)

    def __init__(self, sigma: float, layout: ErrorStateLayout, bias: str = "b_alt"):
        super().__init__(sigma, layout, bias)

    def model(self, p, v):
        p = np.asarray(p, dtype=float)
        dp = np.zeros_like(p)
        dp[:, 2] = -1.0
        return -p[:, 2], dp, np.zeros_like(p)

    def hessian_blocks(self, p, v):
        return _zeros3(p), _zeros3(p), _zeros3(p)


class _ToTarget(ScalarBiasedMeasurement):
    """A measurement to the known ground target ``target`` (NED [m]); ``bias``: its bias state (default the class's
    ``bias_state``)."""

    bias_state = ""

    def __init__(self, target, sigma: float, layout: ErrorStateLayout, bias: str | None = None):
        self.target = _target(target)
        super().__init__(sigma, layout, self.bias_state if bias is None else bias)


class RangeMeasurement(_ToTarget):
    """Slant range to the known target ``|r - p|`` [m] (eq. 3.13, second row)."""

    names, units, bias_state = ("range",), ("m",), "b_range"

    def model(self, p, v):
        d = self.target - np.asarray(p, dtype=float)
        rng = np.sqrt(np.sum(d * d, axis=1))
        return rng, -d / rng[:, None], np.zeros_like(d)

    def hessian_blocks(self, p, v):
        _, rho, _, proj = _geometry(self.target, p)
        return proj / rho[:, None, None], _zeros3(p), _zeros3(p)


class RangeRateMeasurement(_ToTarget):
    """Range rate to the known target ``-v^T (r - p)/|r - p|`` [m/s] (eq. 3.13, third row)."""

    names, units, bias_state = ("rate",), ("m/s",), "b_rate"

    def model(self, p, v):
        v = np.asarray(v, dtype=float)
        d = self.target - np.asarray(p, dtype=float)
        rng = np.sqrt(np.sum(d * d, axis=1))
        vd = np.sum(v * d, axis=1)
        h = -vd / rng
        dp = v / rng[:, None] - (vd / rng**3)[:, None] * d  # eq. 3.17 / B.28
        dv = -d / rng[:, None]
        return h, dp, dv

    def hessian_blocks(self, p, v):
        _, rho, u, proj = _geometry(self.target, p)
        v = np.asarray(v, dtype=float)
        w = np.einsum("rij,rj->ri", proj, v)
        vu = np.sum(v * u, axis=1)
        pp = (u[:, :, None] * w[:, None, :] + w[:, :, None] * u[:, None, :] + vu[:, None, None] * proj) / rho[:, None, None] ** 2
        return pp, proj / rho[:, None, None], _zeros3(p)
