"""Hill-climbing autofocus on one focusing parameter (Pogorelsky et al. 2022 Algorithm 1, eq. 3; gap G14).

Algorithm 1 as printed: from v0 evaluate v0 +- step; if neither is sharper, keep v0; else walk in the sharper
direction by ``step`` while the sharpness increases (at most ``max_iter`` steps) and keep the last improvement. Its
resolution is the step (1 m/s in the paper: quantisation alone gives step/sqrt(12) = 0.29 m/s). ``refine`` continues
with each smaller step of the list from the best point (the issue's "then refined"), and ``parabolic=True`` ends with
the vertex of the parabola through the best point and its two neighbours at the last step (kept only when it lies
between them). The sharpness function is the caller's (e.g. the normalised variance of an image formed with v).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

from sarnav.errors import ConfigError

__all__ = ["HillClimbResult", "hill_climb"]


@dataclass
class HillClimbResult:
    """best : the parameter chosen; value : its sharpness; visited : every (parameter, sharpness) evaluated, in order;
    evaluations : len(visited); hit_limit : a walk stopped at ``max_iter`` without the sharpness decreasing."""

    best: float
    value: float
    visited: list = field(default_factory=list)
    hit_limit: bool = False

    @property
    def evaluations(self) -> int:
        return len(self.visited)


def _walk(f, v, s, step, max_iter, seen):
    """One Algorithm-1 walk from (v, s) with ``step``: returns (v, s, hit_limit)."""
    up, down = f(v + step, seen), f(v - step, seen)
    if up <= s and down <= s:
        return v, s, False
    d = 1.0 if up > down else -1.0
    v, s = v + d * step, max(up, down)
    for _ in range(max_iter):
        s_new = f(v + d * step, seen)
        if s_new < s:
            return v, s, False
        v, s = v + d * step, s_new
    return v, s, True


def hill_climb(sharpness: Callable[[float], float], v0: float, step: float = 1.0, max_iter: int = 60,
               refine: Sequence[float] = (0.5, 0.25), parabolic: bool = True) -> HillClimbResult:
    """Maximise ``sharpness(v)`` from ``v0`` (module docstring); each distinct v is evaluated once."""
    if not (math.isfinite(step) and step > 0):
        raise ConfigError("autofocus.step", f"must be finite and > 0, got {step!r}")
    if not (isinstance(max_iter, int) and max_iter >= 1):
        raise ConfigError("autofocus.max_iter", f"must be an integer >= 1, got {max_iter!r}")
    if any(not (math.isfinite(r) and 0 < r < step) for r in refine):
        raise ConfigError("autofocus.refine", f"refinement steps must be in (0, step = {step}), got {list(refine)}")
    cache: dict = {}
    visited: list = []

    def f(v, seen):
        key = round(v, 9)
        if key not in cache:
            cache[key] = float(sharpness(v))
            visited.append((v, cache[key]))
        return cache[key]

    v, s = float(v0), f(float(v0), None)
    hit = False
    last = step
    for st in (step, *refine):
        v, s, h = _walk(f, v, s, st, max_iter, None)
        hit |= h
        last = st
    if parabolic:
        lo, hi = f(v - last, None), f(v + last, None)
        den = lo - 2.0 * s + hi
        if den < 0:
            dv = 0.5 * last * (lo - hi) / den
            if abs(dv) <= last:
                v = v + dv
    return HillClimbResult(v, s, visited, hit)
