"""The ``rda-nav`` scenario kind: INS + altimeter + SAR range/cross-range from 1-s RDA sub-apertures.

Lindstrom et al., NAVIGATION 69(3) (extraction seed-001) and thesis ch. 5; design and gap decisions in
docs/scenarios/rda-nav.md. Scenarios ``rda-nav`` (paper sim, Tables 1-3) and ``rda-nav-flexsar``
(simulated FlexSAR-like flight, Tables 4-6). Configuration and wiring only; the physics is in the library:

* the flight (truth, IMU, strapdown INS, covariance per 0.1-s step, feedback, record): ``simulation.flight``;
* the measurements: ``measurements.telemetry.AltimeterMeasurement`` and ``measurements.sar`` (range, cross-range
  at the reference target's time of closest approach, TOC), made from images by ``measurements.sar_image``
  (``sar.measurement = "image"``) or synthesised from truth (``"oracle"``, the only mode in which truth enters a
  measurement: the truth state at the true TOC plus the truth FOGM bias and Table 2's white noise);
* the update strategies: ``filters.delayed`` (``sar.delayed_state``: H mapped from the TOC to the update epoch,
  eq. 57, with the process noise after the TOC as correlated noise), ``filters.second_order``
  (``sar.second_order``: Gaussian second-order terms under the TOC covariance) and ``filters.update.correlated``.

``sar.enabled = false`` flies with the altimeter only.

Random draws, per run from its own Generator, in this order: IMU biases (6), measurement biases (3), initial error
(18), measurement-bias drive (cov steps x 3), the clutter seed (1 integer), IMU sample 0; then per update the IMU
block, the altimeter noise and (SAR enabled) the two SAR noises. Run i depends only on cfg and seeds[i]; the
reference targets are drawn from ``scene.seed`` (the same world for every run), the clutter from the run's clutter
seed (``scene.clutter_per_run``, default) or from ``scene.seed``.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from sarnav import units
from sarnav.analysis.covariance import sar_covariance_study
from sarnav.errors import ConfigError, require_finite
from sarnav.filters import ErrorStateLayout, ErrorStateModel, delayed, second_order, update
from sarnav.filters.ekf import directional_sigma
from sarnav.filters.prediction import Prediction, stack_predictions
from sarnav.ins import NavState
from sarnav.measurements.sar import CROSS_RANGE_MODELS, SarCrossRangeMeasurement, SarRangeMeasurement
from sarnav.measurements.sar_image import STAGES as IMAGE_STAGES
from sarnav.measurements.sar_image import SubApertureImager
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.montecarlo.kind import validate_campaign
from sarnav.montecarlo.record import RunRecord
from sarnav.radar.params import RadarParams
from sarnav.radar.scene import Scene, beside_track, clutter_beside_track, point_targets
from sarnav.rotations import quat_to_dcm
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import get as _get
from sarnav.scenarios.fields import positive as _pos
from sarnav.scenarios.fields import table as _table
from sarnav.scenarios.fields import vector as _vector
from sarnav.scenarios.vocabulary import (flight_size_check, IMU_OVERRIDES, RADAR_KEYS, filter_imu_keys, make_radar, radar_fields,
                                         read_filter_imu, read_imu, read_initial, read_trajectory, whole_number)
from sarnav.simulation.flight import ErrorStateFlight, FlightSpec, ImuSpec
from sarnav.trajectory import StraightLevel
from sarnav.trajectory.sampled import closest_approach, interpolate_state

#: covariance-propagation step [s] (F held constant over a step); also the INS history spacing
COV_STEP = 0.1
STATE_LAYOUT = ErrorStateLayout(("b_alt", "b_range", "b_cross"), scalar_units=("m", "m", "m"))
MEAS_NAMES = ["alt", "range", "cross"]
MEAS_UNITS = ["m", "m", "m"]
MEASUREMENT_MODES = ("oracle", "image")
STAGES = IMAGE_STAGES + ("update",)
#: units and descriptions of the extra results.nc variables
EXTRA_ATTRS = {
    "toc": {"units": "s", "description": "time of closest approach of the reference target each SAR update refers "
                                         "to: measured from the image (image mode) or the truth (oracle)"},
    "registration_error": {"units": "m", "description": "image-derived minus geometric truth: range of closest "
                                                        "approach (meas range), along-track V x TOC error (meas cross); "
                                                        "NaN for the altimeter"},
    "autofocus_dk": {"units": "Hz/s", "description": "mapdrift correction of the azimuth FM rate, K_a - K_amf"},
    "stage_seconds": {"units": "s", "description": "wall time per stage of each image and update (per run)"},
}


# --- configuration ------------------------------------------------------------------------------

def default_config() -> dict:
    """Paper simulation (Tables 1-3, 200 runs, L1357); gap fills commented, see docs/scenarios/rda-nav.md."""
    return {
        "scenario": {"name": "rda-nav", "kind": "rda-nav",
                     "description": "NAVIGATION paper sim / thesis ch. 5: INS + altimeter + RDA range/cross-range EKF"},
        "campaign": {"runs": 200, "seed": 2022},  # 200 runs: paper L1357
        "trajectory": {
            "start_ned": [0.0, 0.0, -1000.0],  # altitude not given (G7): 1000 m, thesis §18
            "speed": 10.0,  # Table 3
            "heading_deg": 0.0,  # northbound (L1289)
            "duration": 50.0,  # 50 x 1-s sub-apertures (G17)
        },
        "imu": {
            "grade": "nav-paper-tactical",  # Tables 1-2 (biases = Table 1 initial 3-sigma, G2)
            "rate_hz": 100.0,  # not given (G13)
            "tau_accel": 3600.0,  # not given (G2)
            "tau_gyro": 3600.0,
        },
        "altimeter": {"sigma_3sigma": 4.0, "bias_3sigma": 0.25, "tau": 3600.0},  # Tables 2, 1; tau G2
        "sar": {
            "enabled": True,
            "measurement": "image",  # --set sar.measurement=oracle: truth + noise
            "cross_range_model": "zero-doppler",  # G1: docs/scenarios/rda-nav.md §2
            "delayed_state": True,  # H mapped from the TOC to the update epoch (eq. 57)
            "second_order": True,  # Gaussian second-order terms of h (zero-Doppler lever / |v|), §2
            "range_3sigma": 0.75,  # Table 2
            "cross_3sigma": 0.75,  # Table 2
            "bias_range_3sigma": 0.25,  # Table 1
            "bias_cross_3sigma": 0.25,  # Table 1
            "tau_range": 3600.0,  # G2
            "tau_cross": 3600.0,
            # image mode (G11): R = registration_sigma_m^2 per axis [range, along-track], set from the measured
            # registration errors (summary.json "registration"; docs/scenarios/rda-nav.md §3)
            "registration_sigma_m": [0.00125, 0.0315],
            "image_added_noise": False,  # true: also add Table 2's white noise (range/cross_3sigma) in image mode
        },
        "radar": {
            "preset": "nav-paper-sim",  # Table 3
            "snr_db": -10.0,  # receiver noise: per-sample SNR of the reflector (G5); independent per acquisition
        },
        "scene": {
            "seed": 7,
            "ground_range_min": 1760.0,  # slant 2021 m at 1000 m altitude (window 2000-2210 m)
            "ground_range_max": 1940.0,  # slant 2183 m
            "toc_jitter_s": 0.25,  # reference-target TOC = aperture centre +- this (G4)
            "clutter_per_image": 4,  # G5
            "clutter_per_run": True,  # G5: clutter redrawn per run (independent registration errors)
            "reflector_amplitude": 3.16,  # 10 dB above the unit-mean-power clutter (G4)
        },
        "initial": {
            "p_3sigma": [1.9, 1.9, 4.4],  # Table 1
            "v_3sigma": [0.3, 0.3, 0.5],
            "theta_3sigma": [0.002, 0.002, 0.006],
        },
    }


def flexsar_config() -> dict:
    """Simulated FlexSAR-like flight: paper Tables 4-6 (60 m/s, PRF 1667 Hz, 1948-2112 m, 15 deg/hr)."""
    cfg = default_config()
    cfg["scenario"].update(name="rda-nav-flexsar", description="Paper Tables 4-6: simulated FlexSAR-like flight at 60 m/s")
    cfg["trajectory"]["speed"] = 60.0  # Table 6
    cfg["imu"]["gyro_bias_3sigma"] = 15.0  # Table 4 (absorbs Earth rate, L1487)
    cfg["altimeter"]["sigma_3sigma"] = 3.9  # Table 5 "1.3 m (0.4 hPa)" read as 1-sigma (G10)
    cfg["sar"]["range_3sigma"] = 0.25  # Table 5
    cfg["sar"]["cross_3sigma"] = 0.25
    cfg["sar"]["registration_sigma_m"] = [0.0007, 0.0024]  # measured, 50 runs: (0.01 +- 0.70) mm, (0.00 +- 2.53) mm
    cfg["radar"]["preset"] = "flexsar"
    cfg["scene"]["ground_range_min"] = 1690.0  # slant 1966 m (window 1948-2112 m)
    cfg["scene"]["ground_range_max"] = 1830.0  # slant 2086 m
    return cfg


def optional_keys() -> list[str]:
    """Keys accepted although the default configuration leaves them out: IMU 3-sigma overrides, [filter.imu],
    radar fields over the preset."""
    return [f"imu.{k}" for k in IMU_OVERRIDES] + filter_imu_keys() + [f"radar.{k}" for k in RADAR_KEYS]


@dataclass(frozen=True)
class RdaNavParams:
    """Validated, SI-converted content of an rda-nav scenario."""

    runs: int
    trajectory: StraightLevel
    altitude: float
    imu: ImuSpec  # the truth sensor
    imu_filter: ImuSpec  # the filter's model of it
    imu_rate: float
    alt_sigma: float
    sar_enabled: bool
    measurement: str
    cross_model: str
    delayed_state: bool
    second_order: bool
    sar_sigma: np.ndarray  # (2,) range, cross [m]
    registration_sigma: np.ndarray  # (2,) image mode: range, along-track registration 1-sigma [m]
    image_added_noise: bool
    bias_sigma: np.ndarray  # (3,) b_alt, b_range, b_cross steady-state sigma [m]
    bias_tau: np.ndarray  # (3,)
    radar: RadarParams
    snr_db: float  # receiver noise: per-sample SNR of the reflector [dB]
    scene: dict
    p0_sigma: np.ndarray  # (18,)

    @property
    def n_updates(self) -> int:
        return int(math.floor(self.trajectory.duration + 1e-9))

    @property
    def samples_per_update(self) -> int:
        return int(round(self.imu_rate))

    @property
    def samples_per_step(self) -> int:
        return int(round(self.imu_rate * COV_STEP))


def _parse_sar(cfg: dict) -> dict:
    three = units.three_sigma_to_sigma
    sar = _table(cfg, "sar")
    mode = sar.get("measurement")
    if mode not in MEASUREMENT_MODES:
        raise ConfigError("sar.measurement", f"must be one of {MEASUREMENT_MODES}, got {mode!r}")
    cross_model = sar.get("cross_range_model")
    if cross_model not in CROSS_RANGE_MODELS:
        raise ConfigError("sar.cross_range_model", f"must be one of {CROSS_RANGE_MODELS}, got {cross_model!r}")
    if cross_model == "paper" and mode == "image":
        raise ConfigError("sar.cross_range_model", "'paper' (eq. 48 with constant u_c, r_orig) cannot be made from "
                          "an image; use 'zero-doppler' with sar.measurement = 'image'")
    return dict(sar_enabled=_bool(cfg, "sar", "enabled"), measurement=mode, cross_model=cross_model,
                delayed_state=_bool(cfg, "sar", "delayed_state"), second_order=_bool(cfg, "sar", "second_order"),
                sar_sigma=three(np.array([_pos(cfg, "sar", "range_3sigma", "m"), _pos(cfg, "sar", "cross_3sigma", "m")])),
                registration_sigma=_vector(cfg, "sar", "registration_sigma_m", n=2, positive=True, unit="m"),
                image_added_noise=_bool(cfg, "sar", "image_added_noise"))


def _parse_scene(cfg: dict) -> dict:
    sc = _table(cfg, "scene")
    seed_s = sc.get("seed")
    if isinstance(seed_s, bool) or not isinstance(seed_s, int) or seed_s < 0:
        raise ConfigError("scene.seed", f"must be an integer >= 0, got {seed_s!r}")
    gmin = _pos(cfg, "scene", "ground_range_min", "m")
    gmax = _pos(cfg, "scene", "ground_range_max", "m")
    if not gmax > gmin:
        raise ConfigError("scene.ground_range_max", f"must be > scene.ground_range_min = {gmin} m, got {gmax}")
    jitter = require_finite("scene.toc_jitter_s", _get(cfg, "scene", "toc_jitter_s"), 0.0, 0.4, "s")
    clutter = _get(cfg, "scene", "clutter_per_image")
    if isinstance(clutter, bool) or not isinstance(clutter, int) or not 0 <= clutter <= 1000:
        raise ConfigError("scene.clutter_per_image", f"must be an integer in [0, 1000], got {clutter!r}")
    return {"seed": seed_s, "ground_range": (gmin, gmax), "toc_jitter": jitter, "clutter": clutter,
            "reflector_amplitude": _pos(cfg, "scene", "reflector_amplitude"),
            "clutter_per_run": _bool(cfg, "scene", "clutter_per_run")}


def parse(cfg: dict) -> RdaNavParams:
    """Validate ``cfg`` and convert to SI; ConfigError names the first bad field and its range."""
    runs, seed = validate_campaign(cfg)
    traj = read_trajectory(cfg, max_duration=3600.0)
    if not traj.start[2] < 0:
        raise ConfigError("trajectory.start_ned[2]", f"must be < 0 m (above the ground, NED down), got {traj.start[2]}")
    whole_number("trajectory.duration", traj.duration, 1.0, "1-s sub-apertures")
    imu, imu_rate = read_imu(cfg)
    flight_size_check(traj.duration, imu_rate)
    whole_number("imu.rate_hz", imu_rate, 1.0 / COV_STEP, f"{1 / COV_STEP:g}-Hz steps (a multiple of {1 / COV_STEP:g} Hz)")
    filt = read_filter_imu(cfg, imu)
    three = units.three_sigma_to_sigma
    alt_sigma = three(_pos(cfg, "altimeter", "sigma_3sigma", "m"))
    sar = _parse_sar(cfg)
    bias3 = np.array([_pos(cfg, "altimeter", "bias_3sigma", "m"), _pos(cfg, "sar", "bias_range_3sigma", "m"),
                      _pos(cfg, "sar", "bias_cross_3sigma", "m")])
    bias_tau = np.array([_pos(cfg, "altimeter", "tau", "s"), _pos(cfg, "sar", "tau_range", "s"), _pos(cfg, "sar", "tau_cross", "s")])
    preset, fields = radar_fields(cfg)
    if preset is None:
        raise ConfigError("radar.preset", "is required for rda-nav (its receive window): 'nav-paper-sim' or 'flexsar'")
    radar = make_radar(preset, fields)
    snr = require_finite("radar.snr_db", _get(cfg, "radar", "snr_db"), -60.0, 100.0, "dB")
    ini = read_initial(cfg, filt)
    p0 = np.concatenate([ini["p"], ini["v"], ini["th"], ini["ba"], ini["bg"], three(bias3)])
    return RdaNavParams(runs=runs, trajectory=traj, altitude=float(-traj.start[2]), imu=imu, imu_filter=filt,
                        imu_rate=imu_rate, alt_sigma=float(alt_sigma), bias_sigma=three(bias3), bias_tau=bias_tau,
                        radar=radar, snr_db=float(snr), scene=_parse_scene(cfg), p0_sigma=p0, **sar)


def measurement_sigma(prm: RdaNavParams, image: bool):
    """(sigma (2,) [range, cross] of R, 0/1 factor of Table 2's white noise added to z) for the SAR pair.

    Oracle: Table 2's noise is the measurement's only error and R = its variance. Image: the error is what
    the image makes (registration, clutter, receiver noise), R = ``sar.registration_sigma_m`` squared, set
    from the measured registration errors; ``sar.image_added_noise`` adds Table 2's noise on top (and to R).
    """
    if not image:
        return prm.sar_sigma.copy(), 1.0
    if prm.image_added_noise:
        return np.hypot(prm.sar_sigma, prm.registration_sigma), 1.0
    return prm.registration_sigma.copy(), 0.0


def reference_targets(prm: RdaNavParams) -> np.ndarray:
    """(U, 3) one geolocated reference target per sub-aperture, on the ground to the right of the track.

    TOC at the aperture centre +- ``scene.toc_jitter_s``, ground range uniform in the configured band;
    drawn from ``scene.seed`` (the same world for every run).
    """
    rng = np.random.default_rng(np.random.SeedSequence(prm.scene["seed"]))
    traj = prm.trajectory
    k = np.arange(prm.n_updates)
    toc = k + 0.5 + rng.uniform(-prm.scene["toc_jitter"], prm.scene["toc_jitter"], k.size)
    gr = rng.uniform(*prm.scene["ground_range"], k.size)
    return beside_track(traj.state(np.array([0.0])).position[0], traj.heading, traj.speed, toc, gr)


def scene_factory(prm: RdaNavParams, targets: np.ndarray):
    """``(u, clutter_seed) -> Scene``: the reflector of sub-aperture u plus ``scene.clutter_per_image`` Rayleigh
    scatterers whose TOC lies in the aperture (u + 0.1 .. u + 0.9 s), drawn from ``[scene.seed, 1, u]`` (one world)
    or ``[clutter_seed, 2, u]`` (per run)."""
    traj = prm.trajectory
    origin = traj.state(np.array([0.0])).position[0]

    def scene_for(u: int, clutter_seed: int | None) -> Scene:
        key = [prm.scene["seed"], 1, u] if clutter_seed is None else [clutter_seed, 2, u]
        rng = np.random.default_rng(np.random.SeedSequence(key))
        clutter = clutter_beside_track(rng, origin, traj.heading, traj.speed, u, (0.1, 0.9),
                                       prm.scene["ground_range"], prm.scene["clutter"])
        return point_targets(targets[u][None, :], prm.scene["reflector_amplitude"]) + clutter

    return scene_for


# --- the Monte Carlo ------------------------------------------------------------------------------

def _toc_state(nav: NavState, iv: dict, eta) -> NavState:
    """The INS estimate at each run's TOC ``eta`` (R,): position and velocity interpolated in the aperture's
    history, the bias estimates of the update epoch."""
    p = np.stack([interpolate_state(iv["t"], iv["p"][r], eta[r]) for r in range(len(eta))])
    v = np.stack([interpolate_state(iv["t"], iv["v"][r], eta[r]) for r in range(len(eta))])
    return NavState(p=p, v=v, q=nav.q, ba=nav.ba, bg=nav.bg, bm=nav.bm)


class _Sar:
    """The SAR pair of one sub-aperture: predictions, the delayed-state and second-order strategies, z."""

    def __init__(self, prm: RdaNavParams, fl: ErrorStateFlight, imager):
        self.prm, self.fl, self.imager = prm, fl, imager
        self.targets = reference_targets(prm)
        self.sigma, self.add_white = measurement_sigma(prm, image=imager is not None)

    def models(self, u: int, iv: dict):
        L, targ = self.fl.layout, self.targets[u]
        kw = {}
        if self.prm.cross_model == "paper":  # eq. 49: u_c and r_orig from each run's estimated aperture
            kw = dict(u_c=iv["p"][:, -1] - iv["p"][:, 0], r_orig=iv["p"][:, 0])
        return (SarRangeMeasurement(targ, self.sigma[0], L),
                SarCrossRangeMeasurement(targ, self.sigma[1], L, model=self.prm.cross_model, **kw))

    def predict(self, u: int, iv: dict, eta) -> Prediction:
        fl, prm = self.fl, self.prm
        nav_toc = _toc_state(fl.nav, iv, eta)
        pred = stack_predictions([m.predict(nav_toc) for m in self.models(u, iv)])
        if prm.delayed_state:
            Phi_inv, Qd = delayed.back_transition(fl.model, quat_to_dcm(fl.nav.q), iv["f_mean"], iv["t"][-1] - eta)
            if prm.second_order:
                pred = second_order.with_second_order(pred, delayed.covariance_at(fl.P, Phi_inv, Qd))
            return delayed.map_to_update_epoch(pred, Phi_inv, Qd)
        if prm.second_order:
            pred = second_order.with_second_order(pred, fl.P)
        return pred.replace(hessians=None)

    def measure(self, u: int, iv: dict, noise, record: dict):
        """(z (R, 2), TOC used (R,)): from the images, or the oracle's truth at the true TOC."""
        fl, prm, R = self.fl, self.prm, self.fl.R
        targ, j = self.targets[u], iv["j"]
        steps = fl.steps
        eta_true, r_true, p_true_toc = closest_approach(targ, iv["t"], fl.truth_out.position[u * steps:j + 1])
        v_true_toc = prm.trajectory.state(np.array([eta_true])).velocity[0]
        bm = fl.bm_truth[:, j]
        if self.imager is None:
            truth_toc = NavState(p=np.broadcast_to(p_true_toc, (R, 3)), v=np.broadcast_to(v_true_toc, (R, 3)),
                                 q=fl.nav.q, ba=fl.nav.ba, bg=fl.nav.bg, bm=bm)
            z = np.concatenate([m.simulate(truth_toc, noise=noise[:, i:i + 1])
                                for i, m in enumerate(self.models(u, iv))], axis=1)
            return z, np.full(R, eta_true)
        speed_sigma = directional_sigma(fl.P, fl.layout.slice("v"), fl.nav.v)
        am = self.imager.measure(u, iv["t"], iv["p"], iv["v"], speed_sigma)
        n_add = prm.sar_sigma * noise * self.add_white
        z = np.stack([am.range + bm[:, 1] + n_add[:, 0], bm[:, 2] + n_add[:, 1]], axis=1)  # cross: 0 at zero Doppler
        record["registration_error"][:, u, 1] = am.range - r_true
        record["registration_error"][:, u, 2] = prm.trajectory.speed * (am.toc - eta_true)
        record["autofocus_dk"][:, u] = am.autofocus_dk
        record["stage_seconds"][:, u, :len(IMAGE_STAGES)] += am.seconds
        if am.capture is not None:
            record["capture"] = am.capture
        return z, am.toc


def _imager(prm: RdaNavParams, fl: ErrorStateFlight, capture_aperture=None):
    if not (prm.sar_enabled and prm.measurement == "image"):
        return None
    seeds = fl.extra  # the per-run clutter seeds (also keying the in-flight receiver noise)
    return SubApertureImager(
        radar=prm.radar, truth=prm.trajectory, speed=prm.trajectory.speed, targets=reference_targets(prm),
        scene_for=scene_factory(prm, reference_targets(prm)), reflector_amplitude=prm.scene["reflector_amplitude"],
        snr_db=prm.snr_db, reference_seed=prm.scene["seed"], noise_seeds=seeds,
        clutter_seeds=seeds if prm.scene["clutter_per_run"] else None, capture_aperture=capture_aperture)


def simulate_runs(prm: RdaNavParams, run_ids, seeds) -> list[RunRecord]:
    """The batched Monte Carlo of :class:`RdaNavKind` (module docstring)."""
    return _simulate(prm, run_ids, seeds)[0]


def capture_images(prm: RdaNavParams, seed, aperture: int) -> dict:
    """The images of sub-aperture ``aperture`` of the run with ``seed`` (reference, in flight before and after
    mapdrift, correlation surface; ``measurements.sar_image.SubApertureImager``), for figures. The run's numbers
    are the same as without the capture."""
    return _simulate(prm, [0], [seed], capture_aperture=aperture)[1].get("capture")


def _simulate(prm: RdaNavParams, run_ids, seeds, capture_aperture=None):
    L = STATE_LAYOUT
    spec = FlightSpec(prm.trajectory, prm.imu, prm.imu_rate, prm.bias_sigma, prm.bias_tau, prm.p0_sigma,
                      prm.n_updates, prm.samples_per_update, prm.samples_per_step, imu_filter=prm.imu_filter)
    # the clutter seed is drawn after the bias drive, before IMU sample 0; F at the step's start attitude
    fl = ErrorStateFlight(spec, L, seeds, extra_draws=lambda rngs: [int(g.integers(2**63)) for g in rngs],
                          covariance_attitude="start")
    R, n_upd = fl.R, prm.n_updates
    alt = AltimeterMeasurement(prm.alt_sigma, L)
    sar = _Sar(prm, fl, _imager(prm, fl, capture_aperture)) if prm.sar_enabled else None
    rec = {"residual": np.full((R, n_upd, 3), np.nan), "residual_sigma": np.full((R, n_upd, 3), np.nan),
           "nis": np.empty((R, n_upd)), "toc": np.full((R, n_upd), np.nan),
           "registration_error": np.full((R, n_upd, 3), np.nan), "autofocus_dk": np.full((R, n_upd), np.nan),
           "stage_seconds": np.zeros((R, n_upd, len(STAGES)))}
    for u in range(n_upd):
        iv = fl.fly_interval(u)
        z_alt = alt.simulate(fl.truth, fl.rngs)
        pred = alt.predict(fl.nav).replace(hessians=None, C=np.zeros((R, L.n, 1)))
        z, cols = z_alt, slice(0, 1)
        if sar is not None:
            noise = np.stack([g.standard_normal(2) for g in fl.rngs])  # (R, 2), drawn in every mode
            z_sar, rec["toc"][:, u] = sar.measure(u, iv, noise, rec)
            t0 = _time.perf_counter()
            pred = stack_predictions([pred.replace(C=None), sar.predict(u, iv, rec["toc"][:, u])])
            if pred.C is None:
                pred = pred.replace(C=np.zeros((R, L.n, 3)))
            z, cols = np.concatenate([z_alt, z_sar], axis=1), slice(0, 3)
            rec["stage_seconds"][:, u, -1] += (_time.perf_counter() - t0) / R
        up = update.correlated(fl.P, pred, z)
        fl.after_update(iv["j"], up.dx, up.P)
        rec["residual"][:, u, cols], rec["residual_sigma"][:, u, cols], rec["nis"][:, u] = \
            up.residual, up.residual_sigma, up.nis
    return _records(prm, fl, run_ids, rec, image=sar is not None and sar.imager is not None), rec


def _records(prm, fl, run_ids, rec, image: bool) -> list[RunRecord]:
    n_upd, t_out = prm.n_updates, fl.t_out
    t_upd = t_out[fl.steps::fl.steps]
    dof = 3 if prm.sar_enabled else 1
    records = []
    for i in range(fl.R):
        extras = {"toc": (("update",), rec["toc"][i])}
        if image:
            extras["registration_error"] = (("update", "meas"), rec["registration_error"][i])
            extras["autofocus_dk"] = (("update",), rec["autofocus_dk"][i])
            extras["stage_seconds"] = (("update", "stage"), rec["stage_seconds"][i])
        records.append(RunRecord(
            run=int(run_ids[i]), time=t_out.copy(), error=fl.err[i], sigma=fl.sig[i], nees=fl.nees[i],
            update_time=t_upd.copy(), residual=rec["residual"][i], residual_sigma=rec["residual_sigma"][i],
            nis=rec["nis"][i], nis_dof=np.full(n_upd, dof, dtype=int), extras=extras))
    return records


def covariance_study(prm: RdaNavParams, range_sigma: float, cross_sigma: float, ground_ranges=None,
                     cross_model: str | None = None) -> dict:
    """The truth-linearised covariance study of this scenario's filter (``analysis.covariance.sar_covariance_study``)
    for a given SAR noise: its IMU model, altimeter, biases, P0, trajectory and reference targets; ``cross_model``
    defaults to ``sar.cross_range_model``; ``ground_ranges``: several targets per aperture (see there)."""
    g, fi = prm.imu_filter.grade, prm.imu_filter
    model = ErrorStateModel(STATE_LAYOUT, g.vrw, g.arw, g.accel_bias, g.gyro_bias, fi.tau_accel, fi.tau_gyro,
                            prm.bias_sigma, prm.bias_tau)
    return sar_covariance_study(model, prm.trajectory, prm.p0_sigma, prm.alt_sigma, reference_targets(prm),
                                range_sigma, cross_sigma, ground_ranges=ground_ranges,
                                cross_model=prm.cross_model if cross_model is None else cross_model, step=COV_STEP)


class RdaNavKind(ErrorStateKind):
    """NAVIGATION paper / thesis ch. 5 image-aided INS Monte Carlo (module docstring)."""

    kind = "rda-nav"

    def default_config(self) -> dict:
        return default_config()

    def optional_keys(self) -> list[str]:
        return optional_keys()

    layout = STATE_LAYOUT
    measurement_names = tuple(MEAS_NAMES)
    measurement_units = tuple(MEAS_UNITS)

    def parse(self, cfg: dict):
        return parse(cfg)

    def simulate_runs(self, prm, run_ids, seeds) -> list[RunRecord]:
        return simulate_runs(prm, run_ids, seeds)

    def extra_attrs(self, cfg: dict) -> dict[str, dict]:
        return EXTRA_ATTRS

    def extra_coords(self, cfg: dict) -> dict:
        return {"stage": (list(STAGES), {"units": "", "description": "stages of the imaging chain and the update, "
                                         "timed per image (echoes: simulation, both noisy acquisitions, range "
                                         "compression, reference chip)"})}

    def figures(self, results, outdir) -> list[str]:
        """Paper-style extras: the images of sub-aperture 10 of run 0 (reference, in flight before and
        after mapdrift, correlation surface; paper Figs 4-6) and the position 3-sigma with and without SAR
        on a log scale (paper Fig. 15). Run 0 is simulated again for them (a pure function of the scenario
        and its seed, so identical to the stored run 0); the altimeter-only curve is run 0 with
        ``sar.enabled = false``."""
        import copy
        from pathlib import Path

        from sarnav.montecarlo.seeding import run_seeds
        from sarnav.report.rda_nav_figures import plot_aperture_images, plot_sar_ablation
        from sarnav.tomlio import parse_toml

        cfg = parse_toml(results.attrs["scenario"])
        prm = parse(cfg)
        seed0 = run_seeds(int(cfg["campaign"]["seed"]), int(cfg["campaign"]["runs"]))[0]
        outdir = Path(outdir)
        paths = []
        if prm.sar_enabled and prm.measurement == "image":
            cap = capture_images(prm, seed0, min(10, prm.n_updates - 1))
            paths.append(plot_aperture_images(cap, outdir / "sar_images_run0.png"))
        if prm.sar_enabled:
            off = copy.deepcopy(cfg)
            off["sar"]["enabled"] = False
            rec = simulate_runs(parse(off), [0], [seed0])[0]
            pos = [list(results["state"].values).index(s) for s in ("pN", "pE", "pD")]
            paths.append(plot_sar_ablation(results["time"].values, results["sigma"].values[0][:, pos],
                                           rec.time, rec.sigma[:, :3], outdir / "position_3sigma_with_without_sar.png"))
        return paths
