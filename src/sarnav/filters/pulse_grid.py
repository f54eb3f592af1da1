"""The up-sampled ("interpolated") time vector, the navigation frame the filters work in, and the spline baseline.

Sun (2022) §3.3-3.5 (extraction seed-003 §2.11-2.13): a SAR image needs the antenna position at every pulse
(kHz) while the IMU gives 100-200 Hz and the absolute fix 20 Hz. The filters are *propagated* on an
up-sampled time vector with a zero-order hold on the latest IMU sample (L750); it is the time vector that is
interpolated, not the positions. :func:`build_grid` makes that vector: the sorted union of the output (pulse)
times, the IMU sample times and the fix times inside a window, with, for each epoch, the index of the IMU
sample held over the following sub-interval (the latest sample at or before the epoch: causal zero-order hold,
gap G11) and the index of a fix taken there.

Because the hold is causal, an IMU interval split into sub-steps propagates exactly as the unsplit interval
(constant input over the interval), so the up-sampled filter agrees with the non-interpolated one at the IMU
epochs (claim T10) up to rounding.

:class:`NavFrame` says which world a filter lives in: ``flat`` (the sources' flat, non-rotating NED tangent
frame with constant gravity, positions in metres) or ``geodetic`` (WGS-84, positions as latitude, longitude,
height; the linear filters then work in curvilinear local metres about an origin:
``x_N = (L - L0)(R_N0 + h0)``, ``x_E = (lambda - lambda0)(R_E0 + h0) cos L0``, ``x_D = -(h - h0)``, gap G6).

Naive baseline (the source's spline comparison, L1353-1370): :func:`spline_positions`, a cubic spline
(scipy) through positions given at a low rate (the 20 Hz fixes, or a 200 Hz filter output), evaluated at the
pulse times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from sarnav.errors import InputDataError
from sarnav.frames.wgs84 import geodetic_difference_ned, radii_of_curvature

#: two epochs closer than this are one epoch [s] (timestamps of different sensors on one clock)
TIME_TOLERANCE = 1e-9


@dataclass(frozen=True)
class ImuStream:
    """IMU samples of R runs: ``times`` (M,) [s], ``specific_force`` f^b and ``angular_rate`` omega_ib^b
    (R, M, 3) [m/s^2, rad/s]."""

    times: np.ndarray
    specific_force: np.ndarray
    angular_rate: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.times, dtype=float)
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputDataError("imu.time", "must be a finite, strictly increasing 1-D array")
        for name in ("specific_force", "angular_rate"):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.ndim != 3 or a.shape[1:] != (t.size, 3):
                raise InputDataError(f"imu.{name}", f"must have shape (runs, {t.size}, 3), got {a.shape}")
            if not np.all(np.isfinite(a)):
                r, k, _ = np.argwhere(~np.isfinite(a))[0]
                raise InputDataError(f"imu.{name}", f"NaN/inf IMU sample (run {r}, sample {k}, t={t[k]} s)")


@dataclass(frozen=True)
class FixStream:
    """Absolute position fixes: ``times`` (K,) [s], ``position`` (R, K, 3) in the frame's native coordinates
    (metres NED, or lat [rad], lon [rad], h [m]), ``sigma`` (3,) per-axis NED standard deviation [m]."""

    times: np.ndarray
    position: np.ndarray
    sigma: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.times, dtype=float)
        if t.ndim != 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputDataError("fix.time", "must be a finite, strictly increasing 1-D array")
        p = np.asarray(self.position, dtype=float)
        if p.ndim != 3 or p.shape[1:] != (t.size, 3) or not np.all(np.isfinite(p)):
            raise InputDataError("fix.position", f"must be finite with shape (runs, {t.size}, 3), got {p.shape}")
        s = np.asarray(self.sigma, dtype=float)
        if s.shape != (3,) or not np.all(s > 0) or not np.all(np.isfinite(s)):
            raise InputDataError("fix.sigma", f"must be 3 finite standard deviations > 0 m, got {s!r}")


@dataclass(frozen=True)
class Grid:
    """Epochs of one window: ``t`` (T,) [s]; ``imu`` (T,) index of the IMU sample held from t[k] to t[k+1];
    ``imu_new`` (T,) bool, an IMU sample arrives at t[k]; ``fix`` (T,) index of the fix taken at t[k] or -1;
    ``out`` (T,) bool, t[k] is an output (pulse) epoch."""

    t: np.ndarray
    imu: np.ndarray
    imu_new: np.ndarray
    fix: np.ndarray
    out: np.ndarray


def _match(grid_t, times):
    """Index into grid_t of every time (all present by construction)."""
    k = np.searchsorted(grid_t, times - TIME_TOLERANCE)
    return k


def build_grid(t_start: float, t_end: float, imu_times, fix_times=(), output_times=()) -> Grid:
    """The up-sampled time vector on [t_start, t_end] (module docstring).

    Parameters
    ----------
    imu_times : IMU sample times; one must be at or before ``t_start`` (the sample held at the start).
    fix_times : fix times (those inside the window are used; at ``t_start`` too).
    output_times : pulse / output times (inside the window).
    """
    imu_times = np.asarray(imu_times, dtype=float)
    if not t_end > t_start:
        raise InputDataError("grid.t_end", f"must be > t_start={t_start}, got {t_end}")
    if imu_times.size == 0 or imu_times[0] > t_start + TIME_TOLERANCE:
        raise InputDataError("imu.time", f"need an IMU sample at or before the window start {t_start} s")
    gaps = np.diff(imu_times)
    if gaps.size == 0 or imu_times[-1] < t_end - 1.5 * np.median(gaps):
        raise InputDataError("imu.time", f"IMU samples end at {imu_times[-1]} s, before the window end {t_end} s")
    if gaps.size and np.any(gaps > 1.5 * np.median(gaps)):
        k = int(np.argmax(gaps > 1.5 * np.median(gaps)))
        raise InputDataError("imu.time", f"gap of {gaps[k]} s after t={imu_times[k]} s (missing IMU samples)")
    sel = lambda a: a[(a >= t_start - TIME_TOLERANCE) & (a <= t_end + TIME_TOLERANCE)]  # noqa: E731
    fix_times = np.asarray(fix_times, dtype=float)
    output_times = np.asarray(output_times, dtype=float)
    parts = [np.array([t_start, t_end]), sel(imu_times), sel(fix_times), sel(output_times)]
    t = np.sort(np.concatenate(parts))
    keep = np.concatenate([[True], np.diff(t) > TIME_TOLERANCE])
    t = t[keep]
    held = np.searchsorted(imu_times, t + TIME_TOLERANCE, side="right") - 1
    imu_new = np.zeros(t.size, dtype=bool)
    imu_new[_match(t, sel(imu_times))] = True
    fix = np.full(t.size, -1, dtype=np.int64)
    fsel = np.flatnonzero((fix_times >= t_start - TIME_TOLERANCE) & (fix_times <= t_end + TIME_TOLERANCE))
    fix[_match(t, fix_times[fsel])] = fsel
    out = np.zeros(t.size, dtype=bool)
    out[_match(t, sel(output_times))] = True
    return Grid(t, held.astype(np.int64), imu_new, fix, out)


def uniform_times(t_start: float, t_end: float, rate: float) -> np.ndarray:
    """t_start, t_start + 1/rate, ... <= t_end (e.g. pulse times at the PRF), computed as k / rate + t_start."""
    n = int(np.floor((t_end - t_start) * rate + 1e-9)) + 1
    return t_start + np.arange(n) / rate


@dataclass(frozen=True)
class NavFrame:
    """World of a filter: ``geodetic`` False -> flat NED metres with constant gravity ``gravity``; True ->
    WGS-84 with native positions (lat, lon, h) and curvilinear local metres about ``origin`` (lat0, lon0, h0)."""

    geodetic: bool = False
    origin: tuple = (0.0, 0.0, 0.0)
    gravity: float = 9.81

    def scales(self):
        """(R_N0 + h0, (R_E0 + h0) cos L0) [m/rad]."""
        lat0, _, h0 = self.origin
        rn, re = radii_of_curvature(lat0)
        return float(rn + h0), float((re + h0) * np.cos(lat0))

    def to_local(self, pos) -> np.ndarray:
        """Native positions (..., 3) -> local metres (..., 3)."""
        pos = np.asarray(pos, dtype=float)
        if not self.geodetic:
            return pos.copy()
        (sn, se), (lat0, lon0, h0) = self.scales(), self.origin
        return np.stack([(pos[..., 0] - lat0) * sn, (pos[..., 1] - lon0) * se, -(pos[..., 2] - h0)], -1)

    def to_native(self, local) -> np.ndarray:
        """Local metres (..., 3) -> native positions (..., 3) (the inverse of :meth:`to_local`)."""
        local = np.asarray(local, dtype=float)
        if not self.geodetic:
            return local.copy()
        (sn, se), (lat0, lon0, h0) = self.scales(), self.origin
        return np.stack([lat0 + local[..., 0] / sn, lon0 + local[..., 1] / se, h0 - local[..., 2]], -1)

    def error_ned(self, estimate, truth) -> np.ndarray:
        """estimate - truth in NED metres (..., 3), both native."""
        estimate, truth = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
        if not self.geodetic:
            return estimate - truth
        return geodetic_difference_ned(estimate[..., 0], estimate[..., 1], estimate[..., 2],
                                       truth[..., 0], truth[..., 1], truth[..., 2])


@dataclass
class GridOutput:
    """Filter output at the output epochs: ``times`` (T,), ``position`` (R, T, 3) native, ``velocity``
    (R, T, 3) NED [m/s], ``quaternion`` (R, T, 4) q_b^n; at the fix epochs ``fix_times`` (K,) and
    ``position_cov`` (R, K, 3, 3) [m^2] (KF covariance, or the particle cloud's sample covariance after the
    update), ``fix_position`` (R, K, 3) native estimate after the update."""

    times: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    quaternion: np.ndarray
    fix_times: np.ndarray
    fix_position: np.ndarray
    position_cov: np.ndarray

    @staticmethod
    def concatenate(parts) -> "GridOutput":
        parts = list(parts)
        cat = lambda name, ax: np.concatenate([getattr(p, name) for p in parts], axis=ax)  # noqa: E731
        return GridOutput(cat("times", 0), cat("position", 1), cat("velocity", 1), cat("quaternion", 1),
                          cat("fix_times", 0), cat("fix_position", 1), cat("position_cov", 1))


def spline_positions(times, positions, query_times) -> np.ndarray:
    """Cubic spline (scipy ``CubicSpline``, not-a-knot) through ``positions`` (R, M, 3) given at ``times``
    (M,), evaluated at ``query_times`` (T,) -> (R, T, 3). The naive baseline of L1353-1370 (spline of the
    20 Hz fixes, or of a 200 Hz filter output); for geodetic positions it interpolates lat, lon, h."""
    times = np.asarray(times, dtype=float)
    positions = np.asarray(positions, dtype=float)
    if positions.ndim != 3 or positions.shape[1] != times.size or times.size < 4:
        raise InputDataError("spline.positions", f"need (runs, {times.size} >= 4, 3) positions, got {positions.shape}")
    q = np.asarray(query_times, dtype=float)
    if q.min() < times[0] - TIME_TOLERANCE or q.max() > times[-1] + TIME_TOLERANCE:
        raise InputDataError("spline.query_times", f"must lie in [{times[0]}, {times[-1]}] s (no extrapolation)")
    return np.moveaxis(CubicSpline(times, np.moveaxis(positions, 1, 0), axis=0)(q), 0, 1)


class GridFilter:
    """Common driver of the filters on the up-sampled grid: propagate epoch by epoch between fixes (a numba
    kernel per block), update at each fix, record the output epochs. Subclasses implement
    ``_propagate(grid, a, b, imu)`` (epochs a..b, returns native positions, velocities, quaternions at a..b),
    ``_update(z_native (R, 3), sigma (3,))`` and ``_position_cov()`` (R, 3, 3)."""

    frame: NavFrame

    def _start(self, t0):
        self.t = float(t0)
        self._emit_start = True

    def run(self, imu: ImuStream, t_end: float, fixes: FixStream | None = None, output_times=()) -> GridOutput:
        """Propagate from the current time to ``t_end``; fixes strictly after the current time are applied;
        outputs at ``output_times`` in (current, t_end] (and at the current time on the first call)."""
        fix_times = np.empty(0) if fixes is None else fixes.times
        fix_times = fix_times[fix_times > self.t + TIME_TOLERANCE]
        grid = build_grid(self.t, float(t_end), imu.times, fix_times, output_times)
        fix_idx = np.full(grid.t.size, -1, dtype=np.int64)
        if fixes is not None:
            k = grid.fix >= 0
            fix_idx[k] = np.searchsorted(fixes.times, fix_times[grid.fix[k]] - TIME_TOLERANCE)
        stops = np.unique(np.concatenate([[0], np.flatnonzero(fix_idx >= 0), [grid.t.size - 1]]))
        out_t, pos, vel, quat, f_t, f_pos, f_cov = [], [], [], [], [], [], []
        if self._emit_start and grid.out[0]:
            p0, v0, q0 = self._propagate(grid, 0, 0, imu)
            out_t.append(grid.t[:1]), pos.append(p0), vel.append(v0), quat.append(q0)
        self._emit_start = False
        for a, b in zip(stops[:-1], stops[1:]):
            p, v, q = self._propagate(grid, a, b, imu)
            k = fix_idx[b]
            if k >= 0:
                self._update(fixes.position[:, k], fixes.sigma)
                p[:, -1], v[:, -1], q[:, -1] = self._current()
                f_t.append(grid.t[b:b + 1]), f_pos.append(p[:, -1:]), f_cov.append(self._position_cov()[:, None])
            sel = grid.out[a + 1:b + 1]
            out_t.append(grid.t[a + 1:b + 1][sel]), pos.append(p[:, 1:][:, sel])
            vel.append(v[:, 1:][:, sel]), quat.append(q[:, 1:][:, sel])
        self.t = float(grid.t[-1])
        runs = imu.specific_force.shape[0]
        cat = lambda xs, shape: np.concatenate(xs, axis=1) if xs else np.zeros((runs, 0) + shape)  # noqa: E731
        return GridOutput(np.concatenate(out_t) if out_t else np.zeros(0), cat(pos, (3,)), cat(vel, (3,)),
                          cat(quat, (4,)), np.concatenate(f_t) if f_t else np.zeros(0), cat(f_pos, (3,)),
                          cat(f_cov, (3, 3)))
