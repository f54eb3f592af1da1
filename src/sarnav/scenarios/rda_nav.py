"""The ``rda-nav`` scenario kind: INS + altimeter + SAR range/cross-range from 1-s RDA sub-apertures.

Lindstrom et al., NAVIGATION 69(3) (extraction seed-001) and thesis ch. 5; design and gap decisions in
docs/scenarios/rda-nav.md. Scenarios ``rda-nav`` (paper sim, Tables 1-3) and ``rda-nav-flexsar``
(simulated FlexSAR-like flight, Tables 4-6).

Per run: analytic truth (straight, level) -> IMU (white noise + FOGM biases) -> strapdown INS ->
covariance propagation (Van Loan per 0.1-s step) -> at the end of every 1-s sub-aperture one stacked
update [altimeter, range, cross-range] (Joseph form), full feedback and reset. The SAR measurement refers
to the reference target's time of closest approach (TOC) inside the aperture; the estimate there comes
from the INS history of the aperture and H is mapped to the update epoch by Phi(t_toc, t_k) (eq. 57).
With ``sar.second_order`` (default) z_hat and R get the Gaussian second-order terms of the range and
cross-range functions under the TOC covariance (the zero-Doppler lever is divided by the estimated speed).

``sar.measurement``:
* ``"oracle"``: z from the truth state at the true TOC plus the truth FOGM bias and white noise
  (the only mode in which truth enters a measurement);
* ``"image"``: echoes -> range compression -> RDA with the estimated speed -> mapdrift -> registration
  against the geolocated reference chip (``sarnav.scenarios.rda_nav_imaging``).
``sar.enabled = false`` flies with the altimeter only.

Random draws, per run from its own Generator, in this order: IMU biases (6), measurement biases (3),
initial error (18), measurement-bias drive (cov steps x 3), the clutter seed (1 integer), IMU sample 0; then
per update the IMU block, the altimeter noise and (SAR enabled) the two SAR noises. Run i depends only on
cfg and seeds[i]; the reference targets are drawn from ``scene.seed`` (the same world for every run), the
clutter from the run's clutter seed (``scene.clutter_per_run``, default) or from ``scene.seed``.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError, require_finite, require_positive
from sarnav.filters import ErrorStateLayout, correlated_update, normalized_squared
from sarnav.measurements.image_shift import (
    CROSS_RANGE_MODELS,
    CrossRangeMeasurement,
    RangeMeasurement,
    closest_approach,
    interpolate_state,
    second_order_terms,
)
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.montecarlo.record import RunRecord
from sarnav.rotations import quat_to_dcm
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.montecarlo.kind import validate_campaign
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import get as _get
from sarnav.scenarios.fields import positive as _pos
from sarnav.scenarios.fields import table as _table
from sarnav.scenarios.fields import vector as _vector
from sarnav.scenarios.flight import ErrorStateFlight, FlightSpec
from sarnav.sensors.imu import GRADE_THREE_SIGMA, ImuGrade
from sarnav.trajectory import StraightLevel

#: covariance-propagation step [s] (F held constant over a step); also the INS history spacing
COV_STEP = 0.1
STATE_LAYOUT = ErrorStateLayout(("b_alt", "b_range", "b_cross"), scalar_units=("m", "m", "m"))
MEAS_NAMES = ["alt", "range", "cross"]
MEAS_UNITS = ["m", "m", "m"]
MEASUREMENT_MODES = ("oracle", "image")
STAGES = ("echoes", "rda", "autofocus", "registration", "update")
_IMU_KEYS = ("vrw_3sigma", "accel_bias_3sigma", "arw_3sigma", "gyro_bias_3sigma")


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
        "radar": {"preset": "nav-paper-sim"},  # Table 3
        "scene": {
            "seed": 7,
            "ground_range_min": 1760.0,  # slant 2021 m at 1000 m altitude (window 2000-2210 m)
            "ground_range_max": 1940.0,  # slant 2183 m
            "toc_jitter_s": 0.25,  # reference-target TOC = aperture centre +- this (G4)
            "clutter_per_image": 4,  # G5
            "clutter_per_run": True,  # G5: clutter redrawn per run (independent registration errors)
            "reflector_amplitude": 3.16,  # 10 dB above the unit-mean-power clutter (G4)
            "snr_db": -10.0,  # receiver noise: per-sample SNR of the reflector (G5); independent per acquisition
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
    return [f"imu.{k}" for k in _IMU_KEYS]


@dataclass(frozen=True)
class RdaNavParams:
    """Validated, SI-converted content of an rda-nav scenario."""

    runs: int
    trajectory: StraightLevel
    altitude: float
    imu_grade: ImuGrade
    imu_rate: float
    tau_accel: float
    tau_gyro: float
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
    radar_preset: str
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


def parse(cfg: dict) -> RdaNavParams:
    """Validate ``cfg`` and convert to SI; ConfigError names the first bad field and its range."""
    runs, seed = validate_campaign(cfg)

    start = _vector(cfg, "trajectory", "start_ned", unit="m")
    if not start[2] < 0:
        raise ConfigError("trajectory.start_ned[2]", f"must be < 0 m (above the ground, NED down), got {start[2]}")
    speed = _pos(cfg, "trajectory", "speed", "m/s")
    heading = float(units.deg_to_rad(require_finite("trajectory.heading_deg", _get(cfg, "trajectory", "heading_deg"), -360.0, 360.0, "deg")))
    duration = require_finite("trajectory.duration", _get(cfg, "trajectory", "duration"), 1.0, 3600.0, "s")
    if abs(duration - round(duration)) > 1e-9:
        raise ConfigError("trajectory.duration", f"must be a whole number of 1-s sub-apertures, got {duration}")
    traj = StraightLevel(start, speed, heading, duration)

    imu = _table(cfg, "imu")
    grade_name = imu.get("grade")
    if grade_name not in GRADE_THREE_SIGMA:
        raise ConfigError("imu.grade", f"must be one of {sorted(GRADE_THREE_SIGMA)}, got {grade_name!r}")
    vals3 = [imu.get(k, b) for k, b in zip(_IMU_KEYS, GRADE_THREE_SIGMA[grade_name])]
    for k, v in zip(_IMU_KEYS, vals3):
        require_positive(f"imu.{k}", v)
    grade = ImuGrade.from_three_sigma(grade_name, *vals3)
    imu_rate = _pos(cfg, "imu", "rate_hz", "Hz")
    n_step = imu_rate * COV_STEP
    if abs(n_step - round(n_step)) > 1e-9 or round(n_step) < 1:
        raise ConfigError("imu.rate_hz", f"must be a multiple of {1 / COV_STEP:g} Hz, got {imu_rate}")

    three = units.three_sigma_to_sigma
    alt_sigma = three(_pos(cfg, "altimeter", "sigma_3sigma", "m"))
    sar = _table(cfg, "sar")
    enabled = _bool(cfg, "sar", "enabled")
    mode = sar.get("measurement")
    if mode not in MEASUREMENT_MODES:
        raise ConfigError("sar.measurement", f"must be one of {MEASUREMENT_MODES}, got {mode!r}")
    cross_model = sar.get("cross_range_model")
    if cross_model not in CROSS_RANGE_MODELS:
        raise ConfigError("sar.cross_range_model", f"must be one of {CROSS_RANGE_MODELS}, got {cross_model!r}")
    if cross_model == "paper" and mode == "image":
        raise ConfigError("sar.cross_range_model", "'paper' (eq. 48 with constant u_c, r_orig) cannot be made from "
                          "an image; use 'zero-doppler' with sar.measurement = 'image'")
    delayed = _bool(cfg, "sar", "delayed_state")
    second = _bool(cfg, "sar", "second_order")
    sar_sigma = three(np.array([_pos(cfg, "sar", "range_3sigma", "m"), _pos(cfg, "sar", "cross_3sigma", "m")]))
    reg_sigma = _vector(cfg, "sar", "registration_sigma_m", n=2, positive=True, unit="m")
    added = _bool(cfg, "sar", "image_added_noise")
    bias3 = np.array([_pos(cfg, "altimeter", "bias_3sigma", "m"), _pos(cfg, "sar", "bias_range_3sigma", "m"),
                      _pos(cfg, "sar", "bias_cross_3sigma", "m")])
    bias_tau = np.array([_pos(cfg, "altimeter", "tau", "s"), _pos(cfg, "sar", "tau_range", "s"), _pos(cfg, "sar", "tau_cross", "s")])

    preset = _get(cfg, "radar", "preset")
    if preset not in ("nav-paper-sim", "flexsar"):
        raise ConfigError("radar.preset", f"must be 'nav-paper-sim' or 'flexsar', got {preset!r}")
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
    refl = _pos(cfg, "scene", "reflector_amplitude")
    snr = require_finite("scene.snr_db", _get(cfg, "scene", "snr_db"), -60.0, 100.0, "dB")
    scene = {"seed": seed_s, "ground_range": (gmin, gmax), "toc_jitter": jitter, "clutter": clutter,
             "reflector_amplitude": refl, "snr_db": float(snr), "clutter_per_run": _bool(cfg, "scene", "clutter_per_run")}

    p3 = _vector(cfg, "initial", "p_3sigma", positive=True, unit="m")
    v3 = _vector(cfg, "initial", "v_3sigma", positive=True, unit="m/s")
    th3 = _vector(cfg, "initial", "theta_3sigma", positive=True, unit="rad")
    p0 = np.concatenate([three(p3), three(v3), three(th3), np.full(3, grade.accel_bias), np.full(3, grade.gyro_bias),
                         three(bias3)])
    return RdaNavParams(
        runs=runs, trajectory=traj, altitude=float(-start[2]), imu_grade=grade, imu_rate=imu_rate,
        tau_accel=_pos(cfg, "imu", "tau_accel", "s"), tau_gyro=_pos(cfg, "imu", "tau_gyro", "s"),
        alt_sigma=float(alt_sigma), sar_enabled=enabled, measurement=mode, cross_model=cross_model,
        delayed_state=delayed, second_order=second, sar_sigma=sar_sigma, registration_sigma=reg_sigma, image_added_noise=added, bias_sigma=three(bias3),
        bias_tau=bias_tau, radar_preset=preset, scene=scene, p0_sigma=p0,
    )


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
    u = np.array([math.cos(traj.heading), math.sin(traj.heading), 0.0])
    w = np.array([-math.sin(traj.heading), math.cos(traj.heading), 0.0])  # right of the heading
    k = np.arange(prm.n_updates)
    toc = k + 0.5 + rng.uniform(-prm.scene["toc_jitter"], prm.scene["toc_jitter"], k.size)
    gr = rng.uniform(*prm.scene["ground_range"], k.size)
    start = traj.state(np.array([0.0])).position[0]
    ground = np.array([start[0], start[1], 0.0])
    return ground + (traj.speed * toc)[:, None] * u + gr[:, None] * w


# --- the Monte Carlo ------------------------------------------------------------------------------

def _phi_back(model, T_hat, f_mean, span):
    """Phi(t_toc, t_k) = Phi(t_k, t_toc)^-1 and the process noise Q_d accumulated over [t_toc, t_k] (R, n, n)."""
    n = model.layout.n
    if span <= 0:
        eye = np.broadcast_to(np.eye(n), (T_hat.shape[0], n, n))
        return eye, np.zeros_like(eye)
    Phi, Qd = model.discretize(T_hat, f_mean, span)
    return np.linalg.inv(Phi), Qd


def simulate_runs(prm: RdaNavParams, run_ids, seeds) -> list[RunRecord]:
    """The batched Monte Carlo of :class:`RdaNavKind` (see the module docstring)."""
    L = STATE_LAYOUT
    spec = FlightSpec(prm.trajectory, prm.imu_grade, prm.imu_rate, prm.tau_accel, prm.tau_gyro, prm.bias_sigma,
                      prm.bias_tau, prm.p0_sigma, prm.n_updates, prm.samples_per_update, prm.samples_per_step)
    # the clutter seed is drawn after the bias drive, before IMU sample 0; F at the step's start attitude
    fl = ErrorStateFlight(spec, L, seeds, extra_draws=lambda rngs: [int(g.integers(2**63)) for g in rngs],
                          covariance_attitude="start")
    rngs, R, traj, model = fl.rngs, fl.R, prm.trajectory, fl.model
    steps, n_upd, t_out, truth_out, bm_truth = fl.steps, prm.n_updates, fl.t_out, fl.truth_out, fl.bm_truth
    targets = reference_targets(prm)
    i_range, i_cross = L.index("b_range"), L.index("b_cross")
    alt = AltimeterMeasurement(prm.alt_sigma, L)
    clutter_seeds = fl.extra
    imaging = None
    if prm.sar_enabled and prm.measurement == "image":
        from sarnav.scenarios.rda_nav_imaging import ApertureImager

        imaging = ApertureImager(prm, targets, clutter_seeds if prm.scene["clutter_per_run"] else None,
                                 noise_seeds=clutter_seeds)
    res = np.full((R, n_upd, 3), np.nan)
    res_sig = np.full((R, n_upd, 3), np.nan)
    nis = np.empty((R, n_upd))
    toc_used = np.full((R, n_upd), np.nan)
    reg_err = np.full((R, n_upd, 3), np.nan)
    af_dk = np.full((R, n_upd), np.nan)
    stage_s = np.zeros((R, n_upd, len(STAGES)))

    for u in range(n_upd):
        iv = fl.fly_interval(u)
        j, ap_t, ap_p, ap_v, f_mean = iv["j"], iv["t"], iv["p"], iv["v"], iv["f_mean"]
        truth, nav, P = fl.truth, fl.nav, fl.P
        t_k = t_out[j]

        # --- measurements at the end of the sub-aperture ---
        z_alt = alt.simulate(truth, bm_truth[:, j, 0], rngs)
        zh_alt, H_alt, R_alt = alt.predict(nav)
        if prm.sar_enabled:
            targ = targets[u]
            eta_true, _, p_true_toc = closest_approach(targ, ap_t, truth_out.position[u * steps:j + 1])
            v_true_toc = traj.state(np.array([eta_true])).velocity[0]
            noise = np.stack([g.standard_normal(2) for g in rngs])  # (R, 2), drawn in every mode
            if imaging is not None:
                u_hat = nav.v / np.linalg.norm(nav.v, axis=1, keepdims=True)
                vv = P[:, L.slice("v"), L.slice("v")]
                speed_sigma = np.sqrt(np.einsum("ri,rij,rj->r", u_hat, vv, u_hat))
                meas = imaging.measure(u, ap_t, ap_p, ap_v, stage_s[:, u], speed_sigma)
                eta_meas = meas["toc"]
            else:
                eta_meas = np.full(R, eta_true)
            t0 = _time.perf_counter()
            meas_sigma, add_white = measurement_sigma(prm, image=imaging is not None)
            z_sar = np.empty((R, 2))
            zh_sar = np.empty((R, 2))
            H_sar = np.empty((R, 2, L.n))
            R_sar = np.zeros((R, 2, 2))
            C_sar = np.zeros((R, L.n, 2))
            T_last = quat_to_dcm(nav.q)
            for r in range(R):
                span = t_k - eta_meas[r]
                phi, q_back = (_phi_back(model, T_last[r:r + 1], f_mean[r:r + 1], span)
                               if prm.delayed_state else (None, None))
                phi = None if phi is None else phi[0]
                p_hat_toc = interpolate_state(ap_t, ap_p[r], eta_meas[r])
                v_hat_toc = interpolate_state(ap_t, ap_v[r], eta_meas[r])
                kw = {}
                if prm.cross_model == "paper":
                    kw = dict(u_c=ap_p[r, -1] - ap_p[r, 0], r_orig=ap_p[r, 0])
                rm = RangeMeasurement(targ, meas_sigma[0], L.n, i_range, phi_back=phi)
                cm = CrossRangeMeasurement(targ, meas_sigma[1], L.n, i_cross,
                                           model_name=prm.cross_model, phi_back=phi, **kw)
                zr, Hr, Rr = rm.predict(p_hat_toc, v_hat_toc, nav.bm[r, 1])
                zc, Hc, Rc = cm.predict(p_hat_toc, v_hat_toc, nav.bm[r, 2])
                zh_sar[r] = [zr[0], zc[0]]
                H_sar[r] = np.vstack([Hr, Hc])
                R_sar[r] = np.diag([Rr[0, 0], Rc[0, 0]])
                if prm.second_order:
                    # Gaussian second-order filter: E[h] and the variance of the quadratic remainder under the
                    # error covariance at the TOC, dx(t_toc) = Phi^-1 (dx(t_k) - w): P_toc = Phi^-1 (P - Q_d) Phi^-T
                    P_toc = P[r] if phi is None else phi @ (P[r] - q_back[0]) @ phi.T
                    dz2, C2 = second_order_terms([rm.hessian(p_hat_toc), cm.hessian(p_hat_toc, v_hat_toc)], P_toc)
                    zh_sar[r] += dz2
                    R_sar[r] += C2
                if q_back is not None:
                    # dx(t_toc) = Phi^-1 (dx(t_k) - w), w ~ N(0, Q_d over [t_toc, t_k]): the SAR noise becomes
                    # nu = v - H w, cov H Q_d H^T + R, correlated with dx(t_k): cov(dx_k, nu) = -Q_d H^T
                    R_sar[r] += H_sar[r] @ q_back[0] @ H_sar[r].T
                    C_sar[r] = -q_back[0] @ H_sar[r].T
                b_true = bm_truth[r, j, 1:3]
                n_add = prm.sar_sigma * noise[r] * add_white
                if imaging is None:  # oracle: truth model at the true TOC (eqs. 47-48)
                    z_sar[r] = [rm.model(p_true_toc, v_true_toc, b_true[0]) + n_add[0],
                                cm.model(p_true_toc, v_true_toc, b_true[1]) + n_add[1]]
                    toc_used[r, u] = eta_true
                else:  # image: measured ROC, and 0 for the zero-Doppler cross-range (G1, G11)
                    z_sar[r] = [meas["range"][r] + b_true[0] + n_add[0], b_true[1] + n_add[1]]
                    toc_used[r, u] = eta_meas[r]
                    # registration error: measured minus geometric truth (range, along-track)
                    reg_err[r, u, 1] = meas["range"][r] - np.linalg.norm(targ - p_true_toc)
                    reg_err[r, u, 2] = traj.speed * (eta_meas[r] - eta_true)
                    af_dk[r, u] = meas["autofocus_dk"][r]
            z = np.concatenate([z_alt, z_sar], axis=1)
            z_hat = np.concatenate([zh_alt, zh_sar], axis=1)
            H = np.concatenate([H_alt, H_sar], axis=1)
            Rm = np.zeros((R, 3, 3))
            Rm[:, :1, :1] = R_alt
            Rm[:, 1:, 1:] = R_sar
            Cm = np.zeros((R, L.n, 3))
            Cm[:, :, 1:] = C_sar
            cols = slice(0, 3)
            stage_s[:, u, STAGES.index("update")] += (_time.perf_counter() - t0) / R
        else:
            z, z_hat, H, Rm, cols = z_alt, zh_alt, H_alt, R_alt, slice(0, 1)
            Cm = np.zeros((R, L.n, 1))
        r_vec = z - z_hat
        dx, P_post, S = correlated_update(P, H, Rm, Cm, r_vec)
        fl.after_update(j, dx, P_post)
        res[:, u, cols] = r_vec
        res_sig[:, u, cols] = np.sqrt(np.einsum("rii->ri", S))
        nis[:, u] = normalized_squared(r_vec, S)
    err, sig, nees = fl.err, fl.sig, fl.nees

    t_upd = t_out[steps::steps]
    dof = 3 if prm.sar_enabled else 1
    records = []
    for i in range(R):
        extras = {"toc": (("update",), toc_used[i])}
        if imaging is not None:
            extras["registration_error"] = (("update", "meas"), reg_err[i])
            extras["autofocus_dk"] = (("update",), af_dk[i])
            extras["stage_seconds"] = (("update", "stage"), stage_s[i])
        records.append(RunRecord(
            run=int(run_ids[i]), time=t_out.copy(), error=err[i], sigma=sig[i], nees=nees[i],
            update_time=t_upd.copy(), residual=res[i], residual_sigma=res_sig[i], nis=nis[i],
            nis_dof=np.full(n_upd, dof, dtype=int), extras=extras))
    return records


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
        from sarnav.scenarios.rda_nav_imaging import capture_images

        cfg = parse_toml(results.attrs["scenario"])
        prm = parse(cfg)
        seed0 = run_seeds(int(cfg["campaign"]["seed"]), int(cfg["campaign"]["runs"]))[0]
        outdir = Path(outdir)
        paths = []
        if prm.sar_enabled and prm.measurement == "image":
            with capture_images(min(10, prm.n_updates - 1)) as cap:
                simulate_runs(prm, [0], [seed0])
            paths.append(plot_aperture_images(cap, outdir / "sar_images_run0.png"))
        if prm.sar_enabled:
            off = copy.deepcopy(cfg)
            off["sar"]["enabled"] = False
            rec = simulate_runs(parse(off), [0], [seed0])[0]
            pos = [list(results["state"].values).index(s) for s in ("pN", "pE", "pD")]
            paths.append(plot_sar_ablation(results["time"].values, results["sigma"].values[0][:, pos],
                                           rec.time, rec.sigma[:, :3], outdir / "position_3sigma_with_without_sar.png"))
        return paths
