"""FFBP's plan: how :func:`sarnav.imaging.ffbp.ffbp` factorises the aperture and what error it predicts.

The error model (every interpolation stage adds its kernel's 2-D error of a flat band at ``oversample``; the level-0
range interpolation adds its summed error) and the operation-count cost model that picks the subaperture length and
the number of merges (docs/backprojection.md, "Fast factorised back-projection").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError
from sarnav.imaging.interpolation_error import WINDOWED, interpolation_error_2d

__all__ = ["FFBP_KERNELS", "BASE_CHOICES", "POLAR_MARGIN", "OVERSAMPLE_CHOICES", "FfbpPlan", "ffbp_error_model",
           "ffbp_plan", "merge_cost", "plan_cost", "plan_for_error", "check_kernel"]

_C = 299792458.0
#: polar-image interpolation kernels: name -> taps per dimension (sarnav.imaging.interpolation_error)
FFBP_KERNELS = {"kaiser6": WINDOWED["kaiser6"], "cubic": 4}
#: extra polar samples beyond the pixels' extent on each side (the 6-tap kernel's support is 3)
POLAR_MARGIN = 4
#: subaperture lengths [pulses] the cost model chooses from when ``base_pulses`` is not given (2048 pixels and pulses:
#: 32 with two merges of 4 was the fastest plan on the own and the peer's collect, 8-13 % ahead of 16 with 2-3,
#: docs/backprojection.md)
BASE_CHOICES = (8, 16, 32, 64)


@dataclass(frozen=True)
class FfbpPlan:
    """How :func:`sarnav.imaging.ffbp.ffbp` factorises: subaperture sizes, polar sampling and the predicted error."""

    base_pulses: int
    merge: int
    levels: int
    oversample: float
    bandwidth: float
    n_stages: int
    predicted_error_db: float
    kernel: str = "kaiser6"

    @property
    def final_pulses(self) -> int:
        return self.base_pulses * self.merge ** self.levels


def ffbp_error_model(oversample: float, n_stages: int, data_error: float = 0.0, kernel: str = "kaiser6") -> float:
    """Predicted image error [dB] of FFBP against exact back-projection (module doc): ``10 log10(n_stages *
    eps_kernel_2d(os, os) + data_error)``; ``data_error`` (linear): the level-0 range interpolation's error."""
    eps = n_stages * interpolation_error_2d(check_kernel(kernel), oversample, oversample) + data_error
    return float(10.0 * math.log10(eps))


def check_kernel(kernel):
    """``kernel`` if it is one of :data:`FFBP_KERNELS`, else a ConfigError naming it."""
    if kernel not in FFBP_KERNELS:
        raise ConfigError("kernel", f"must be one of {tuple(FFBP_KERNELS)}, got {kernel!r}")
    return kernel


def _int_arg(name, value, lo):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise ConfigError(name, f"must be an integer >= {lo}, got {value!r}")
    return int(value)


def ffbp_plan(n_pulses: int, *, base_pulses: int | None = None, merge: int = 4, levels: int | None = None,
              oversample: float = 2.0, bandwidth: float, cost=None, kernel: str = "kaiser6",
              data_error: float = 0.0) -> FfbpPlan:
    """Choose the factorisation and predict its error (``data_error``: the level-0 range interpolation's, linear).

    Default ``base_pulses`` and ``levels``: of :data:`BASE_CHOICES` (16 when ``cost`` is None) and 0 .. (as many
    merges as fit), the pair that minimises ``cost(base_pulses, levels)`` (operation count estimate,
    :func:`plan_cost`); without ``cost`` the most levels.
    """
    if base_pulses is not None:
        base_pulses = _int_arg("base_pulses", base_pulses, 1)
    merge = _int_arg("merge", merge, 2)
    check_kernel(kernel)
    if not (isinstance(oversample, (int, float)) and math.isfinite(oversample) and oversample >= 1.5):
        raise ConfigError("oversample", f"must be a number >= 1.5 (polar samples per Nyquist sample), got {oversample!r}")
    if levels is not None:
        levels = _int_arg("levels", levels, 0)
    bases = [base_pulses] if base_pulses is not None else [16] if cost is None else \
        [b for b in BASE_CHOICES if b <= max(n_pulses, BASE_CHOICES[0])]
    plans = []
    for base in bases:
        top = 0
        while base * merge ** (top + 1) <= n_pulses:
            top += 1
        for lev in ([levels] if levels is not None else range(top + 1) if cost is not None else [top]):
            plans.append((cost(base, lev) if cost is not None else 0.0, base, lev))
    _, base_pulses, levels = min(plans, key=lambda t: t[0])
    n_stages = levels + 1
    return FfbpPlan(base_pulses, merge, levels, float(oversample), float(bandwidth), n_stages,
                    ffbp_error_model(oversample, n_stages, data_error, kernel=kernel), kernel)


#: the oversampling factors a target error (``ffbp(..., error_db=)``) is met with: 1.6 .. 4.0 in steps of 0.1 (kaiser6's
#: tabulated beta, ``interpolation_error.KAISER6_BETA``)
OVERSAMPLE_CHOICES = tuple(round(1.6 + 0.1 * i, 1) for i in range(25))


def plan_for_error(error_db, n_pulses: int, cost_at, *, base_pulses: int | None, merge: int, levels: int | None,
                   kernel: str, data_share: float = 0.0, data_error: float = 0.0) -> tuple[float, int, int]:
    """(oversample, base pulses, levels) of least cost whose predicted error is <= ``error_db``: over
    :data:`OVERSAMPLE_CHOICES` and, unless given, :data:`BASE_CHOICES` and the levels that fit, the polar stages'
    error (:func:`ffbp_error_model`) times 1 + ``data_share`` (the level-0 range interpolation's share under ``ffbp``'s
    "auto" rule) plus ``data_error`` (linear: a range interpolation fixed in advance); ``cost_at(os)``: the
    :func:`plan_cost` function at that os. A target no plan reaches is a ConfigError naming ``error_db`` and the least
    error a plan predicts."""
    if isinstance(error_db, bool) or not isinstance(error_db, (int, float)) or not math.isfinite(error_db):
        raise ConfigError("error_db", f"must be a finite number of dB, got {error_db!r}")
    check_kernel(kernel)
    merge = _int_arg("merge", merge, 2)
    base_pulses = None if base_pulses is None else _int_arg("base_pulses", base_pulses, 1)
    levels = None if levels is None else _int_arg("levels", levels, 0)
    bases = [base_pulses] if base_pulses is not None else [b for b in BASE_CHOICES if b <= max(n_pulses, BASE_CHOICES[0])]
    best, reach = None, math.inf
    for os_ in OVERSAMPLE_CHOICES:
        cost, stage = None, interpolation_error_2d(kernel, os_, os_)      # one stage's error (ffbp_error_model)
        for base in bases:
            top = 0
            while base * merge ** (top + 1) <= n_pulses:
                top += 1
            for lev in [levels] if levels is not None else range(top + 1):
                err = 10.0 * math.log10((1.0 + data_share) * (lev + 1) * stage + data_error)
                reach = min(reach, err)
                if err <= error_db:
                    cost = cost or cost_at(os_)
                    c = cost(base, lev)
                    best = (c, os_, base, lev) if best is None or c < best[0] else best
    if best is None:
        raise ConfigError("error_db", f"must be >= {reach:.1f} dB (the least error a {kernel} plan predicts at os <= "
                                      f"{OVERSAMPLE_CHOICES[-1]}), got {error_db!r}")
    return best[1], best[2], best[3]


#: cost of one polar-image evaluation relative to one back-projected pixel-pulse: fixed part (locate, phase) and per
#: tap (benchmarks/bench_ffbp.py, 2 cores: 16 taps ~5)
_EVAL_COST_FIXED, _EVAL_COST_TAP = 1.0, 0.25
#: fixed part of a two-pass merge's point (``ffbp_merge``: two locations and two phase factors, a row of the pass-1
#: image); its taps are N + N / merge. Measured per parent point, 2 cores, a (2190 x 194) child onto a (2187 x 746)
#: parent: kaiser6 8.4 ns against 17.6 ns for the 2-D merge (10 units), cubic 9.2 against 14.0 ns
_TWO_PASS_COST_FIXED = 3.0


def merge_cost(taps: int, merge: int, two_pass: bool) -> float:
    """Cost of one merge evaluation [pixel-pulse units]: the 2-D kernel's N^2 taps, or a two-pass merge's N + N / merge
    (:mod:`sarnav.imaging.ffbp_merge`)."""
    if two_pass:
        return _TWO_PASS_COST_FIXED + _EVAL_COST_TAP * taps * (1.0 + 1.0 / merge)
    return _EVAL_COST_FIXED + _EVAL_COST_TAP * taps * taps


def plan_cost(p, n_pix, pos, v, hull, bw, os_, spacing, lam_eff, merge, taps, two_pass: bool = False):
    """Operation count (pixel-pulse units) of the factorisation as a function of (base pulses, levels); ``two_pass``:
    the merges are :mod:`sarnav.imaging.ffbp_merge`'s."""
    c = pos.mean(axis=0)
    d = hull - c
    r = np.linalg.norm(d, axis=1)
    u = d @ v / r
    n_r = np.ptp(r) * 2.0 * bw * os_ / _C + 2 * POLAR_MARGIN
    eval_cost = _EVAL_COST_FIXED + _EVAL_COST_TAP * taps * taps
    step_cost = merge_cost(taps, merge, two_pass)

    def n_u(n_pulses):
        return np.ptp(u) * 2.0 * n_pulses * spacing * os_ / lam_eff + 2 * POLAR_MARGIN

    def cost(base, levels):
        total = p * n_r * n_u(base)                                  # level-0 exact formation
        for lev in range(1, levels + 1):
            size = base * merge ** lev
            total += step_cost * (p / size) * n_r * n_u(size) * merge
        return total + eval_cost * n_pix * math.ceil(p / (base * merge ** levels))

    return cost


