"""Piecewise-constant rates joined by smooth (quintic "smootherstep") transitions.

A :class:`RateProfile` is ``r(t) = r_0 + sum_k (r_k - r_{k-1}) S((t - t_k)/T)`` with
``S(x) = 6x^5 - 15x^4 + 10x^3`` on [0, 1] (0 before, 1 after): r is C^2 and its first two
derivatives vanish at both ends of every transition. Its integral and derivative are closed forms,
used for heading (turn-rate profile) and altitude (climb-rate profile) of
:class:`sarnav.trajectory.maneuver.Maneuvering`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, require_finite, require_positive


def _smootherstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10.0 - 15.0 * x + 6.0 * x**2)


def _smootherstep_rate(x):
    """dS/dx."""
    inside = (x > 0.0) & (x < 1.0)
    return np.where(inside, 30.0 * x**2 * (1.0 - x) ** 2, 0.0)


def _smootherstep_integral(x):
    """int_0^x S(u) du (x >= 0 part; 0 for x <= 0)."""
    xc = np.clip(x, 0.0, 1.0)
    inside = xc**4 * (2.5 - 3.0 * xc + xc**2)
    return np.where(x <= 0.0, 0.0, np.where(x >= 1.0, 0.5 + (x - 1.0), inside))


@dataclass(frozen=True)
class RateProfile:
    """Rate r(t) holding ``rates[k]`` from ``starts[k]`` (after a transition of ``transition`` s).

    Parameters
    ----------
    starts : segment start times [s], increasing, ``starts[0] == 0``.
    rates : rate held in each segment (any unit u/s).
    transition : duration of each smooth transition from the previous rate [s], > 0 and no longer
        than the shortest segment.
    """

    starts: tuple[float, ...]
    rates: tuple[float, ...]
    transition: float

    def __post_init__(self):
        if len(self.starts) != len(self.rates) or len(self.starts) == 0:
            raise ConfigError("rate_profile", "starts and rates must be non-empty and of equal length")
        for i, (s, r) in enumerate(zip(self.starts, self.rates)):
            require_finite(f"rate_profile.starts[{i}]", s, lo=0.0, unit="s")
            require_finite(f"rate_profile.rates[{i}]", r)
        require_positive("rate_profile.transition", self.transition, "s")
        if self.starts[0] != 0.0:
            raise ConfigError("rate_profile.starts[0]", f"must be 0 s, got {self.starts[0]}")
        gaps = np.diff(self.starts)
        if np.any(gaps < self.transition):
            raise ConfigError("rate_profile.starts", f"segments must be at least transition={self.transition} s long")

    def _steps(self, t):
        t = np.asarray(t, dtype=float)
        x = (t[..., None] - np.asarray(self.starts[1:])) / self.transition
        dr = np.diff(np.asarray(self.rates))
        return x, dr

    def rate(self, t):
        """r(t)."""
        x, dr = self._steps(t)
        return self.rates[0] + np.sum(dr * _smootherstep(x), axis=-1)

    def rate_derivative(self, t):
        """dr/dt."""
        x, dr = self._steps(t)
        return np.sum(dr * _smootherstep_rate(x), axis=-1) / self.transition

    def integral(self, t):
        """int_0^t r(s) ds."""
        t = np.asarray(t, dtype=float)
        x, dr = self._steps(t)
        return self.rates[0] * t + self.transition * np.sum(dr * _smootherstep_integral(x), axis=-1)

    def breakpoints(self) -> np.ndarray:
        """Times where r is not analytic (starts and ends of transitions)."""
        s = np.asarray(self.starts[1:])
        return np.unique(np.concatenate([s, s + self.transition]))
