"""The ``quality-nav`` scenario kind: the INS aided by the best-focus along-track velocity of its own SAR images.

Hathaway (2023) scores images formed along candidate tracks; here the focus of each aperture becomes a measurement
an EKF fuses (docs/quality.md §7), with no reference map: no chip, no geolocated target. Configuration and wiring
only; the physics is in the library:

* the flight (truth, tactical IMU, strapdown INS, covariance per 0.1-s step, feedback, record):
  ``simulation.flight.ErrorStateFlight`` with the 15-state error of position, velocity, attitude and IMU biases;
* the fixes: ``measurements.focus_image.FocusApertureImager`` (echoes of a points-over-clutter scene along the true
  track, receiver noise, the INS positions at the pulse times, kurtosis-optimal along-track velocity offset, and
  mapdrift's speed on the same pulses for comparison); the measurement model
  ``measurements.focus.FocusVelocityMeasurement`` (z = e . v(t_c), sigma^2 = kappa / curvature, kappa calibrated
  by Monte Carlo on apertures of the same configuration: ``FocusApertureImager.calibrate``);
* the update: ``filters.delayed`` (``focus.delayed_state``: the fix refers to the aperture centre t_c, mapped to
  the update epoch with the process noise after t_c as correlated noise) and ``filters.update.correlated``.

``focus.measurement = "oracle"`` replaces the fixes by e . v_true(t_c) + ``focus.oracle_sigma`` noise (the only
mode in which truth becomes a measurement); ``focus.enabled = false`` flies the free INS.

Random draws, per run from its own Generator, in this order: IMU biases (6), initial error (15), the scene seed
(one integer), IMU sample 0; then per update the IMU block and one unit normal (used by the oracle, drawn in every
mode). The scene of update u of a run is drawn from ``SeedSequence([scene seed, u])``; kappa's calibration from
``focus.calibration_seed`` (the same for every run and batch: a pure function of the scenario).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError, require_finite
from sarnav.filters import ErrorStateLayout, delayed, update
from sarnav.filters.ekf import directional_sigma
from sarnav.imaging.quality import QUALITY_MEASURES
from sarnav.ins import NavState
from sarnav.measurements.focus import FocusVelocityMeasurement, body_specific_force
from sarnav.measurements.focus_image import FocusApertureImager, FocusSettings
from sarnav.montecarlo.kind import validate_campaign
from sarnav.montecarlo.record import RunRecord
from sarnav.radar.params import RadarParams
from sarnav.rotations import quat_to_dcm
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.scenarios.fields import boolean, get, table
from sarnav.scenarios.quality_tables import integer
from sarnav.scenarios.vocabulary import (EARTH_DEFAULT, IMU_OVERRIDES, RADAR_KEYS, doppler_prf_check, filter_imu_keys,
                                         read_earth,
                                         flight_size_check, make_radar, radar_fields, read_filter_imu, read_imu,
                                         read_initial, read_trajectory, whole_number)
from sarnav.simulation.flight import ErrorStateFlight, FlightSpec, ImuSpec
from sarnav.tomlio import dump_toml
from sarnav.trajectory import StraightLevel

__all__ = ["QualityNavKind", "default_config", "parse", "simulate_runs", "kappa_for", "QualityNavParams"]

COV_STEP = 0.1
LAYOUT = ErrorStateLayout(())  # p, v, th, ba, bg: no measurement bias
MEAS_NAMES = ("v_focus",)
MEAS_UNITS = ("m/s",)
MODES = ("image", "oracle")
#: echo work per fix (scatterers x pulses) and image work per fix (pixels x pulses)
MAX_ECHO_WORK = 2e7
MAX_IMAGE_WORK = 2e8
EXTRA_ATTRS = {
    "focus_error": {"units": "m/s", "description": "focus fix minus the measurement model at the truth, e . v(t_c) "
                                                   "+ lever u . (a_INS - a) (NaN: no fix used)"},
    "focus_accel_term": {"units": "m/s", "description": "lever u . (a_INS - a): what the INS's line-of-sight "
                                                        "acceleration error adds to a fix (R / 2V times it)"},
    "focus_sigma": {"units": "m/s", "description": "1-sigma the filter gives the fix: sqrt(kappa / curvature) "
                                                   "(image) or focus.oracle_sigma"},
    "focus_curvature": {"units": "1/(m/s)^2", "description": "relative curvature -S''/S of the kurtosis at its peak"},
    "mapdrift_error": {"units": "m/s", "description": "mapdrift's speed on the same pulses minus the true speed "
                                                      "(compared, not fused; NaN: off or failed)"},
    "predicted_sigma": {"units": "m/s", "description": "the EKF's 1-sigma of e . v at t_c before the update"},
    "focus_used": {"units": "", "description": "1 where the fix was fused, 0 where there was none (no focused image, "
                                               "optimum at the search's end, failed image) or it was gated"},
    "focus_gated": {"units": "", "description": "1 where a fix was refused by the innovation gate focus.gate_sigmas"},
}


def default_config() -> dict:
    """The thesis' geometry (60 m/s, 1000 m, scene 1760 m east, PRF 1667 Hz) with the NAVIGATION paper's tactical IMU."""
    return {
        "scenario": {"name": "quality-nav", "kind": "quality-nav",
                     "description": "INS aided by the best-focus along-track velocity of its own BPA images (no map)"},
        "campaign": {"runs": 100, "seed": 2023},
        "trajectory": {"start_ned": [0.0, 0.0, -1000.0], "speed": 60.0, "heading_deg": 0.0, "duration": 20.0},
        "earth": dict(EARTH_DEFAULT),  # the sources' non-rotating Earth; docs/navigation.md "Frame"
        "imu": {"grade": "nav-paper-tactical", "rate_hz": 100.0, "tau_accel": 3600.0, "tau_gyro": 3600.0},
        "initial": {"p_3sigma": [1.9, 1.9, 4.4], "v_3sigma": [0.3, 0.3, 0.5], "theta_3sigma": [0.002, 0.002, 0.006]},
        "radar": {"preset": "flexsar", "pulse_length_us": 0.2, "snr_db": 0.0, "range_margin_m": 20.0},
        # a strip along the track, long enough for the image shifts of the INS's cross-track and vertical velocity
        # errors (R / V x line-of-sight error: 17 m at 0.5 m/s); points 20 dB over clutter, 4 per 8 x 8 m grid
        "scene": {"ground_range": 1760.0, "width": 12.0, "length": 60.0, "point_density": 0.0625,
                  "point_to_clutter_db": 20.0, "clutter_density": 0.5},
        # a fix per second from the last 1200 pulses (0.72 s) on a 64 x 64 grid of 0.125 m; the first search stage
        # spans 4 predicted sigma of the fix (0.5 .. 2.5 m/s); kappa from 200 calibration apertures (relative SE 0.1)
        "focus": {"enabled": True, "measurement": "image", "interval_s": 1.0, "aperture_pulses": 1200, "pixels": 64,
                  "pixel_m": 0.125, "span": 0.5, "span_sigmas": 4.0, "span_max": 2.5, "gate_sigmas": 5.0, "n_grid": 11,
                  "measure": "kurtosis", "calibration_apertures": 200, "calibration_seed": 13, "delayed_state": True,
                  "mapdrift": True, "oracle_sigma": 0.05},
    }


def optional_keys() -> list[str]:
    """IMU 3-sigma overrides, [filter.imu] and radar fields over the preset."""
    return [f"imu.{k}" for k in IMU_OVERRIDES] + filter_imu_keys() + [f"radar.{k}" for k in RADAR_KEYS]


@dataclass(frozen=True)
class QualityNavParams:
    """Validated, SI-converted content of a quality-nav scenario."""

    runs: int
    trajectory: StraightLevel
    imu: ImuSpec
    imu_filter: ImuSpec
    imu_rate: float
    radar: RadarParams
    settings: FocusSettings
    p0_sigma: np.ndarray  # (15,)
    interval: float
    enabled: bool
    measurement: str
    delayed_state: bool
    oracle_sigma: float
    span_sigmas: float
    span_max: float
    gate_sigmas: float
    calibration_apertures: int
    calibration_seed: int
    calibration_key: str  # the scenario text kappa depends on (its cache key)
    earth_rate: np.ndarray | None = None  # [earth]: omega_ie^t when earth.rotation, else None
    filter_earth_rate: np.ndarray | None = None  # what the INS / filter assume (None unless earth.modelled)

    @property
    def n_updates(self) -> int:
        return int(round(self.trajectory.duration / self.interval))

    @property
    def samples_per_update(self) -> int:
        return int(round(self.imu_rate * self.interval))

    @property
    def samples_per_step(self) -> int:
        return int(round(self.imu_rate * COV_STEP))


def _num(cfg, key, lo, hi, unit=""):
    return require_finite(f"focus.{key}", get(cfg, "focus", key), lo, hi, unit)


def _settings(cfg: dict, prf: float, interval: float) -> FocusSettings:
    table(cfg, "scene")
    sc = lambda key, lo, hi, unit="": require_finite(f"scene.{key}", get(cfg, "scene", key), lo, hi, unit)  # noqa: E731
    st = FocusSettings(
        aperture_pulses=integer("focus.aperture_pulses", get(cfg, "focus", "aperture_pulses"), 16, 100_000),
        ground_range=sc("ground_range", 10.0, 1e5, "m"), width=sc("width", 0.5, 1000.0, "m"),
        length=sc("length", 0.5, 1000.0, "m"), point_density=sc("point_density", 0.0, 100.0, "1/m^2"),
        point_to_clutter_db=sc("point_to_clutter_db", -40.0, 80.0, "dB"),
        clutter_density=sc("clutter_density", 0.0, 100.0, "1/m^2"),
        snr_db=require_finite("radar.snr_db", get(cfg, "radar", "snr_db"), -60.0, 100.0, "dB"),
        pixels=integer("focus.pixels", get(cfg, "focus", "pixels"), 8, 512), pixel_m=_num(cfg, "pixel_m", 0.01, 10.0, "m"),
        span=_num(cfg, "span", 0.01, 10.0, "m/s"), n_grid=integer("focus.n_grid", get(cfg, "focus", "n_grid"), 3, 51),
        measure=get(cfg, "focus", "measure"), mapdrift=boolean(cfg, "focus", "mapdrift"))
    if st.n_grid % 2 == 0:
        raise ConfigError("focus.n_grid", f"must be odd, got {st.n_grid}")
    if st.measure not in QUALITY_MEASURES:
        raise ConfigError("focus.measure", f"must be one of {sorted(QUALITY_MEASURES)}, got {st.measure!r}")
    if (st.aperture_pulses - 1) / prf > interval + 1e-9:
        raise ConfigError("focus.aperture_pulses", f"{st.aperture_pulses} pulses at {prf:g} Hz last longer than "
                          f"focus.interval_s = {interval} s; at most {int(interval * prf) + 1}")
    scatterers = (st.point_density + st.clutter_density) * st.width * st.length
    if scatterers < 1:
        raise ConfigError("scene.point_density", "the scene has less than one scatterer on average: give "
                          "point_density or clutter_density > 0")
    if scatterers * st.aperture_pulses > MAX_ECHO_WORK:
        raise ConfigError("scene.clutter_density", f"{scatterers:.0f} scatterers x {st.aperture_pulses} pulses per "
                          f"aperture; at most {MAX_ECHO_WORK:.0e}")
    if st.pixels**2 * st.aperture_pulses > MAX_IMAGE_WORK:
        raise ConfigError("focus.pixels", f"{st.pixels}^2 pixels x {st.aperture_pulses} pulses per moment pass; at "
                          f"most {MAX_IMAGE_WORK:.0e}")
    return st


def _radar(cfg: dict, traj: StraightLevel, st_pulses: int, ground_range: float, half: float) -> RadarParams:
    """The preset radar with its receive window around the scene (half-size ``half``) for the aperture (+-
    ``radar.range_margin_m``)."""
    preset, fields = radar_fields(cfg)
    base = make_radar(preset, fields)
    margin = require_finite("radar.range_margin_m", get(cfg, "radar", "range_margin_m"), 0.0, 1000.0, "m")
    h = -float(traj.start[2])
    track = 0.5 * traj.speed * (st_pulses - 1) / base.prf
    window = base.receive_window((math.sqrt(h * h + max(ground_range - half, 0.0) ** 2),
                                  math.sqrt(h * h + (ground_range + half) ** 2 + (track + half) ** 2)), margin)
    n = window["n_range_samples"]
    if n * st_pulses > 2**24:
        raise ConfigError("focus.aperture_pulses", f"{st_pulses} pulses x {n} range samples; at most {2**24}")
    radar = make_radar(preset, fields, near_range=max(window["near_range"], 1.0), n_range_samples=n)
    doppler_prf_check(radar, traj.speed)
    return radar


def _calibration_key(cfg: dict) -> str:
    keep = {k: cfg[k] for k in ("trajectory", "initial", "radar", "scene", "focus", "filter") if k in cfg}
    return dump_toml(keep)


def parse(cfg: dict) -> QualityNavParams:
    """Validate ``cfg`` and convert to SI; ConfigError names the first bad key and its range."""
    runs, _ = validate_campaign(cfg)
    traj = read_trajectory(cfg, max_duration=3600.0)
    if not traj.start[2] < 0:
        raise ConfigError("trajectory.start_ned[2]", f"must be < 0 m (above the ground, NED down), got {traj.start[2]}")
    imu, imu_rate = read_imu(cfg)
    flight_size_check(traj.duration, imu_rate)
    whole_number("imu.rate_hz", imu_rate, 1.0 / COV_STEP, f"{1 / COV_STEP:g}-Hz steps (a multiple of 10 Hz)")
    filt = read_filter_imu(cfg, imu)
    ini = read_initial(cfg, filt)
    table(cfg, "focus")
    interval = _num(cfg, "interval_s", COV_STEP, 60.0, "s")
    whole_number("focus.interval_s", interval, COV_STEP, f"{COV_STEP:g}-s covariance steps")
    whole_number("trajectory.duration", traj.duration, interval, "focus.interval_s update intervals")
    mode = get(cfg, "focus", "measurement")
    if mode not in MODES:
        raise ConfigError("focus.measurement", f"must be one of {list(MODES)}, got {mode!r}")
    preset, fields = radar_fields(cfg)
    if preset is None:
        raise ConfigError("radar.preset", "is required for quality-nav (e.g. 'flexsar')")
    st = _settings(cfg, make_radar(preset, fields).prf, interval)
    if _num(cfg, "span_max", 0.01, 10.0, "m/s") < st.span:
        raise ConfigError("focus.span_max", f"must be >= focus.span = {st.span} m/s")
    radar = _radar(cfg, traj, st.aperture_pulses, st.ground_range, 0.5 * max(st.width, st.length))
    p0 = np.concatenate([ini["p"], ini["v"], ini["th"], ini["ba"], ini["bg"]])
    return QualityNavParams(
        runs=runs, trajectory=traj, imu=imu, imu_filter=filt, imu_rate=imu_rate, radar=radar, settings=st,
        p0_sigma=p0, interval=interval, enabled=boolean(cfg, "focus", "enabled"), measurement=mode,
        delayed_state=boolean(cfg, "focus", "delayed_state"),
        oracle_sigma=_num(cfg, "oracle_sigma", 1e-6, 100.0, "m/s"), span_sigmas=_num(cfg, "span_sigmas", 0.0, 20.0),
        span_max=_num(cfg, "span_max", 0.01, 10.0, "m/s"),
        gate_sigmas=_num(cfg, "gate_sigmas", 1.0, 1e6),
        calibration_apertures=integer("focus.calibration_apertures", get(cfg, "focus", "calibration_apertures"), 2,
                                      1000),
        calibration_seed=integer("focus.calibration_seed", get(cfg, "focus", "calibration_seed"), 0, 2**63 - 1),
        calibration_key=_calibration_key(cfg), **read_earth(cfg))


_KAPPA: dict[str, dict] = {}


def kappa_for(prm: QualityNavParams) -> dict:
    """kappa of the configuration (``FocusApertureImager.calibrate`` on ``focus.calibration_apertures`` apertures with
    INS errors drawn from the initial 1-sigma), computed once per process and scenario text."""
    hit = _KAPPA.get(prm.calibration_key)
    if hit is None:
        imager = FocusApertureImager(prm.radar, prm.trajectory, prm.settings)
        hit = imager.calibrate(prm.calibration_apertures, prm.calibration_seed, prm.interval, prm.p0_sigma[:12],
                               prm.span_sigmas, prm.span_max)
        _KAPPA[prm.calibration_key] = hit
    return hit


# --- the Monte Carlo ------------------------------------------------------------------------------

def _state_at(nav: NavState, iv: dict, t: float) -> NavState:
    """The INS estimate at time t inside the interval: p, v interpolated in its history, the rest of the update
    epoch (only v enters the focus measurement)."""
    p = np.stack([[np.interp(t, iv["t"], iv["p"][r, :, i]) for i in range(3)] for r in range(nav.p.shape[0])])
    v = np.stack([[np.interp(t, iv["t"], iv["v"][r, :, i]) for i in range(3)] for r in range(nav.p.shape[0])])
    return NavState(p=p, v=v, q=nav.q, ba=nav.ba, bg=nav.bg, bm=nav.bm)


class _Focus:
    """The focus measurement of one update for every run: z, the model, the record."""

    def __init__(self, prm: QualityNavParams, fl: ErrorStateFlight):
        self.prm, self.fl = prm, fl
        self.imager = FocusApertureImager(prm.radar, prm.trajectory, prm.settings)
        self.kappa = kappa_for(prm)["kappa"] if prm.measurement == "image" else None

    def measure(self, u: int, iv: dict, noise) -> dict:
        """z (R, 1), the model, ok (R,), t_c, mapdrift's speed and the curvature (R,) of update u."""
        prm, fl = self.prm, self.fl
        t_end = float(iv["t"][-1])
        times = self.imager.times(t_end)
        t_c = 0.5 * (times[0] + times[-1])
        v_true = prm.trajectory.state(np.array([t_c])).velocity[0]
        nan = np.full(fl.R, np.nan)
        truth_c = replace(fl.truth, v=np.broadcast_to(v_true, (fl.R, 3)).copy())  # truth at t_c (biases: epoch's)
        if prm.measurement == "oracle":
            nav_c = _state_at(fl.nav, iv, t_c)
            geo = [self.imager.geometry(nav_c.p[r], nav_c.v[r]) for r in range(fl.R)]
            model = FocusVelocityMeasurement(LAYOUT, nav_c.v, np.full(fl.R, prm.oracle_sigma), **self.coupling(
                np.array([g[1] for g in geo]), np.array([g[2] for g in geo]), iv))
            return {"z": model.simulate(truth_c, noise=noise), "model": model, "ok": np.ones(fl.R, bool), "t_c": t_c,
                    "mapdrift": nan, "curvature": nan, "truth_c": truth_c}
        spans = self.spans(iv, t_c)
        fx = self.imager.measure(t_end, iv["t"], iv["p"], iv["v"], [[int(s), u] for s in fl.extra], spans)
        ok = fx.ok
        e = np.where(ok[:, None], fx.direction, fx.v_hat)
        sigma = np.where(ok, np.sqrt(self.kappa / np.where(ok, fx.curvature, 1.0)), 1.0)
        model = FocusVelocityMeasurement(LAYOUT, e, sigma, **self.coupling(fx.los, fx.lever, iv))
        return {"z": np.where(ok, fx.value, 0.0)[:, None], "model": model, "ok": ok, "t_c": t_c,
                "mapdrift": fx.mapdrift_speed, "curvature": np.where(ok, fx.curvature, np.nan), "truth_c": truth_c}

    def spans(self, iv: dict, t_c: float) -> np.ndarray:
        """Half-width of each run's first search stage: focus.span_sigmas x the filter's predicted 1-sigma of the fix
        (sqrt(H P H^T), the acceleration coupling included), clipped to [focus.span, focus.span_max] [m/s]."""
        prm, fl = self.prm, self.fl
        nav_c = _state_at(fl.nav, iv, t_c)
        geo = [self.imager.geometry(nav_c.p[r], nav_c.v[r]) for r in range(fl.R)]
        model = FocusVelocityMeasurement(LAYOUT, nav_c.v, 1.0, **self.coupling(
            np.array([g[1] for g in geo]), np.array([g[2] for g in geo]), iv))
        pred, _ = _predict(prm, fl, iv, model, t_c)
        s_pred = np.sqrt(np.maximum(update.innovation_covariance(fl.P, pred)[:, 0, 0] - pred.R[:, 0, 0], 0.0))
        return np.clip(prm.span_sigmas * s_pred, prm.settings.span, prm.span_max)

    def coupling(self, los, lever, iv: dict) -> dict:
        """The acceleration coupling of the fix (``FocusVelocityMeasurement``): the INS's specific force of the
        interval's last step, in the nav frame (f_ref) and back in the body frame with its bias estimate (f_body)."""
        nav = self.fl.nav
        return {"los": los, "lever": lever, **body_specific_force(nav.q, iv["f_mean"], nav.ba)}


def _predict(prm: QualityNavParams, fl: ErrorStateFlight, iv: dict, model, t_c: float):
    """(prediction at the update epoch, covariance at t_c): the model at the INS state of t_c, mapped by the
    delayed-state strategy (``focus.delayed_state``)."""
    pred = model.predict(_state_at(fl.nav, iv, t_c)).replace(hessians=None)
    if not prm.delayed_state:
        return pred, fl.P
    span = np.full(fl.R, float(iv["t"][-1]) - t_c)
    Phi_inv, Qd = delayed.back_transition(fl.model, quat_to_dcm(fl.nav.q), iv["f_mean"], span)
    return delayed.map_to_update_epoch(pred, Phi_inv, Qd), delayed.covariance_at(fl.P, Phi_inv, Qd)


def _update(prm: QualityNavParams, fl: ErrorStateFlight, iv: dict, z, model, ok, t_c):
    """The (delayed-state) correlated update, runs without a fix (or whose innovation is beyond
    ``focus.gate_sigmas``) left untouched; returns (Update, predicted sigma of e . v at t_c, used (R,))."""
    pred, Pc = _predict(prm, fl, iv, model, t_c)
    predicted = directional_sigma(Pc, LAYOUT.slice("v"), np.broadcast_to(model.directions, (fl.R, 3)))
    S = update.innovation_covariance(fl.P, pred)[:, 0, 0]
    ok = ok & (np.abs(np.asarray(z)[:, 0] - pred.z_hat[:, 0]) <= prm.gate_sigmas * np.sqrt(S))
    bad = ~ok
    H, R, zz = pred.H.copy(), pred.R.copy(), np.array(z, dtype=np.float64)
    H[bad], R[bad], zz[bad] = 0.0, 1.0, pred.z_hat[bad]
    C = None if pred.C is None else np.where(bad[:, None, None], 0.0, pred.C)
    pred = pred.replace(H=H, R=R, C=C)
    return update.correlated(fl.P, pred, zz), predicted, ok


def simulate_runs(prm: QualityNavParams, run_ids, seeds) -> list[RunRecord]:
    """The batched Monte Carlo of :class:`QualityNavKind` (module docstring)."""
    spec = FlightSpec(prm.trajectory, prm.imu, prm.imu_rate, np.zeros(0), np.zeros(0), prm.p0_sigma, prm.n_updates,
                      prm.samples_per_update, prm.samples_per_step, imu_filter=prm.imu_filter,
                      earth_rate=prm.earth_rate, filter_earth_rate=prm.filter_earth_rate)
    fl = ErrorStateFlight(spec, LAYOUT, seeds, extra_draws=lambda rngs: [int(g.integers(2**63)) for g in rngs],
                          covariance_attitude="start")
    R, U = fl.R, prm.n_updates
    nan = lambda: np.full((R, U), np.nan)  # noqa: E731
    rec = {"residual": nan(), "residual_sigma": nan(), "nis": np.zeros((R, U)), "nis_dof": np.zeros((R, U), int),
           **{k: nan() for k in EXTRA_ATTRS}}
    focus = _Focus(prm, fl) if prm.enabled else None
    for u in range(U):
        iv = fl.fly_interval(u)
        noise = np.stack([g.standard_normal(1) for g in fl.rngs])  # (R, 1), drawn in every mode
        if focus is None:
            fl.after_update(iv["j"], np.zeros((R, LAYOUT.n)), fl.P)
            continue
        m = focus.measure(u, iv, noise)
        ok, model = m["ok"], m["model"]
        up, predicted, used = _update(prm, fl, iv, m["z"], model, ok, m["t_c"])
        rec["focus_used"][:, u] = used
        rec["focus_gated"][:, u] = ok & ~used
        ok = used
        fl.after_update(iv["j"], up.dx, up.P)
        v_true = prm.trajectory.state(np.array([m["t_c"]])).velocity[0]
        e = np.broadcast_to(model.directions, (R, 3))
        h_true = model.predict(m["truth_c"]).z_hat[:, 0]  # the model at the truth: what an error-free fix gives
        rec["residual"][ok, u] = up.residual[ok, 0]
        rec["residual_sigma"][ok, u] = up.residual_sigma[ok, 0]
        rec["nis"][ok, u], rec["nis_dof"][ok, u] = up.nis[ok], 1
        rec["focus_error"][ok, u] = m["z"][ok, 0] - h_true[ok]
        rec["focus_accel_term"][:, u] = h_true - e @ v_true
        rec["focus_sigma"][ok, u] = np.broadcast_to(model.sigma, (R,))[ok]
        rec["focus_curvature"][:, u] = m["curvature"]
        rec["mapdrift_error"][:, u] = m["mapdrift"] - float(np.sqrt(v_true @ v_true))
        rec["predicted_sigma"][:, u] = predicted
    return _records(prm, fl, run_ids, rec)


def _records(prm, fl, run_ids, rec) -> list[RunRecord]:
    t_upd = fl.t_out[fl.steps::fl.steps]
    out = []
    for i in range(fl.R):
        extras = {k: (("update",), rec[k][i]) for k in EXTRA_ATTRS}
        out.append(RunRecord(run=int(run_ids[i]), time=fl.t_out.copy(), error=fl.err[i], sigma=fl.sig[i],
                             nees=fl.nees[i], update_time=t_upd.copy(), residual=rec["residual"][i][:, None],
                             residual_sigma=rec["residual_sigma"][i][:, None], nis=rec["nis"][i],
                             nis_dof=rec["nis_dof"][i], extras=extras))
    return out


class QualityNavKind(ErrorStateKind):
    """Focus-aided INS Monte Carlo (module docstring)."""

    kind = "quality-nav"
    layout = LAYOUT
    measurement_names = MEAS_NAMES
    measurement_units = MEAS_UNITS

    def default_config(self) -> dict:
        return default_config()

    def optional_keys(self) -> list[str]:
        return optional_keys()

    def parse(self, cfg: dict):
        return parse(cfg)

    def simulate_runs(self, prm, run_ids, seeds) -> list[RunRecord]:
        return simulate_runs(prm, run_ids, seeds)

    def extra_attrs(self, cfg: dict) -> dict[str, dict]:
        return EXTRA_ATTRS

    def figures(self, results, outdir) -> list[str]:
        """The along-track velocity error of the runs against the filter's 3-sigma and the free INS's (run 0 flown
        again with ``focus.enabled = false``), and the fix errors against their 1-sigma and mapdrift's."""
        import copy
        from pathlib import Path

        from sarnav.montecarlo.seeding import run_seeds
        from sarnav.report.quality_figures import plot_focus_nav
        from sarnav.tomlio import parse_toml

        cfg = parse_toml(results.attrs["scenario"])
        off = copy.deepcopy(cfg)
        off["focus"]["enabled"] = False
        seed0 = run_seeds(int(cfg["campaign"]["seed"]), int(cfg["campaign"]["runs"]))[0]
        free = simulate_runs(parse(off), [0], [seed0])[0]
        return [str(plot_focus_nav(results, free.time, free.sigma, Path(outdir) / "focus_velocity.png"))]
