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

__all__ = ["FFBP_KERNELS", "TABLE_STEPS", "BASE_CHOICES", "POLAR_MARGIN", "OVERSAMPLE_CHOICES", "FfbpPlan",
           "ffbp_error_model", "stage_error", "table_error", "polar_margin", "polar_margins", "child_margin", "ffbp_plan",
           "merge_cost", "plan_cost", "plan_for_error", "check_kernel", "ERROR_KERNELS", "track_error"]

_C = 299792458.0
#: polar-image interpolation kernels: name -> taps per dimension (sarnav.imaging.interpolation_error); kaiser8 and
#: kaiser10 for images within -70 to -90 dB of exact (``ffbp(..., error_db=)`` weighs them all)
FFBP_KERNELS = {"kaiser6": WINDOWED["kaiser6"], "kaiser8": WINDOWED["kaiser8"], "kaiser10": WINDOWED["kaiser10"],
                "cubic": 4}
#: fractions per sample of each kernel's weight table (``ffbp.kernel_table``: a tap reads the nearest row): the rounding
#: of the fraction costs :func:`table_error`, -80 dB a 1-D interpolation at os 2.5 with 2048 rows, under kaiser6's
#: -60 dB but the floor of kaiser10's -94 dB (measured at 2048^2 on the peer's collect, kaiser10 os 3: -68.1 dB on the
#: uniform sample with 2048 rows, -81.4 dB with 16384); 16384 rows of 10 float32 are 640 KiB
TABLE_STEPS = {"kaiser6": 2048, "cubic": 2048, "kaiser8": 8192, "kaiser10": 16384}
#: extra polar samples beyond the pixels' extent on each side for kernels of up to 6 taps (support 3):
#: :func:`polar_margin` gives a longer kernel one more than its half-width
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
    #: the track's share of ``predicted_error_db`` (:func:`track_error`), -inf for a straight one
    track_error_db: float = -math.inf

    @property
    def final_pulses(self) -> int:
        return self.base_pulses * self.merge ** self.levels


def _db(eps: float) -> float:
    return 10.0 * math.log10(eps) if eps > 0 else -math.inf


def table_error(oversample: float, steps: int) -> float:
    """Relative mean-square error (linear) of reading a kernel's weights at the fraction rounded to 1 / ``steps``, one
    1-D interpolation of a flat band at ``oversample``: the position error d, uniform in +-1 / (2 steps), times the
    band's rms derivative, E|x'|^2 = (2 pi)^2 E[f^2] = pi^2 / (3 os^2): pi^2 / (36 steps^2 os^2)."""
    return math.pi ** 2 / (36.0 * steps * steps * oversample * oversample)


def stage_error(kernel: str, oversample: float) -> float:
    """One polar stage's error (linear): the kernel's 2-D error at ``oversample`` in both dimensions plus its weight
    table's rounding in each (:func:`table_error`)."""
    return interpolation_error_2d(check_kernel(kernel), oversample, oversample) + \
        2.0 * table_error(oversample, TABLE_STEPS[kernel])


def ffbp_error_model(oversample: float, n_stages: int, data_error: float = 0.0, kernel: str = "kaiser6") -> float:
    """Predicted image error [dB] of FFBP against exact back-projection (module doc): ``10 log10(n_stages *
    stage_error(kernel, os) + data_error)``; ``data_error`` (linear): the level-0 range interpolation's error."""
    eps = n_stages * stage_error(kernel, oversample) + data_error
    return float(10.0 * math.log10(eps))


def track_error(pos: np.ndarray, sample: np.ndarray, v: np.ndarray, scene_centre: np.ndarray, wavelength: float,
                top_pulses: int) -> float:
    """Mean-square error (linear) that a track off the straight line adds to FFBP's image, for subapertures of
    ``top_pulses`` pulses at the last level (``pos`` (P, 3) antenna positions, ``sample`` (M, 3) pixels spread
    uniformly over the image, ``v`` the track direction, ``scene_centre`` the point the polar half-planes face).

    A top-level polar image holds, at (r, u) about its centre c, the pulses' sum at the point q of its half-plane
    (``ffbp`` module doc); a pixel x with the same (r, u) gets that value. |x - c| = |q - c|, so for pulse k at
    c + d_k the range differs by dR_k = |x - p_k| - |q - p_k| = -2 (x - q).d_k / (|x - p_k| + |q - p_k|): zero when
    d_k is along v (a straight subaperture), else ~ the offset across the half-plane times the pixel's rotation
    out of it. Each pulse's contribution is off by exp(j 4 pi dR_k / lambda) - 1; over the band those add in
    energy (Parseval), so the image's error is the mean of |exp(j 4 pi dR_k / lambda) - 1|^2 over pulses and pixels.
    Lower levels add only second-order terms: their points are the top's q, carried to a child's coordinates about an
    axis a few subaperture offsets away (measured on the 192^2 test scene with a 1 cm sinusoidal offset: -61.1 /
    -49.7 / -43.8 dB with 0 / 1 / 2 merges, -61.6 / -49.8 / -43.8 predicted by this function for tops of 8 / 32 /
    128 pulses, tests/imaging/test_ffbp.py)."""
    pos = np.asarray(pos, np.float64)
    x = np.asarray(sample, np.float64).reshape(-1, 3)
    k = 4.0 * math.pi / wavelength
    total = 0.0
    for k0 in range(0, pos.shape[0], max(1, int(top_pulses))):
        p = pos[k0:k0 + top_pulses]
        c = p.mean(axis=0)
        off = scene_centre - c
        w = off - np.dot(off, v) * v
        w /= np.linalg.norm(w)
        dx = x - c
        r = np.linalg.norm(dx, axis=1)
        u = np.clip(dx @ v / r, -1.0, 1.0)
        q = c + r[:, None] * (u[:, None] * v + np.sqrt(1.0 - u * u)[:, None] * w)
        for j0 in range(0, p.shape[0], _TRACK_CHUNK):                   # bounded memory whatever the pulse count
            pj = p[j0:j0 + _TRACK_CHUNK]
            num = -2.0 * ((pj - c) @ (x - q).T)                             # (pulses, pixels)
            den = np.linalg.norm(x[None] - pj[:, None], axis=2) + np.linalg.norm(q[None] - pj[:, None], axis=2)
            total += float(np.sum(2.0 - 2.0 * np.cos(k * num / den)))
    return total / (pos.shape[0] * x.shape[0])


#: pulses :func:`track_error` takes at a time (its (pulses, pixels) arrays: 512 x 289 float64, 1.2 MB each)
_TRACK_CHUNK = 512


def polar_margin(kernel: str) -> int:
    """Polar samples kept beyond the pixels' extent on each side of the final polar image: :data:`POLAR_MARGIN`, or the
    kernel's half-width plus one for a longer kernel (every tap of a pixel's support then lies on the image)."""
    return max(POLAR_MARGIN, FFBP_KERNELS[check_kernel(kernel)] // 2 + 1)


def child_margin(margin: tuple[int, int], parent_pulses: int, child_pulses: int, half: int) -> tuple[int, int]:
    """(range, angle) margin [samples] a child needs so that every tap a parent sample in the parent's ``margin`` reads
    lies on the child: in range the child has the parent's dr, so the parent's margin plus the kernel's half-width h;
    in angle the child's samples are parent_pulses / child_pulses times the parent's (du is lambda / (2 l os), l the
    aperture), so ceil(m child_pulses / parent_pulses) + h, and never under :data:`POLAR_MARGIN`. A regular child of
    a merge of 4 needs m / 4 + h; a parent's first child when the last is short nearly m + h (32 of a parent's 33
    pulses: with one margin for every level, FFBP's image lost its last row, -75.3 dB against -91.4 predicted on the
    192^2 test scene with 161 pulses, kaiser10 os 3)."""
    m_r, m_u = margin
    return m_r + half, max(math.ceil(m_u * child_pulses / parent_pulses) + half, POLAR_MARGIN)


def polar_margins(kernel: str, merge: int, levels: int) -> list[tuple[int, int]]:
    """(range, angle) margins [samples] of the polar images of each level 0 .. ``levels`` of a regular factorisation
    (every child ``1 / merge`` of its parent; :func:`child_margin`), the final image's :func:`polar_margin`: the range
    margin grows by h a level down, the angle margin is ceil(m / merge) + h. With one margin at every level kaiser10's
    merges left the parent's outer samples partly unread: -75 dB of error a merge on the 192^2 test scene, the same at
    os 2.5 and 4."""
    half = FFBP_KERNELS[check_kernel(kernel)] // 2
    out = [(polar_margin(kernel),) * 2]
    for _ in range(levels):
        out.append(child_margin(out[-1], merge, 1, half))
    return out[::-1]


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
              data_error: float = 0.0, track=None) -> FfbpPlan:
    """Choose the factorisation and predict its error (``data_error``: the level-0 range interpolation's, linear;
    ``track(top_pulses)``: the track's error, linear, for subapertures of that many pulses at the last level,
    :func:`track_error`; None: a straight track).

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
    bent = 0.0 if track is None else track(base_pulses * merge ** levels)
    return FfbpPlan(base_pulses, merge, levels, float(oversample), float(bandwidth), n_stages,
                    ffbp_error_model(oversample, n_stages, data_error + bent, kernel=kernel), kernel,
                    _db(bent))


#: the oversampling factors a target error (``ffbp(..., error_db=)``) is met with: 1.6 .. 4.0 in steps of 0.1 (kaiser6's
#: tabulated beta, ``interpolation_error.KAISER6_BETA``)
OVERSAMPLE_CHOICES = tuple(round(1.6 + 0.1 * i, 1) for i in range(25))


#: the kernels ``ffbp(..., error_db=)`` weighs when no kernel is given
ERROR_KERNELS = ("kaiser6", "kaiser8", "kaiser10")


def plan_for_error(error_db, n_pulses: int, cost_at, *, base_pulses: int | None, merge: int, levels: int | None,
                   kernel: str | None, data_share: float = 0.0, data_error: float = 0.0,
                   track=None) -> tuple[float, int, int, str]:
    """(oversample, base pulses, levels, kernel) of least cost whose predicted error is <= ``error_db``: over
    :data:`OVERSAMPLE_CHOICES`, ``kernel`` (None: each of :data:`ERROR_KERNELS`) and, unless given,
    :data:`BASE_CHOICES` and the levels that fit, the polar stages' error (:func:`ffbp_error_model`) times 1 +
    ``data_share`` (the level-0 range interpolation's share under ``ffbp``'s "auto" rule) plus ``data_error`` (linear:
    a range interpolation fixed in advance); ``cost_at(os, kernel)``: the :func:`plan_cost` function at that os and
    kernel; ``track(top_pulses)`` (linear, :func:`track_error`): the error of a track off the straight line, which
    grows with the subapertures of the last level, so a bent track gets fewer merges. A target no plan reaches is a
    ConfigError naming ``error_db`` and the least error a plan predicts."""
    if isinstance(error_db, bool) or not isinstance(error_db, (int, float)) or not math.isfinite(error_db):
        raise ConfigError("error_db", f"must be a finite number of dB, got {error_db!r}")
    kernels = ERROR_KERNELS if kernel is None else (check_kernel(kernel),)
    merge = _int_arg("merge", merge, 2)
    base_pulses = None if base_pulses is None else _int_arg("base_pulses", base_pulses, 1)
    levels = None if levels is None else _int_arg("levels", levels, 0)
    bases = [base_pulses] if base_pulses is not None else [b for b in BASE_CHOICES if b <= max(n_pulses, BASE_CHOICES[0])]
    best, reach = None, math.inf
    bent = {}
    for kern in kernels:
        for os_ in OVERSAMPLE_CHOICES:
            cost, stage = None, stage_error(kern, os_)                     # one stage's error (ffbp_error_model)
            for base in bases:
                top = 0
                while base * merge ** (top + 1) <= n_pulses:
                    top += 1
                for lev in [levels] if levels is not None else range(top + 1):
                    n = base * merge ** lev
                    if n not in bent:
                        bent[n] = 0.0 if track is None else track(n)
                    err = 10.0 * math.log10((1.0 + data_share) * (lev + 1) * stage + data_error + bent[n])
                    reach = min(reach, err)
                    if err <= error_db:
                        cost = cost or cost_at(os_, kern)
                        c = cost(base, lev)
                        best = (c, os_, base, lev, kern) if best is None or c < best[0] else best
    if best is None:
        raise ConfigError("error_db", f"must be >= {reach:.1f} dB (the least error a {' / '.join(kernels)} plan "
                                      f"predicts at os <= {OVERSAMPLE_CHOICES[-1]}"
                                      f"{' on this track' if max(bent.values(), default=0.0) > 1e-12 else ''}), got {error_db!r}")
    return best[1], best[2], best[3], best[4]


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
    margin = max(POLAR_MARGIN, taps // 2 + 1)                         # polar_margin
    n_r = np.ptp(r) * 2.0 * bw * os_ / _C + 2 * margin
    eval_cost = _EVAL_COST_FIXED + _EVAL_COST_TAP * taps * taps
    step_cost = merge_cost(taps, merge, two_pass)

    def n_u(n_pulses):
        return np.ptp(u) * 2.0 * n_pulses * spacing * os_ / lam_eff + 2 * margin

    def cost(base, levels):
        total = p * n_r * n_u(base)                                  # level-0 exact formation
        for lev in range(1, levels + 1):
            size = base * merge ** lev
            total += step_cost * (p / size) * n_r * n_u(size) * merge
        return total + eval_cost * n_pix * math.ceil(p / (base * merge ** levels))

    return cost


