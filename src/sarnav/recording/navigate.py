"""``sarnav navigate``: the SAR-aided navigator on a recorded flight (docs/navigate.md).

The recording is the navigator's only source (docs/recording.md): the initial estimate and its 1-sigma from the
manifest's ``[initial]``, then, GPS-denied, the IMU log integrated by the strapdown INS (``Navigator.propagate``,
covariance steps of ``COV_STEP``), and at the end of every 1-s interval one update
(``navigation.sar_navigator.SarNavigator``, the loop the rda-nav campaign runs): the altimeter value recorded at that
epoch and the (range, cross-range) pairs of the aperture recorded inside the interval, each image formed from the
aperture's recorded pulses along the navigator's *own* estimated track of the interval (the file's antenna positions
are never used for them; the recorded pulse times and the reference pass's trusted positions are), with R from each
image, the screening and the gate of rda-nav.

The timeline (``recording.timeline.plan_flight``): covariance steps at the IMU samples of the epochs t0 + 0.1 j s,
1-s intervals of ten steps, the update at each interval's last sample (a jittered clock, dropped samples and bridged
gaps put every event at its time). An altimeter value (and, up to ``initial.gnss_until_s``, a GNSS fix) is fused at
the update epoch it was recorded at (within half an IMU interval); an aperture in the interval that holds all its
pulses. What does not fit (an aperture across two intervals, a second aperture in one interval, values between
update epochs) is not fused and is recorded; an aperture whose images cannot be formed (its reference does not cover
it, a file that does not read) is skipped and recorded, never an abort.

Results (:class:`Navigation`): the estimate and its covariance at every step epoch (every ``COV_STEP``), every
update's residuals and NIS, every pair's measurement and status. ``navigate`` fills a :class:`Navigation` it is
handed as it goes, so an interrupted run leaves what was done. With ``images``, every in-flight image formed is
handed to it as the run goes (``images(aperture, time, images)``, ``ApertureMeasurements.images``: the images
registered, the pulses and the estimated track they were focused with); its failure is a notice, never an abort.
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
from sarnav.measurements.gnss import GnssFix
from sarnav.recording.recording import Recording
from sarnav.recording.timeline import FlightPlan, plan_flight
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
    max_gap : the longest gap in the IMU log bridged [s] (``recording.timeline``; ``ins.max_gap_s``).
    """

    sar: SarUpdateSettings | None = field(default_factory=lambda: SarUpdateSettings(sar_sigma=np.full(2, 0.25)))
    imaging: ImagingSettings = field(default_factory=ImagingSettings)
    sar_bias_sigma: np.ndarray = field(default_factory=lambda: np.full(2, 0.25 / 3.0))
    sar_bias_tau: np.ndarray = field(default_factory=lambda: np.full(2, 3600.0))
    imu_filter: ImuSpec | None = None
    earth_modelled: bool = True
    max_gap: float = 1.0


@dataclass
class Navigation:
    """What :func:`navigate` made (so far): per output epoch (every ``COV_STEP``) ``time`` and the estimate
    ``p, v, q, ba, bg, bm`` with its covariance ``P``; per update ``updates`` (dicts: time, aperture, z, residual,
    residual_sigma, nis, nis_dof, rejected, pairs_fused, seconds: wall time per stage: "propagate" the interval's
    INS and covariance, "images" the extractor's whole work, of which its ``STAGES`` "rda", "autofocus",
    "registration" on the in-flight image, "update", "image_files" the ``images`` hook); per aperture and point
    ``pairs`` (dicts: the update's time, aperture, point, the image's toc, range, cross-range, sigma, correlation,
    ambiguity, status code, reason, residual and its sigma); ``plan``; ``notices``; ``complete`` once every update
    is done."""

    layout: object = STATE_LAYOUT
    targets: int = 0
    plan: FlightPlan | None = None
    time: list = field(default_factory=list)
    states: list = field(default_factory=list)
    P: list = field(default_factory=list)
    updates: list = field(default_factory=list)
    pairs: list = field(default_factory=list)
    gnss: list = field(default_factory=list)
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


def _initial_pv(rec: Recording) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Initial position and velocity with their 1-sigma: the manifest's, or, where it leaves them out (allowed with
    ``gnss_until_s``), the GNSS fix at the initial time and its stated 1-sigma."""
    ini = rec.manifest.initial
    p, v, sp, sv = ini.p, ini.v, ini.sigma["p"], ini.sigma["v"]
    if p is not None and v is not None:
        return p, v, sp, sv
    g, tol = rec.gnss, 0.5 / rec.manifest.imu.rate_hz
    k = int(np.argmin(np.abs(g.time - ini.time)))
    if not abs(g.time[k] - ini.time) <= tol:
        raise InputDataError(f"{rec.manifest.gnss_file}:time_s", f"no GNSS fix at the initial time {ini.time!r} s "
                             f"(within {tol:g} s) to start from ({MANIFEST}:initial leaves position_ned_m or "
                             f"velocity_ned_mps out); the nearest is at {g.time[k]!r} s")
    if p is None:
        p, sp = g.position[k], g.position_sigma[k]
    if v is None:
        if g.velocity is None:
            raise ConfigError(f"{MANIFEST}:initial.velocity_ned_mps", "missing: the GNSS log has no velocity "
                              f"({rec.manifest.gnss_file}: v_north_mps ...) to start from")
        v, sv = g.velocity[k], g.velocity_sigma[k]
    return p, v, sp, sv


def _initial(rec: Recording, settings: NavigateSettings) -> Navigator:
    """The navigator at the manifest's initial estimate (``[initial]``) with its covariance and error model."""
    m = rec.manifest
    ini = m.initial
    if np.any(m.lever_arm != 0):
        raise ConfigError(f"{MANIFEST}:platform.lever_arm_m", "navigate does not model an antenna lever arm yet: the "
                          f"antenna must be at the IMU ([0, 0, 0]), got {m.lever_arm.tolist()}")
    alt = m.altimeter
    alt_sigma, alt_tau = (alt.bias_sigma, alt.tau) if alt is not None else (0.0, 3600.0)
    bias_sigma = np.array([alt_sigma, *settings.sar_bias_sigma], dtype=np.float64)
    bias_tau = np.array([alt_tau, *settings.sar_bias_tau], dtype=np.float64)
    s = ini.sigma
    p, v, sp, sv = _initial_pv(rec)
    p0 = np.concatenate([sp, sv, s["th"], s["ba"], s["bg"], bias_sigma])
    P0 = np.diag(p0**2)[None]
    imu = m.imu.spec if settings.imu_filter is None else settings.imu_filter
    earth = (earth_rate_tangent(units.deg_to_rad(float(m.frame.origin[0])))
             if m.frame.earth_rotation and settings.earth_modelled else None)
    nav0 = NavState(p=np.array(p, dtype=np.float64)[None], v=np.array(v, dtype=np.float64)[None],
                    q=ini.q[None].copy(), ba=ini.ba[None].copy(), bg=ini.bg[None].copy(), bm=ini.bm[None].copy())
    model = error_model(STATE_LAYOUT, imu, bias_sigma, bias_tau, earth_rate=earth)
    return Navigator(nav0, P0, model, STATE_LAYOUT, tau_accel=imu.tau_accel, tau_gyro=imu.tau_gyro,
                     bias_tau=bias_tau, earth_rate=earth, covariance_attitude="start")


def _notices(out: Navigation, rec: Recording, plan: FlightPlan) -> None:
    for i, reason in plan.skipped:
        _skip(out, rec, i, np.nan, reason)
    if plan.altimeter_unused:
        out.notices.append(f"{plan.altimeter_unused} altimeter values are not at an update epoch (the end of a 1-s "
                           "interval) and were not used")
    if plan.gnss_unused:
        out.notices.append(f"{plan.gnss_unused} GNSS fixes are not at an update epoch up to initial.gnss_until_s "
                           "and were not used")
    for gap in plan.gaps:
        out.notices.append(f"IMU gap of {gap.seconds:.6g} s after t = {gap.time:.6g} s bridged (covariance grown "
                           f"for a motion spread of {gap.accel_sigma:.3g} m/s^2, {gap.gyro_sigma:.3g} rad/s)")


def navigate(rec: Recording, settings: NavigateSettings | None = None, progress=None,
             into: Navigation | None = None, images=None) -> Navigation:
    """Navigate the recording ``rec`` (module docstring) and return the :class:`Navigation` (``into``, filled as the
    run goes, when given). ``progress(update, updates, navigation)`` is called after each update; ``images(aperture,
    time, images)`` with the in-flight images of each aperture imaged (module docstring)."""
    settings = NavigateSettings() if settings is None else settings
    out = Navigation() if into is None else into
    sar_on = settings.sar is not None and bool(rec.manifest.apertures)
    plan = plan_flight(rec, sar=sar_on, max_gap=settings.max_gap, gnss_until=rec.manifest.initial.gnss_until)
    out.plan, out.targets = plan, (rec.points.anchors.shape[1] if rec.points is not None else 0)
    nv = _initial(rec, settings)
    alt_sigma = None if rec.altimeter is None else rec.manifest.altimeter.sigma
    sn = SarNavigator(nv, alt_sigma, settings.sar if sar_on else None, max(out.targets, 1), image=True)
    imager = rec.imager(settings.imaging) if sar_on else None
    if imager is not None:
        imager.keep_images = images is not None
    _notices(out, rec, plan)
    t, nu, om = rec.imu.rates()
    out.record(t[plan.k0], nv.nav, nv.P)
    step = COV_STEP if plan.uniform else None
    for u in range(plan.n_updates):
        b, t0 = plan.bounds[u], time.perf_counter()
        if b.size < 2:  # inside a bridged gap: the next interval integrates across it
            out.notices.append(f"update {u} skipped: its interval holds no IMU sample (a gap)")
            continue
        sl = slice(int(b[0]), int(b[-1]) + 1)
        iv = nv.propagate(t[sl], nu[None, sl], om[None, sl], None, step_seconds=step, bounds=b - b[0],
                          max_gap=settings.max_gap, bridge=plan.bridge(u))
        for s, (nav_s, P_s) in enumerate(iv.estimates[:-1]):
            out.record(iv.t[s + 1], nav_s, P_s)
        _update(out, rec, sn, imager, plan, u, iv, time.perf_counter() - t0, images)
        if plan.gnss[u] >= 0:
            _gnss_update(out, rec, nv, int(plan.gnss[u]), float(iv.t[-1]))
        out.record(iv.t[-1], nv.nav, nv.P)
        if progress is not None:
            progress(u, plan.n_updates, out)
    out.complete = True
    return out


def _gnss_update(out: Navigation, rec: Recording, nv: Navigator, k: int, t: float) -> None:
    """Fuse GNSS fix k (position, and velocity when logged) at the update epoch t, after the interval's altimeter
    and SAR update (independent noises: sequential equals joint; after, because the SAR update's delayed state refers
    its pairs to the interval's propagation, which a GNSS update before it would leave out); in ``out.gnss``."""
    g = rec.gnss
    model = GnssFix(STATE_LAYOUT, g.position_sigma[k], None if g.velocity is None else g.velocity_sigma[k])
    z = g.position[k] if g.velocity is None else np.concatenate([g.position[k], g.velocity[k]])
    fused = nv.update(model.predict(nv.nav), z[None])
    out.gnss.append({"time": t, "fix": k, "z": z, "residual": fused.residual[0], "residual_sigma":
                     fused.residual_sigma[0], "nis": float(fused.nis[0]), "nis_dof": int(fused.dof[0])})


def _update(out: Navigation, rec: Recording, sn: SarNavigator, imager, plan: FlightPlan, u: int, iv,
            seconds: float, images=None) -> None:
    """Update u: the altimeter value at its epoch and the pairs of its aperture, fused and recorded (``seconds``:
    the interval's INS and covariance); the aperture's images handed to ``images`` (``image_files``: its seconds)."""
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
    t2 = time.perf_counter()
    stages = {"propagate": seconds, "images": t1 - t0, **dict.fromkeys(STAGES[1:], 0.0), "update": t2 - t1,
              "image_files": 0.0}
    if images is not None and am is not None and am.images:
        _hand_images(out, rec, images, ap, float(iv.t[-1]), am.images)
        stages["image_files"] = time.perf_counter() - t2
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


def _hand_images(out: Navigation, rec: Recording, images, ap: int, t: float, formed: dict) -> None:
    """``images(ap, t, formed)``; a failure (a full disk, a geometry a file cannot hold) is a notice."""
    try:
        images(ap, t, formed)
    except (SarnavError, OSError, ValueError, ArithmeticError) as err:
        out.notices.append(f"aperture {ap} ({rec.manifest.apertures[ap].file}): image files not written: "
                           f"{type(err).__name__}: {err}")


def _skip(out: Navigation, rec: Recording, aperture: int, t: float, reason: str) -> None:
    nan2 = np.full(2, np.nan)
    for k in range(out.targets):
        out.pairs.append({"time": float(t), "aperture": aperture, "point": k, "toc": math.nan, "range": math.nan,
                          "z": nan2, "sigma": nan2, "correlation": math.nan, "ambiguity": math.nan, "code": SKIPPED,
                          "reason": f"skipped: {reason}", "residual": nan2, "residual_sigma": nan2})
    out.notices.append(f"aperture {aperture} ({rec.manifest.apertures[aperture].file}) skipped: {reason}")
