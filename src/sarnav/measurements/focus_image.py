"""Image-derived focus fixes of a flight: echoes of an aperture -> best-focus along-track velocity (and mapdrift's).

The extractor of the ``quality-nav`` scenario (docs/quality.md §7), typed to nothing but radar parameters, a truth
trajectory to fly the echoes along, and a scene description. Per update u (aperture of ``aperture_pulses`` pulses
ending at the update epoch) and run r:

* the *simulator*: a scene of bright points over Rayleigh clutter on a strip (:meth:`FocusApertureImager.scene`)
  centred at ground range ``ground_range`` to the right of the *true* track abeam the aperture centre t_c, drawn
  from ``SeedSequence([scene_seed_r, u])``; noise-free echoes along the true track
  (``radar.echoes``), receiver noise (per-sample SNR ``snr_db`` of a bright point), range compression;
* the *measurement*: the antenna positions the INS believes at the pulse times (its history interpolated); a
  ``pixels`` x ``pixels`` ground grid of ``pixel_m`` spacing centred where the INS believes the scene is (its
  position at t_c plus ``ground_range`` to the right of its own track: a common position error moves the grid and
  the image together); ``measurements.focus.extract_focus_velocity`` (kurtosis, two stages); and for comparison
  ``imaging.autofocus.mapdrift`` on the same pulses (range window +-``mapdrift_half_range_m`` around the range the INS
  predicts), whose speed estimate is reported, not fused.

The fix's noise is sigma^2 = kappa / curvature (``measurements.focus``); :meth:`FocusApertureImager.calibrate`
fits kappa by Monte Carlo on apertures of the same configuration with INS errors drawn from given 1-sigma figures
(the filter's initial uncertainty): a laboratory calibration with known truth, made once per configuration from
its own seed, never from the runs it is used in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from sarnav.errors import InputDataError, SarnavError
from sarnav.imaging.autofocus import mapdrift
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.measurements.focus import calibrate_kappa, extract_focus_velocity
from sarnav.radar.echoes import add_receiver_noise, simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.scene import Scene, random_scatterers
from sarnav.rotations import quat_to_dcm
from sarnav.trajectory.base import Trajectory
from sarnav.units import C

__all__ = ["FocusSettings", "FocusFixes", "FocusApertureImager"]


@dataclass(frozen=True)
class FocusSettings:
    """Scene, grid and search of the focus fixes (module docstring; defaults: the ``quality-nav`` scenario)."""

    aperture_pulses: int = 1200
    ground_range: float = 1760.0
    width: float = 12.0
    length: float = 60.0
    point_density: float = 0.0625
    point_to_clutter_db: float = 20.0
    clutter_density: float = 0.5
    snr_db: float = 0.0
    pixels: int = 64
    pixel_m: float = 0.125
    span: float = 0.5
    n_grid: int = 11
    measure: str = "kurtosis"
    mapdrift: bool = True
    mapdrift_half_range_m: float = 12.0
    contrast_sigmas: float = 5.0
    #: phase accuracy of the first search stage's candidate images [rad] (the second, recentred, stage uses a tenth)
    tolerance: float = 0.1

    @property
    def point_amplitude(self) -> float:
        return 10.0 ** (self.point_to_clutter_db / 20.0)

    def contrast_threshold(self, radar: RadarParams, speed: float, altitude: float) -> float:
        """The normalised kurtosis an image must exceed to count as focused: ``contrast_sigmas`` standard errors
        2 / sqrt(P_eff) of speckle's (0), P_eff = grid area / resolution-cell area (lambda R / (2 V T) along-track,
        c / (2 B sin(incidence)) across)."""
        r0 = math.hypot(altitude, self.ground_range)
        t_ap = (self.aperture_pulses - 1) / radar.prf
        cell = (radar.wavelength * r0 / (2.0 * speed * t_ap)) * (C / (2.0 * radar.bandwidth) * r0 / self.ground_range)
        p_eff = max(1.0, (self.pixels * self.pixel_m) ** 2 / cell)
        return self.contrast_sigmas * 2.0 / math.sqrt(p_eff)


@dataclass
class FocusFixes:
    """The fixes of one update for R runs (NaN where a run has none; ``error`` says why).

    value : (R,) measured along-track velocity e . v [m/s]; direction : (R, 3) e; curvature : (R,) relative
    curvature of the score [1/(m/s)^2]; t_c : aperture centre [s]; v_hat : (R, 3) INS velocity at t_c;
    mapdrift_speed : (R,) mapdrift's speed estimate [m/s] (NaN when disabled or failed); error : (R,) messages
    (why a fix is not used); contrast : (R,) normalised kurtosis of the best image; los : (R, 3) unit line of sight
    INS antenna -> grid centre at t_c; lever : (R,) R / (2 V) [s] (the acceleration coupling of
    ``FocusVelocityMeasurement``).
    """

    value: np.ndarray
    direction: np.ndarray
    curvature: np.ndarray
    t_c: float
    v_hat: np.ndarray
    mapdrift_speed: np.ndarray
    error: list = field(default_factory=list)
    contrast: np.ndarray | None = None
    los: np.ndarray | None = None
    lever: np.ndarray | None = None

    @property
    def ok(self) -> np.ndarray:
        """Runs with a usable fix (a value, a maximum of the score inside the search, a focused image)."""
        return np.isfinite(self.value) & (self.curvature > 0) & np.array([not e for e in self.error])


def _right_of(direction: np.ndarray) -> np.ndarray:
    """Unit horizontal vector to the right of a horizontal direction (NED: north -> east)."""
    d = np.array([direction[0], direction[1], 0.0])
    d /= math.hypot(d[0], d[1])
    return np.array([-d[1], d[0], 0.0])


@dataclass
class FocusApertureImager:
    """Makes the focus fixes of each update for a batch of runs (module docstring).

    Parameters
    ----------
    radar : the radar (PRF, receive window); truth : the true trajectory (echoes are flown along it);
    settings : :class:`FocusSettings`.
    """

    radar: RadarParams
    truth: Trajectory
    settings: FocusSettings = field(default_factory=FocusSettings)

    def times(self, t_end: float) -> np.ndarray:
        """(P,) pulse times of the aperture ending at ``t_end`` [s]."""
        p = self.settings.aperture_pulses
        return self.radar.pulse_times(p, t_end, p - 1)

    def echoes(self, times: np.ndarray, seed_key):
        """Range-compressed pulses of the aperture's scene (drawn from ``SeedSequence(seed_key)``) along the truth."""
        st = self.settings
        tr = self.truth.state(times)
        c = 0.5 * (times[0] + times[-1])
        tc = self.truth.state(np.array([c]))
        centre = tc.position[0] + st.ground_range * _right_of(tc.velocity[0])
        scene_ss, noise_ss = np.random.SeedSequence(seed_key).spawn(2)
        raw = simulate_echoes(self.radar, tr.position, times, self.scene(scene_ss, centre, tc.velocity[0]))
        raw = add_receiver_noise(raw, st.point_amplitude, st.snr_db, np.random.default_rng(noise_ss))
        return range_compress(raw)

    def scene(self, seed, centre, velocity) -> Scene:
        """Bright points (Poisson, ``point_density`` per m^2, constant amplitude, random phase) over Rayleigh clutter
        (``clutter_density``, unit mean power) on a ``length`` x ``width`` strip (along x across the track of
        ``velocity``) centred on ``centre`` (NED, on the ground): long enough that the image of the grid's ground stays
        inside it when the INS's cross-track and vertical velocity errors move the image along-track (by about
        R / V times the line-of-sight velocity error)."""
        st = self.settings
        rng = np.random.default_rng(seed)
        ext = ((-0.5 * st.length, 0.5 * st.length), (-0.5 * st.width, 0.5 * st.width))
        pts = random_scatterers(rng, ext, st.point_density, "constant", st.point_amplitude**2)
        clutter = random_scatterers(rng, ext, st.clutter_density, "rayleigh", 1.0)
        local = pts + clutter
        e = np.array([velocity[0], velocity[1], 0.0]) / math.hypot(velocity[0], velocity[1])
        c = _right_of(e)
        pos = (np.array([centre[0], centre[1], 0.0]) + local.positions[:, :1] * e[None, :]
               + local.positions[:, 1:2] * c[None, :])
        return Scene(pos, local.amplitudes)

    def geometry(self, p_c: np.ndarray, v_c: np.ndarray):
        """(grid centre on the ground, unit line of sight, lever R / 2V [s]) seen from position p_c, velocity v_c."""
        centre = p_c + self.settings.ground_range * _right_of(v_c)
        centre[2] = 0.0
        d = centre - p_c
        r0 = float(np.linalg.norm(d))
        return centre, d / r0, r0 / (2.0 * float(np.linalg.norm(v_c)))

    def fix(self, rc, times, p_hat: np.ndarray, v_hat_c: np.ndarray, span: float | None = None):
        """(FocusFix, mapdrift speed or NaN) of one aperture from the positions the INS believes (P, 3); ``span``:
        half-width of the first search stage [m/s] (default ``settings.span``)."""
        st = self.settings
        k = times.size // 2
        centre = self.geometry(p_hat[k], v_hat_c)[0]
        grid = GroundGrid.centered(float(centre[0]), float(centre[1]), st.pixel_m, (st.pixels, st.pixels))
        fx = extract_focus_velocity(rc, grid, p_hat, times, span=st.span if span is None else float(span),
                                    n_grid=st.n_grid, measure=st.measure, tolerance=st.tolerance,
                                    velocity_estimate=v_hat_c)
        speed = float("nan")
        if st.mapdrift:
            r0 = float(np.linalg.norm(np.array([centre[0], centre[1], 0.0]) - p_hat[k]))
            r = rc.slant_range
            half = st.mapdrift_half_range_m
            a, b = int(np.searchsorted(r, r0 - half)), int(np.searchsorted(r, r0 + half))
            if b - a >= 16:
                sub = replace(rc, data=rc.data[:, a:b], slant_range=r[a:b]).with_positions(p_hat)
                try:
                    speed = float(mapdrift(sub, float(np.linalg.norm(v_hat_c))).speed)
                except SarnavError:  # the comparison only: the focus fix stands
                    speed = float("nan")
        return fx, speed

    def measure(self, t_end: float, ap_t, ap_p, ap_v, scene_keys, spans=None) -> FocusFixes:
        """The fixes of the aperture ending at ``t_end`` for every run: ``ap_t`` (K,) epochs and ``ap_p``, ``ap_v``
        (R, K, 3) the INS history over the update interval (linearly interpolated to the pulse times),
        ``scene_keys`` one SeedSequence key per run, ``spans`` (R,) the first stage's half-width per run [m/s]
        (default ``settings.span``; e.g. a multiple of the filter's predicted sigma of the fix). A run whose image
        gives no fix is recorded, not raised."""
        ap_p, ap_v = np.asarray(ap_p, dtype=np.float64), np.asarray(ap_v, dtype=np.float64)
        runs = ap_p.shape[0]
        if len(scene_keys) != runs:
            raise InputDataError("scene_keys", f"need one per run ({runs}), got {len(scene_keys)}")
        times = self.times(t_end)
        t_c = 0.5 * (times[0] + times[-1])
        out = FocusFixes(np.full(runs, np.nan), np.zeros((runs, 3)), np.zeros(runs), float(t_c), np.zeros((runs, 3)),
                         np.full(runs, np.nan), [""] * runs, np.full(runs, np.nan), np.zeros((runs, 3)), np.zeros(runs))
        v_true = self.truth.state(np.array([t_c])).velocity[0]
        threshold = self.settings.contrast_threshold(self.radar, float(np.linalg.norm(v_true)),
                                                     -float(self.truth.state(np.array([t_c])).position[0, 2]))
        for r in range(runs):
            p_hat = np.stack([np.interp(times, ap_t, ap_p[r, :, i]) for i in range(3)], axis=1)
            v_c = np.array([np.interp(t_c, ap_t, ap_v[r, :, i]) for i in range(3)])
            out.v_hat[r] = v_c
            _, out.los[r], out.lever[r] = self.geometry(p_hat[times.size // 2], v_c)
            try:
                fx, speed = self.fix(self.echoes(times, scene_keys[r]), times, p_hat, v_c,
                                     None if spans is None else spans[r])
            except SarnavError as err:  # one bad image never aborts the campaign
                out.error[r] = str(err)
                continue
            out.value[r], out.direction[r], out.curvature[r] = fx.value, fx.direction, fx.curvature
            out.mapdrift_speed[r], out.contrast[r] = speed, fx.contrast
            out.error[r] = self._rejection(fx, threshold)
        return out

    def _rejection(self, fx, threshold: float) -> str:
        """Why a fix is not used ("" if it is): the optimum at the end of the first search stage (it may lie
        beyond ``span``), or an image not focused above speckle (its peak curvature is then noise)."""
        if fx.at_edge:
            return "the best focus is at an end of the first search stage"
        if not fx.contrast > threshold:
            return f"normalised kurtosis {fx.contrast:.3g} below {threshold:.3g} (speckle: 0): no focused scatterer"
        return ""

    def calibrate(self, n: int, seed: int, t_end: float, sigma, span_sigmas: float = 4.0,
                  span_max: float | None = None) -> dict:
        """kappa of sigma^2 = kappa / curvature from ``n`` apertures ending at ``t_end``, against the full model.

        ``sigma``: 1-sigma of the INS error (truth - estimate) per axis of p [m], v [m/s], th [rad], b_a [m/s^2]
        (12 values: the filter's initial uncertainty). Aperture i draws its scene and the error dx from
        ``SeedSequence([seed, i, .])``; the INS track is p - dp - dv tau - dacc tau^2 / 2 with the acceleration error
        dacc = f x dth - C db_a (eq. 3.7), and the fix error is z minus the model of ``FocusVelocityMeasurement``,
        e . v_true - lever u . dacc. The first stage spans ``span_sigmas`` x the fix's predicted 1-sigma under these
        draws (clipped to [settings.span, span_max]), as the filter's search does. Returns kappa, its relative SE,
        the errors and curvatures, the number used."""
        sigma = np.asarray(sigma, dtype=np.float64)
        times = self.times(t_end)
        t_c = 0.5 * (times[0] + times[-1])
        tr = self.truth.state(times)
        st_c = self.truth.state(np.array([t_c]))
        v_true, C = st_c.velocity[0], quat_to_dcm(st_c.quaternion)[0]
        f_n = C @ self.truth.specific_force(np.array([t_c]))[0]
        threshold = self.settings.contrast_threshold(self.radar, float(np.linalg.norm(v_true)),
                                                     -float(st_c.position[0, 2]))
        quiet = replace(self, settings=replace(self.settings, mapdrift=False))
        tau = times - t_c
        _, u0, lever0 = self.geometry(tr.position[times.size // 2], v_true)
        e0 = v_true / np.linalg.norm(v_true)
        pred_var = (np.sum((e0 * sigma[3:6]) ** 2) + lever0**2 * (np.sum((np.cross(u0, f_n) * sigma[6:9]) ** 2)
                                                                 + np.sum((C.T @ u0 * sigma[9:12]) ** 2)))
        span = float(np.clip(span_sigmas * math.sqrt(pred_var), self.settings.span,
                             self.settings.span if span_max is None else span_max))
        err, curv, contrast = [], [], []
        for i in range(int(n)):
            dx = np.random.default_rng(np.random.SeedSequence([seed, i, 1])).normal(0.0, sigma[:12])
            dacc = np.cross(f_n, dx[6:9]) - C @ dx[9:12]
            p_hat = tr.position - dx[:3] - np.outer(tau, dx[3:6]) - 0.5 * np.outer(tau**2, dacc)
            v_hat = v_true - dx[3:6]
            try:
                fx, _ = quiet.fix(self.echoes(times, [seed, i, 0]), times, p_hat, v_hat, span)
            except SarnavError:
                continue
            if fx.curvature > 0 and not self._rejection(fx, threshold):
                _, u, lever = self.geometry(p_hat[times.size // 2], v_hat)
                err.append(fx.value - float(fx.direction @ v_true) + lever * float(u @ dacc))
                curv.append(fx.curvature)
                contrast.append(fx.contrast)
        if len(err) < 2:
            raise InputDataError("focus.calibration_apertures", f"only {len(err)} of {n} calibration apertures gave a "
                                 "fix; the scene or SNR gives no focus information")
        kappa, rel = calibrate_kappa(err, curv)
        return {"kappa": kappa, "relative_se": rel, "errors": np.array(err), "curvatures": np.array(curv),
                "contrasts": np.array(contrast), "used": len(err), "apertures": int(n), "span": span}
