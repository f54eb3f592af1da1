"""The timeline of a recorded flight for ``sarnav navigate``: covariance steps, update intervals, bridged gaps.

Steps and intervals are defined by time, not by sample count, so that a jittered clock, dropped samples and gaps
put every event at its time (docs/navigate.md, "Timeline"): the step epochs are t0 + j ``COV_STEP`` (t0 the IMU
sample at ``initial.time_s``) and each is taken to the last IMU sample at or before it (within half a nominal
sample interval, so a jittered sample near the epoch is that epoch's sample); interval u runs from epoch 10u to
epoch 10(u + 1) (``UPDATE_SECONDS``) through the distinct samples of its epochs, and its update is at its last
sample. On a uniform clock this is every ``rate_hz COV_STEP``-th sample (the campaign's steps, bit for bit).

**Gaps.** An interval between two IMU samples longer than ``MAX_GAP_INTERVALS`` nominal intervals (a jittered
clock and single dropped samples stay below it) is a gap. Gaps up to the navigator's ``max_gap`` are bridged: the
INS integrates across them with the trapezoid rule between the bounding samples (the three-point rule tends to it
when the previous interval is long, ``ins.strapdown``), and the covariance is grown for what the log does not say
about the motion inside the gap (:func:`gap_noise`). Longer gaps are refused with the time named.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.ins.strapdown import MAX_GAP_INTERVALS
from sarnav.navigation.sar_navigator import COV_STEP, STATE_LAYOUT, UPDATE_SECONDS
from sarnav.recording.fields import MANIFEST
from sarnav.recording.recording import Recording

__all__ = ["FlightPlan", "Gap", "plan_flight", "gap_noise", "STEPS_PER_UPDATE"]

#: covariance steps per update interval
STEPS_PER_UPDATE = int(round(UPDATE_SECONDS / COV_STEP))


@dataclass(frozen=True)
class Gap:
    """A bridged gap: after IMU sample ``after`` (its index in the log), ``seconds`` long until the next sample;
    ``Q`` (n, n): the covariance added for it (:func:`gap_noise`); ``accel_sigma`` [m/s^2] and ``gyro_sigma``
    [rad/s]: the spread of the log's motion around it that sized Q."""

    after: int
    time: float
    seconds: float
    accel_sigma: float
    gyro_sigma: float
    Q: np.ndarray


@dataclass(frozen=True)
class FlightPlan:
    """What each update of a recording integrates and fuses (:func:`plan_flight`).

    k0 : the IMU sample at the initial time; bounds : per update interval u, the IMU samples (log indices) of its
    covariance steps' ends, from its first sample to its last (one entry: the interval holds no sample, e.g. inside
    a gap: no update); altimeter : (U,) index into the altimeter log of the value fused at each update (-1: none);
    aperture : (U,) the aperture fused at each update (-1: none); gnss : (U,) the GNSS fix fused at each update
    (-1: none); skipped : [(aperture, reason)] of the apertures no interval holds; altimeter_unused, gnss_unused :
    values not at an update epoch (or after ``gnss_until``); gaps : the bridged gaps; uniform : the clock is uniform
    (every step ``rate_hz COV_STEP`` samples)."""

    k0: int
    bounds: tuple
    altimeter: np.ndarray
    aperture: np.ndarray
    gnss: np.ndarray
    skipped: list
    altimeter_unused: int
    gnss_unused: int
    gaps: tuple
    uniform: bool

    @property
    def n_updates(self) -> int:
        return len(self.bounds)

    def bridge(self, u: int) -> dict:
        """{step of interval u: the covariance added after it} for the gaps inside interval u's steps."""
        b, out = self.bounds[u], {}
        for gap in self.gaps:
            s = int(np.searchsorted(b, gap.after, side="right")) - 1
            if 0 <= s < b.size - 1:
                out[s] = out.get(s, 0.0) + gap.Q
        return out


def gap_noise(t, nu, omega, k: int, layout=STATE_LAYOUT) -> tuple[float, float, np.ndarray]:
    """(accel 1-sigma, gyro 1-sigma, Q) for the gap between samples k and k + 1 of the log (t, nu, omega).

    Inside a gap of T seconds the INS integrates the chord between the bounding samples; the truth departs from it
    by what the vehicle did meanwhile, which the log does not say. Its size is taken from the log itself: the RMS
    departure of the samples from their own straight-line fit over T seconds on each side of the gap (at least 5
    samples each; sensor noise included, which also covers the noise of the two bounding samples), the largest axis
    (sigma_f, sigma_w). Modelled as a constant error over the gap (the conservative, fully correlated case):
    dv = e T, dp = e T^2 / 2, dth = e_w T, and the attitude error's tilt of the specific force
    |f| sigma_w T^2 / 2 in velocity (T^3 / 6 in position), added independently per axis."""
    T = float(t[k + 1] - t[k])
    spreads_f, spreads_w = [], []
    for side in (np.flatnonzero((t >= t[k] - T) & (t <= t[k]))[-64:], np.flatnonzero((t >= t[k + 1]) &
                                                                                       (t <= t[k + 1] + T))[:64]):
        if side.size < 5:
            side = np.arange(max(k - 4, 0), k + 1) if side[-1] == k else np.arange(k + 1, min(k + 6, t.size))
        x = t[side] - t[side].mean()
        for values, out in ((nu[side], spreads_f), (omega[side], spreads_w)):
            if side.size < 3:
                out.append(np.std(values, axis=0).max())
                continue
            coef = np.polyfit(x, values, 1)
            res = values - (coef[0][None] * x[:, None] + coef[1][None])
            out.append(float(np.sqrt(np.mean(res * res, axis=0)).max()))
    sf, sw = max(spreads_f), max(spreads_w)
    g = float(np.linalg.norm(0.5 * (nu[k] + nu[k + 1])))
    n = layout.n
    Q = np.zeros((n, n))
    p, v, th = layout.slice("p"), layout.slice("v"), layout.slice("th")
    eye = np.eye(3)
    tilt_v, tilt_p = g * sw * T * T / 2.0, g * sw * T ** 3 / 6.0
    Q[p, p] = (sf * sf * T ** 4 / 4.0 + tilt_p * tilt_p) * eye
    Q[v, v] = (sf * sf * T * T + tilt_v * tilt_v) * eye
    Q[p, v] = Q[v, p] = (sf * sf * T ** 3 / 2.0 + tilt_p * tilt_v) * eye
    Q[th, th] = sw * sw * T * T * eye
    return sf, sw, Q


def _gaps(rec: Recording, t, nu, om, k0: int, max_gap: float) -> tuple:
    """The gaps of the log after sample k0, bridged (:class:`Gap`) or refused (InputDataError naming the row)."""
    name, nominal = rec.manifest.imu.file, 1.0 / rec.manifest.imu.rate_hz
    dt = np.diff(t[k0:])
    out = []
    for j in np.flatnonzero(dt > MAX_GAP_INTERVALS * nominal):
        k = int(k0 + j)
        if dt[j] > max_gap:
            raise InputDataError(f"{name}:{k + 3}:time_s", f"a gap of {dt[j]:.6g} s after t = {float(t[k]):.6f} s "
                                 f"(line {k + 2}; recording time) is longer than the navigator bridges (ins.max_gap_s = {max_gap:g} s)")
        sf, sw, Q = gap_noise(t, nu, om, k)
        out.append(Gap(k, float(t[k]), float(dt[j]), sf, sw, Q))
    return tuple(out)


def _epoch_samples(t, k0: int, tol: float) -> np.ndarray:
    """Per step epoch t0 + j COV_STEP (j = 0 .. while inside the log), the last sample at or before it (+ tol)."""
    t0 = t[k0]
    n_epochs = int(np.floor((t[-1] - t0 + tol) / COV_STEP + 1e-9)) + 1
    n_epochs -= (n_epochs - 1) % STEPS_PER_UPDATE  # whole intervals
    epochs = t0 + COV_STEP * np.arange(n_epochs)
    return np.searchsorted(t, epochs + tol, side="right") - 1


def plan_flight(rec: Recording, sar: bool = True, max_gap: float = 1.0, gnss_until: float | None = None) -> FlightPlan:
    """The timeline of ``rec`` (module docstring): its intervals, their steps and what each update fuses. ``sar``
    False: no aperture is fused (all listed as skipped); ``max_gap`` [s]: the longest gap bridged; ``gnss_until``
    [s]: GNSS fixes up to this time are fused (None: none)."""
    m_info = rec.manifest.imu
    t, nu, om = rec.imu.rates()
    t0, tol = rec.manifest.initial.time, 0.5 / m_info.rate_hz
    k0 = int(np.argmin(np.abs(t - t0)))
    if not abs(t[k0] - t0) <= tol:
        raise InputDataError(f"{m_info.file}:time_s", f"no IMU sample at the initial time {t0!r} s "
                             f"({MANIFEST}:initial.time_s; the nearest is at {t[k0]!r} s)")
    if not (np.isfinite(max_gap) and max_gap > 0):
        raise ConfigError("ins.max_gap_s", f"must be finite and > 0 s, got {max_gap!r}")
    gaps = _gaps(rec, t, nu, om, k0, max_gap)
    idx = _epoch_samples(t, k0, tol)
    n_upd = (idx.size - 1) // STEPS_PER_UPDATE
    if n_upd < 1:
        raise InputDataError(f"{m_info.file}:time_s", f"holds {t[-1] - t[k0]:.6g} s after the initial time, less "
                             f"than one {UPDATE_SECONDS:g}-s interval")
    bounds = tuple(np.unique(idx[u * STEPS_PER_UPDATE:(u + 1) * STEPS_PER_UPDATE + 1]) for u in range(n_upd))
    c = int(round(m_info.rate_hz * COV_STEP))
    uniform = abs(m_info.rate_hz * COV_STEP - c) <= 1e-9 * m_info.rate_hz and bool(
        np.array_equal(idx, k0 + c * np.arange(idx.size)))
    edges = t[idx[::STEPS_PER_UPDATE]]
    ends = np.array([t[b[-1]] if b.size > 1 else np.nan for b in bounds])
    alt, alt_unused = _at_updates(None if rec.altimeter is None else rec.altimeter.time, ends, tol)
    g_times = None if (rec.gnss is None or gnss_until is None) else rec.gnss.time
    fix, gnss_unused = _at_updates(g_times, ends, tol, until=gnss_until)
    aperture, skipped = _apertures(rec, sar, edges, ends, tol)
    return FlightPlan(k0, bounds, alt, aperture, fix, skipped, alt_unused, gnss_unused, gaps, uniform)


def _at_updates(times, ends, tol: float, until: float | None = None) -> tuple[np.ndarray, int]:
    """(U,) index of the value recorded at each update epoch (within tol; -1: none) and the count of values not
    used (not at an update epoch, a second one at an epoch, or after ``until``)."""
    out = np.full(ends.size, -1, dtype=np.int64)
    if times is None:
        return out, 0
    unused = 0
    finite = np.where(np.isfinite(ends), ends, np.inf)
    for i, ta in enumerate(times):
        u = int(np.argmin(np.abs(finite - ta)))
        if abs(finite[u] - ta) <= tol and out[u] < 0 and (until is None or ta <= until + tol):
            out[u] = i
        else:
            unused += 1
    return out, unused


def _apertures(rec: Recording, sar: bool, edges, ends, tol: float) -> tuple[np.ndarray, list]:
    """(U,) the aperture fused at each update (-1: none) and [(aperture, reason)] of those no interval holds."""
    n_upd = ends.size
    aperture, skipped = np.full(n_upd, -1, dtype=np.int64), []
    offset = rec.manifest.time.radar_clock_offset
    for i, ap in enumerate(rec.manifest.apertures):
        a, b = ap.start + offset, ap.end + offset
        u = int(np.searchsorted(edges, a + tol, side="right")) - 1
        if not sar:
            skipped.append((i, "SAR is off (sar.enabled = false)"))
        elif not (0 <= u < n_upd and b <= ends[u] + tol):
            skipped.append((i, f"its pulses [{a:.6g}, {b:.6g}] s are not inside one navigation interval (1-s "
                               f"intervals of IMU samples from {edges[0]:.6g} s to {edges[-1]:.6g} s)"))
        elif aperture[u] >= 0:
            skipped.append((i, f"interval {u} holds aperture {aperture[u]} already"))
        else:
            aperture[u] = i
    return aperture, skipped
