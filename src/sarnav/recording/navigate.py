"""``sarnav navigate``: the SAR-aided navigator on a recorded flight (docs/navigate.md).

The recording is the navigator's only source (docs/recording.md): the initial estimate and its 1-sigma from the
manifest's ``[initial]``, then, GPS-denied, the IMU log integrated by the strapdown INS (``Navigator.propagate``,
covariance steps of ``COV_STEP``), and at the end of every 1-s interval one update
(``navigation.sar_navigator.SarNavigator``, the loop the rda-nav campaign runs): the altimeter value recorded at that
epoch and the (range, cross-range) pairs of the aperture recorded inside the interval, each image formed from the
aperture's recorded pulses along the navigator's *own* estimated track of the interval (the file's antenna positions
are never used for them; the recorded pulse times and the reference pass's trusted positions are), with R from each
image, the screening and the gate of rda-nav.

The timeline (:func:`plan_flight`): interval u spans IMU samples k0 + u m .. k0 + (u + 1) m (m = round(rate_hz)
samples, k0 the sample at ``initial.time_s``); its update is at the time of its last sample. An altimeter value is
fused at the update epoch it was recorded at (within half an IMU interval); an aperture in the interval that holds
all its pulses. What does not fit (an aperture across two intervals, a second aperture in one interval, altimeter
values between update epochs) is not fused and is recorded; an aperture whose images cannot be formed (its reference
does not cover it, a file that does not read) is skipped and recorded, never an abort.

Results (:class:`Navigation`): the estimate and its covariance at every step epoch (every ``COV_STEP``), every
update's residuals and NIS, every pair's measurement and status. ``navigate`` fills a :class:`Navigation` it is
handed as it goes, so an interrupted run leaves what was done.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError, InputDataError, SarnavError
from sarnav.frames import earth_rate_tangent
from sarnav.ins import NavState
from sarnav.measurements.sar_aperture import STAGES, ImagingSettings
from sarnav.navigation import Navigator, error_model
from sarnav.navigation.sar_aiding import REJECTIONS, SarUpdateSettings
from sarnav.navigation.sar_navigator import COV_STEP, STATE_LAYOUT, UPDATE_SECONDS, SarNavigator
from sarnav.recording.fields import MANIFEST
from sarnav.recording.recording import Recording
from sarnav.sensors.imu import ImuSpec

__all__ = ["NavigateSettings", "Navigation", "FlightPlan", "navigate", "plan_flight", "STATE_LAYOUT", "COV_STEP",
           "UPDATE_SECONDS", "SKIPPED", "REJECTIONS", "pair_status"]

#: status code of a pair whose aperture was skipped (no image formed); codes >= 0 are ``sar_aiding.REJECTIONS``
SKIPPED = -1


def pair_status(code: int) -> str:
    """The words of a pair's status code: "fused", a rejection of ``sar_aiding.REJECTIONS``, or "skipped"."""
    return "skipped" if code == SKIPPED else (REJECTIONS[code] or "fused")


@dataclass(frozen=True)
class NavigateSettings:
    """The navigator's settings (``--config nav.toml`` / ``--set``; defaults those of the rda-nav scenario).

    sar : how the SAR pairs are modelled and screened (``navigation.sar_aiding``; its ``geolocation_sigma`` is
        replaced by the recording's map 1-sigma of each point); None: no SAR (INS + altimeter).
    imaging : the extractor's settings (RDA or BPA, focus, autofocus, match thresholds).
    sar_bias_sigma, sar_bias_tau : (2,) steady-state 1-sigma [m] and correlation time [s] of the SAR range and
        cross-range biases (first-order Gauss-Markov states; the altimeter's come from the manifest).
    imu_filter : the filter's model of the IMU (None: the manifest's ``[imu]``).
    earth_modelled : the filter models the Earth's rotation when the recording's IMU senses it
        (``frame.earth_rotation``), at the origin's latitude.
    """

    sar: SarUpdateSettings | None = field(default_factory=lambda: SarUpdateSettings(sar_sigma=np.full(2, 0.25)))
    imaging: ImagingSettings = field(default_factory=ImagingSettings)
    sar_bias_sigma: np.ndarray = field(default_factory=lambda: np.full(2, 0.25 / 3.0))
    sar_bias_tau: np.ndarray = field(default_factory=lambda: np.full(2, 3600.0))
    imu_filter: ImuSpec | None = None
    earth_modelled: bool = True


@dataclass(frozen=True)
class FlightPlan:
    """What each update of a recording fuses (:func:`plan_flight`).

    k0 : the IMU sample at the initial time; m, c : IMU samples per update interval and per covariance step;
    n_updates : full intervals in the log; altimeter : (U,) index into the altimeter log of the value fused at each
    update (-1: none); aperture : (U,) the aperture fused at each update (-1: none); skipped : [(aperture, reason)]
    of the apertures no interval holds; altimeter_unused : altimeter values not at an update epoch.
    """

    k0: int
    m: int
    c: int
    n_updates: int
    altimeter: np.ndarray
    aperture: np.ndarray
    skipped: list
    altimeter_unused: int


def plan_flight(rec: Recording, sar: bool = True) -> FlightPlan:
    """The timeline of ``rec`` (module docstring): its intervals and what each update fuses. ``sar`` False: no
    aperture is fused (all listed as skipped)."""
    m_info = rec.manifest.imu
    rate = m_info.rate_hz
    m, c = int(round(rate * UPDATE_SECONDS)), int(round(rate * COV_STEP))
    if c < 1 or abs(rate * COV_STEP - c) > 1e-9 * rate or m % c:
        raise ConfigError(f"{MANIFEST}:imu.rate_hz", f"navigate integrates in {COV_STEP:g}-s covariance steps: needs "
                          f"a multiple of {1 / COV_STEP:g} Hz, got {rate!r}")
    t, _, _ = rec.imu.rates()
    t0, tol = rec.manifest.initial.time, 0.5 / rate
    k0 = int(np.argmin(np.abs(t - t0)))
    if not abs(t[k0] - t0) <= tol:
        raise InputDataError(f"{m_info.file}:time_s", f"no IMU sample at the initial time {t0!r} s "
                             f"({MANIFEST}:initial.time_s; the nearest is at {t[k0]!r} s)")
    n_upd = (t.size - 1 - k0) // m
    if n_upd < 1:
        raise InputDataError(f"{m_info.file}:time_s", f"holds {t.size - 1 - k0} samples after the initial time, fewer "
                             f"than one {UPDATE_SECONDS:g}-s interval ({m} samples at imu.rate_hz)")
    edges = t[k0 + m * np.arange(n_upd + 1)]
    alt, unused = np.full(n_upd, -1, dtype=np.int64), 0
    if rec.altimeter is not None:
        for i, ta in enumerate(rec.altimeter.time):
            u = int(np.argmin(np.abs(edges[1:] - ta)))
            if abs(edges[u + 1] - ta) <= tol and alt[u] < 0:
                alt[u] = i
            else:
                unused += 1
    aperture, skipped = np.full(n_upd, -1, dtype=np.int64), []
    offset = rec.manifest.time.radar_clock_offset
    for i, ap in enumerate(rec.manifest.apertures):
        a, b = ap.start + offset, ap.end + offset
        u = int(np.searchsorted(edges, a + tol, side="right")) - 1
        if not sar:
            skipped.append((i, "SAR is off (sar.enabled = false)"))
        elif not (0 <= u < n_upd and b <= edges[u + 1] + tol):
            skipped.append((i, f"its pulses [{a:.6g}, {b:.6g}] s are not inside one navigation interval (1-s "
                               f"intervals of IMU samples from {edges[0]:.6g} s to {edges[-1]:.6g} s)"))
        elif aperture[u] >= 0:
            skipped.append((i, f"interval {u} holds aperture {aperture[u]} already"))
        else:
            aperture[u] = i
    return FlightPlan(k0, m, c, n_upd, alt, aperture, skipped, unused)


@dataclass
class Navigation:
    """What :func:`navigate` made (so far): per output epoch (every ``COV_STEP``) ``time`` and the estimate
    ``p, v, q, ba, bg, bm`` with its covariance ``P``; per update ``updates`` (dicts: time, aperture, z, residual,
    residual_sigma, nis, nis_dof, rejected, pairs_fused, seconds: wall time per stage: "propagate" the interval's
    INS and covariance, "images" the extractor's whole work, of which its ``STAGES`` "rda", "autofocus",
    "registration" on the in-flight image, "update"); per aperture and point ``pairs`` (dicts: the update's time,
    aperture, point, the image's toc, range, cross-range, sigma, correlation, ambiguity, status code, reason,
    residual and its sigma); ``plan``; ``notices``; ``complete`` once every update is done."""

    layout: object = STATE_LAYOUT
    targets: int = 0
    plan: FlightPlan | None = None
    time: list = field(default_factory=list)
    states: list = field(default_factory=list)
    P: list = field(default_factory=list)
    updates: list = field(default_factory=list)
    pairs: list = field(default_factory=list)
    notices: list = field(default_factory=list)
    complete: bool = False

    def record(self, t: float, nav: NavState, P) -> None:
        self.time.append(float(t))
        self.states.append(np.concatenate([nav.p[0], nav.v[0], nav.q[0], nav.ba[0], nav.bg[0], nav.bm[0]]))
        self.P.append(np.array(P[0]))

    def estimate(self) -> dict:
        """Arrays of the epochs recorded: ``time`` (K,), ``p``, ``v`` (K, 3), ``q`` (K, 4), ``ba``, ``bg``, ``bm``
        (K, 3), ``P`` (K, n, n), ``sigma`` (K, n)."""
        x = np.array(self.states).reshape(-1, 19)
        P = np.array(self.P).reshape(-1, self.layout.n, self.layout.n)
        return {"time": np.array(self.time), "p": x[:, 0:3], "v": x[:, 3:6], "q": x[:, 6:10], "ba": x[:, 10:13],
                "bg": x[:, 13:16], "bm": x[:, 16:19], "P": P, "sigma": np.sqrt(np.einsum("kii->ki", P))}


def _initial(rec: Recording, settings: NavigateSettings) -> Navigator:
    """The navigator at the manifest's initial estimate (``[initial]``) with its covariance and error model."""
    m = rec.manifest
    ini = m.initial
    if ini.gnss_until is not None:
        raise ConfigError(f"{MANIFEST}:initial.gnss_until_s", "navigate does not support GNSS aiding yet: give "
                          "initial.position_ned_m and velocity_ned_mps and leave gnss_until_s out")
    if np.any(m.lever_arm != 0):
        raise ConfigError(f"{MANIFEST}:platform.lever_arm_m", "navigate does not model an antenna lever arm yet: the "
                          f"antenna must be at the IMU ([0, 0, 0]), got {m.lever_arm.tolist()}")
    alt = m.altimeter
    alt_sigma, alt_tau = (alt.bias_sigma, alt.tau) if alt is not None else (0.0, 3600.0)
    bias_sigma = np.array([alt_sigma, *settings.sar_bias_sigma], dtype=np.float64)
    bias_tau = np.array([alt_tau, *settings.sar_bias_tau], dtype=np.float64)
    s = ini.sigma
    p0 = np.concatenate([s["p"], s["v"], s["th"], s["ba"], s["bg"], bias_sigma])
    P0 = np.diag(p0**2)[None]
    imu = m.imu.spec if settings.imu_filter is None else settings.imu_filter
    earth = (earth_rate_tangent(units.deg_to_rad(float(m.frame.origin[0])))
             if m.frame.earth_rotation and settings.earth_modelled else None)
    nav0 = NavState(p=ini.p[None].copy(), v=ini.v[None].copy(), q=ini.q[None].copy(), ba=ini.ba[None].copy(),
                    bg=ini.bg[None].copy(), bm=ini.bm[None].copy())
    model = error_model(STATE_LAYOUT, imu, bias_sigma, bias_tau, earth_rate=earth)
    return Navigator(nav0, P0, model, STATE_LAYOUT, tau_accel=imu.tau_accel, tau_gyro=imu.tau_gyro,
                     bias_tau=bias_tau, earth_rate=earth, covariance_attitude="start")


def navigate(rec: Recording, settings: NavigateSettings | None = None, progress=None,
             into: Navigation | None = None) -> Navigation:
    """Navigate the recording ``rec`` (module docstring) and return the :class:`Navigation` (``into``, filled as the
    run goes, when given). ``progress(update, updates, navigation)`` is called after each update."""
    settings = NavigateSettings() if settings is None else settings
    out = Navigation() if into is None else into
    sar_on = settings.sar is not None and bool(rec.manifest.apertures)
    plan = plan_flight(rec, sar=sar_on)
    out.plan, out.targets = plan, (rec.points.anchors.shape[1] if rec.points is not None else 0)
    nv = _initial(rec, settings)
    alt_sigma = None if rec.altimeter is None else rec.manifest.altimeter.sigma
    sn = SarNavigator(nv, alt_sigma, settings.sar if sar_on else None, max(out.targets, 1), image=True)
    imager = rec.imager(settings.imaging) if sar_on else None
    for i, reason in plan.skipped:
        _skip(out, rec, i, np.nan, reason)
    if plan.altimeter_unused:
        out.notices.append(f"{plan.altimeter_unused} altimeter values are not at an update epoch (the end of a 1-s "
                           "interval) and were not used")
    t, nu, om = rec.imu.rates()
    out.record(t[plan.k0], nv.nav, nv.P)
    for u in range(plan.n_updates):
        a, t0 = plan.k0 + u * plan.m, time.perf_counter()
        iv = nv.propagate(t[a:a + plan.m + 1], nu[None, a:a + plan.m + 1], om[None, a:a + plan.m + 1], plan.c,
                          step_seconds=plan.c / rec.manifest.imu.rate_hz)
        for s, (nav_s, P_s) in enumerate(iv.estimates[:-1]):
            out.record(iv.t[s + 1], nav_s, P_s)
        _update(out, rec, sn, imager, plan, u, iv, time.perf_counter() - t0)
        out.record(iv.t[-1], nv.nav, nv.P)
        if progress is not None:
            progress(u, plan.n_updates, out)
    out.complete = True
    return out


def _update(out: Navigation, rec: Recording, sn: SarNavigator, imager, plan: FlightPlan, u: int, iv,
            seconds: float) -> None:
    """Update u: the altimeter value at its epoch and the pairs of its aperture, fused and recorded (``seconds``:
    the interval's INS and covariance)."""
    k_alt, ap = int(plan.altimeter[u]), int(plan.aperture[u])
    z_alt = None if k_alt < 0 else np.array([[rec.altimeter.altitude[k_alt]]])
    z_sar = eta = am = map_t = map_s = None
    t0 = time.perf_counter()
    if ap >= 0:
        map_t, map_s = rec.points.map[ap][None], rec.points.map_sigma[ap]
        try:
            am = sn.measure_images(imager, ap, iv, map_t)
        except (SarnavError, OSError, ValueError) as err:  # the aperture is skipped, the flight goes on
            _skip(out, rec, ap, iv.t[-1], f"images not formed: {err}")
            ap = -1
        else:
            offsets = np.zeros((1, out.targets, 2)) if rec.sar_offsets is None else rec.sar_offsets[ap][None]
            z_sar, eta = sn.image_pairs(am, iv, offsets)
    t1 = time.perf_counter()
    up = sn.update(iv, z_alt, z_sar, eta, map_t, map_s)
    if up is None:
        return
    stages = {"propagate": seconds, "images": t1 - t0, **dict.fromkeys(STAGES[1:], 0.0),
              "update": time.perf_counter() - t1}
    if am is not None:
        stages.update(zip(STAGES[1:], am.seconds[0, 1:].tolist()))
    out.updates.append({"time": float(iv.t[-1]), "aperture": ap, "altimeter": k_alt >= 0, "z": up.z[0],
                        "residual": up.fused.residual[0], "residual_sigma": up.fused.residual_sigma[0],
                        "nis": float(up.fused.nis[0]), "nis_dof": int(up.fused.dof[0]),
                        "rejected": int(up.rejected[0]), "pairs_fused": int(up.pairs_fused[0]), "seconds": stages})
    if am is not None:
        first = 0 if z_alt is None else 1
        for k in range(out.targets):
            cols = slice(first + 2 * k, first + 2 * k + 2)
            code = int(up.status[0, k])
            out.pairs.append({"time": float(iv.t[-1]), "aperture": ap, "point": k, "toc": float(am.toc[0, k]),
                              "range": float(am.range[0, k]), "z": up.z[0, cols].copy(),
                              "sigma": am.sigma[0, k].copy(), "correlation": float(am.quality[0, k]),
                              "ambiguity": float(am.ambiguity[0, k]), "code": code, "reason": pair_status(code),
                              "residual": up.fused.residual[0, cols].copy(),
                              "residual_sigma": up.fused.residual_sigma[0, cols].copy()})


def _skip(out: Navigation, rec: Recording, aperture: int, t: float, reason: str) -> None:
    nan2 = np.full(2, np.nan)
    for k in range(out.targets):
        out.pairs.append({"time": float(t), "aperture": aperture, "point": k, "toc": math.nan, "range": math.nan,
                          "z": nan2, "sigma": nan2, "correlation": math.nan, "ambiguity": math.nan, "code": SKIPPED,
                          "reason": f"skipped: {reason}", "residual": nan2, "residual_sigma": nan2})
    out.notices.append(f"aperture {aperture} ({rec.manifest.apertures[aperture].file}) skipped: {reason}")
