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
from sarnav.measurements.sar import (CROSS_RANGE_MODELS, SarCrossRangeMeasurement, SarRangeMeasurement,
                                     target_position_noise)
from sarnav.measurements.sar_image import ALGORITHMS, FAILURES, FOCUS, ImagingSettings, SubApertureImager
from sarnav.measurements.sar_image import STAGES as IMAGE_STAGES
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.montecarlo.kind import validate_campaign
from sarnav.montecarlo.record import RunRecord
from sarnav.radar.params import RadarParams
from sarnav.rotations import quat_to_dcm
from sarnav.scenarios import rda_nav_world as world
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import get as _get
from sarnav.scenarios.fields import positive as _pos
from sarnav.scenarios.fields import table as _table
from sarnav.scenarios.fields import vector as _vector
from sarnav.scenarios.vocabulary import (EARTH_DEFAULT, IMU_OVERRIDES, RADAR_KEYS, filter_imu_keys, read_earth,
                                         flight_size_check, make_radar, radar_fields, read_filter_imu, read_imu,
                                         read_initial, read_trajectory, whole_number)
from sarnav.navigation import Interval
from sarnav.simulation.flight import ErrorStateFlight, FlightSpec, ImuSpec
from sarnav.trajectory import StraightLevel
from sarnav.trajectory.base import Trajectory
from sarnav.trajectory.sampled import along_rate, closest_approach, interpolate_state

#: covariance-propagation step [s] (F held constant over a step); also the INS history spacing
COV_STEP = 0.1
STATE_LAYOUT = ErrorStateLayout(("b_alt", "b_range", "b_cross"), scalar_units=("m", "m", "m"))
MEASUREMENT_MODES = ("oracle", "image")
STAGES = IMAGE_STAGES + ("update",)
#: why a SAR pair was not fused (``update_rejected``): the image's own failures, then the innovation gate
REJECTIONS = FAILURES + ("innovation gate",)
#: slant-range margin of the receive window beyond the imaged scene [m] (``radar.range_margin_m``)
DEFAULT_RANGE_MARGIN_M = 30.0
#: largest echo block of one sub-aperture (pulses x range samples): refused beyond it before anything is allocated
MAX_ECHO_SAMPLES = 2.0e7
#: [scene] keys of the terrain scene (in every configuration; used with scene.type = "terrain")
TERRAIN_KEYS = ("terrain_relief_m", "terrain_scale_m", "clutter_density_m2", "clutter_power_m2", "bright_features",
                "bright_amplitude", "reference_coherence")


def meas_names(targets: int) -> list[str]:
    """``alt, range, cross`` and, for several reference targets per image, ``range2, cross2, ...``."""
    out = ["alt"]
    for k in range(targets):
        out += [f"range{k + 1 if k else ''}", f"cross{k + 1 if k else ''}"]
    return out


def extra_attrs() -> dict:
    """Units and descriptions of the extra results.nc variables."""
    reasons = "; ".join(f"{i}: {r}" for i, r in enumerate(REJECTIONS) if i)
    return {
        "toc": {"units": "s", "description": "time of closest approach of the (first) reference target each SAR "
                                             "update refers to: measured from the image (image mode) or the truth"},
        "registration_error": {"units": "m", "description": "image-derived minus geometric truth: range of closest "
                                                            "approach (range), along-track TOC error x the rate of "
                                                            "the along-track offset (V on a straight track: "
                                                            "trajectory.sampled.along_rate) less the modelled focusing shift "
                                                            "(cross); NaN for the altimeter"},
        "registration_sigma": {"units": "m", "description": "1-sigma of the registration predicted from each image "
                                                            "(imaging.registration.magnitude_shift_precision and the "
                                                            "focus sensitivity): range, along-track; the R of the update"},
        "autofocus_dk": {"units": "Hz/s", "description": "mapdrift correction of the azimuth FM rate, K_a - K_amf"},
        "stage_seconds": {"units": "s", "description": "wall time per stage of each image and update (per run)"},
        "update_rejected": {"units": "1", "description": "0 when every SAR pair of the update was fused, else why "
                                                         f"the first one was not: {reasons}",
                            "flag_values": list(range(len(REJECTIONS))), "flag_meanings": " ".join(
                                r.replace(" ", "_").replace("(", "").replace(")", "") or "fused" for r in REJECTIONS)},
        "pairs_fused": {"units": "1", "description": "SAR (range, cross-range) pairs fused in the update"},
    }


# --- configuration ------------------------------------------------------------------------------

def default_config() -> dict:
    """Paper simulation (Tables 1-3, 200 runs, L1357); gap fills commented, see docs/scenarios/rda-nav.md."""
    return {
        "scenario": {"name": "rda-nav", "kind": "rda-nav",
                     "description": "NAVIGATION paper sim / thesis ch. 5: INS + altimeter + RDA range/cross-range EKF"},
        "campaign": {"runs": 200, "seed": 2022},  # 200 runs: paper L1357
        "trajectory": {
            "type": "straight",  # or "turning" (level S-turn), "maneuver" (turns and climbs): sar.algorithm = "bpa"
            "start_ned": [0.0, 0.0, -1000.0],  # altitude not given (G7): 1000 m, thesis §18
            "speed": 10.0,  # Table 3
            "heading_deg": 0.0,  # northbound (L1289)
            "duration": 50.0,  # 50 x 1-s sub-apertures (G17)
        },
        "earth": dict(EARTH_DEFAULT),  # the sources' non-rotating Earth (NAVIGATION L1481-L1488); docs/navigation.md
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
            "algorithm": "rda",  # "bpa": back-projection along the estimated track (any trajectory)
            "cross_range_model": "zero-doppler",  # G1: docs/scenarios/rda-nav.md §2
            "delayed_state": True,  # H mapped from the TOC to the update epoch (eq. 57)
            "second_order": True,  # Gaussian second-order terms of h (zero-Doppler lever / |v|), §2
            "range_3sigma": 0.75,  # Table 2 (oracle mode's noise)
            "cross_3sigma": 0.75,  # Table 2
            "bias_range_3sigma": 0.25,  # Table 1
            "bias_cross_3sigma": 0.25,  # Table 1
            "tau_range": 3600.0,  # G2
            "tau_cross": 3600.0,
            # image mode: R from each image's predicted registration 1-sigma (§3); sar.registration_sigma_m =
            # [range, along-track] [m] overrides it with constants
            "focus": "estimate",  # image focused with the estimated trajectory, the focusing shift modelled (§2)
            "autofocus": True,  # mapdrift runs (recorded as autofocus_dk; the image with focus = "mapdrift")
            "gate_probability": 1e-4,  # chi-square innovation gate of each SAR pair (false-rejection rate; 0: off)
            "min_correlation": 0.5,  # a match below this normalised correlation is refused (update skipped)
            "max_ambiguity": 0.9,  # ... and one whose second-best match is this close
            "image_added_noise": False,  # true: also add Table 2's white noise (range/cross_3sigma) in image mode
        },
        "radar": {
            "preset": "nav-paper-sim",  # Table 3; every radar key may be set over it (docs/scenarios/vocabulary.md)
            "snr_db": -10.0,  # receiver noise: per-sample SNR of the reflector (G5); independent per acquisition
            "range_margin_m": DEFAULT_RANGE_MARGIN_M,  # receive window = imaged slant ranges +- this (+ cT/4)
        },
        "scene": {
            "type": "points",  # or "terrain": DEM, speckle clutter, bright features, a reference from another pass
            "seed": 7,
            "ground_range_min": 1760.0,  # slant 2021 m at 1000 m altitude
            "ground_range_max": 1940.0,  # slant 2183 m
            "toc_jitter_s": 0.25,  # reference-target TOC = aperture centre +- this (G4)
            "targets_per_image": 1,  # reference targets per sub-aperture (each gives a range/cross-range pair)
            "clutter_per_image": 4,  # G5 (points scene)
            "clutter_per_run": True,  # G5: clutter redrawn per run (independent registration errors)
            "reflector_amplitude": 3.16,  # 10 dB above the unit-mean-power clutter (G4)
            "reference_offset_m": [0.0, 0.0],  # reference pass: [across (right of the track), up] [m]
            "geolocation_sigma_m": [0.0, 0.0, 0.0],  # the map's 1-sigma error of each target, N E D [m] (D in R)
            # scene.type = "terrain" (§4):
            "terrain_relief_m": 20.0,  # 1-sigma height of the Gaussian hills [m]
            "terrain_scale_m": [40.0, 200.0],  # hill widths [m]
            "clutter_density_m2": 2.0,  # speckle scatterers per m^2 (a resolution cell is ~1 m^2: several per cell)
            "clutter_power_m2": 0.1,  # sigma0: clutter power per m^2 (|a|^2 of a point scatterer): the reflector
                                      # stands 20 dB above the clutter of its resolution cell
            "bright_features": 2,  # stable bright scatterers per target and sub-aperture
            "bright_amplitude": 2.0,
            "reference_coherence": 1.0,  # temporal coherence of the clutter between the passes
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
    cfg["radar"]["preset"] = "flexsar"
    cfg["scene"]["ground_range_min"] = 1690.0  # slant 1966 m
    cfg["scene"]["ground_range_max"] = 1830.0  # slant 2086 m
    return cfg


def terrain_config() -> dict:
    """The paper sim over terrain (docs §4): hills, speckle clutter, bright features, one scene for every run, and a
    reference product from another pass (30 m to the side, 20 m higher, clutter coherence 0.8) whose geolocation
    has its own error (0.3 m horizontal, 0.5 m vertical, 1-sigma)."""
    cfg = default_config()
    cfg["scenario"].update(name="rda-nav-terrain", description="rda-nav over terrain with speckle clutter and a "
                           "reference from another pass")
    cfg["scene"].update(type="terrain", reference_offset_m=[30.0, 20.0], geolocation_sigma_m=[0.3, 0.3, 0.5],
                        reference_coherence=0.8)
    return cfg


def optional_keys() -> list[str]:
    """Keys accepted although the default configuration leaves them out: IMU 3-sigma overrides, [filter.imu],
    radar fields over the preset and the receive window, a constant registration sigma."""
    return ([f"imu.{k}" for k in IMU_OVERRIDES] + filter_imu_keys() + [f"radar.{k}" for k in RADAR_KEYS]
            + ["radar.near_range_m", "radar.n_range_samples", "sar.registration_sigma_m", "trajectory.turn_rate_deg_s"])


@dataclass(frozen=True)
class RdaNavParams:
    """Validated, SI-converted content of an rda-nav scenario."""

    runs: int
    trajectory: Trajectory
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
    registration_sigma: np.ndarray | None  # (2,) image mode override of the predicted 1-sigma: range, along-track [m]
    image_added_noise: bool
    gate_probability: float
    imaging: ImagingSettings
    bias_sigma: np.ndarray  # (3,) b_alt, b_range, b_cross steady-state sigma [m]
    bias_tau: np.ndarray  # (3,)
    radar: RadarParams
    snr_db: float  # receiver noise: per-sample SNR of the reflector [dB]
    scene: dict
    p0_sigma: np.ndarray  # (18,)
    earth_rate: np.ndarray | None = None  # [earth]: omega_ie^t when earth.rotation, else None
    filter_earth_rate: np.ndarray | None = None  # what the INS / filter assume (None unless earth.modelled)

    @property
    def n_updates(self) -> int:
        return int(math.floor(self.trajectory.duration + 1e-9))

    @property
    def samples_per_update(self) -> int:
        return int(round(self.imu_rate))

    @property
    def samples_per_step(self) -> int:
        return int(round(self.imu_rate * COV_STEP))

    @property
    def targets_per_image(self) -> int:
        return self.scene["targets_per_image"]

    @property
    def focus(self) -> str:
        return self.imaging.focus


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
                registration_sigma=(_vector(cfg, "sar", "registration_sigma_m", n=2, positive=True, unit="m")
                                    if "registration_sigma_m" in sar else None),
                image_added_noise=_bool(cfg, "sar", "image_added_noise"), **_parse_imaging(cfg))


def _parse_imaging(cfg: dict) -> dict:
    algorithm = _get(cfg, "sar", "algorithm")
    if algorithm not in ALGORITHMS:
        raise ConfigError("sar.algorithm", f"must be one of {ALGORITHMS}, got {algorithm!r}")
    focus = _get(cfg, "sar", "focus")
    if focus not in FOCUS:
        raise ConfigError("sar.focus", f"must be one of {FOCUS}, got {focus!r}")
    gate = require_finite("sar.gate_probability", _get(cfg, "sar", "gate_probability"), 0.0, 0.5)
    corr = require_finite("sar.min_correlation", _get(cfg, "sar", "min_correlation"), 0.0, 1.0)
    amb = require_finite("sar.max_ambiguity", _get(cfg, "sar", "max_ambiguity"), 0.0, 1.0)
    return dict(gate_probability=gate,
                imaging=ImagingSettings(algorithm=algorithm, focus=focus, autofocus=_bool(cfg, "sar", "autofocus"),
                                        min_correlation=corr, max_ambiguity=amb))


def _count(cfg, key, lo, hi) -> int:
    v = _get(cfg, "scene", key)
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise ConfigError(f"scene.{key}", f"must be an integer in [{lo}, {hi}], got {v!r}")
    return v


def _parse_scene(cfg: dict) -> dict:
    sc = _table(cfg, "scene")
    stype = sc.get("type")
    if stype not in world.SCENE_TYPES:
        raise ConfigError("scene.type", f"must be one of {world.SCENE_TYPES}, got {stype!r}")
    seed_s = sc.get("seed")
    if isinstance(seed_s, bool) or not isinstance(seed_s, int) or not 0 <= seed_s < 2**63:
        raise ConfigError("scene.seed", f"must be an integer in [0, 2^63), got {seed_s!r}")
    gmin = _pos(cfg, "scene", "ground_range_min", "m", hi=1.0e6)
    gmax = _pos(cfg, "scene", "ground_range_max", "m", hi=1.0e6)
    if not gmax > gmin:
        raise ConfigError("scene.ground_range_max", f"must be > scene.ground_range_min = {gmin} m, got {gmax}")
    scale = _vector(cfg, "scene", "terrain_scale_m", n=2, positive=True, unit="m")
    geo = _vector(cfg, "scene", "geolocation_sigma_m", n=3, unit="m")
    if np.any(geo < 0) or np.any(geo > 100.0):
        raise ConfigError("scene.geolocation_sigma_m", f"must be three 1-sigma values in [0, 100] m, got {geo.tolist()}")
    offset = _vector(cfg, "scene", "reference_offset_m", n=2, unit="m")
    if np.any(np.abs(offset) > 1.0e4):
        raise ConfigError("scene.reference_offset_m", f"must be within +-1e4 m, got {offset.tolist()}")
    return {"type": stype, "seed": seed_s, "ground_range": (gmin, gmax),
            "toc_jitter": require_finite("scene.toc_jitter_s", _get(cfg, "scene", "toc_jitter_s"), 0.0, 0.4, "s"),
            "targets_per_image": _count(cfg, "targets_per_image", 1, 8),
            "clutter": _count(cfg, "clutter_per_image", 0, 1000),
            "reflector_amplitude": _pos(cfg, "scene", "reflector_amplitude", hi=1.0e6),
            "clutter_per_run": _bool(cfg, "scene", "clutter_per_run"),
            "reference_offset": (float(offset[0]), float(offset[1])), "geolocation_sigma": geo,
            "terrain_relief": require_finite("scene.terrain_relief_m", _get(cfg, "scene", "terrain_relief_m"), 0.0,
                                             1000.0, "m"),
            "terrain_scale": (float(scale[0]), float(scale[1])),
            "clutter_density": _pos(cfg, "scene", "clutter_density_m2", "1/m^2", hi=1.0e3),
            "clutter_power": require_finite("scene.clutter_power_m2", _get(cfg, "scene", "clutter_power_m2"), 0.0,
                                            1.0e6),
            "bright_features": _count(cfg, "bright_features", 0, 100),
            "bright_amplitude": _pos(cfg, "scene", "bright_amplitude", hi=1.0e6),
            "reference_coherence": require_finite("scene.reference_coherence",
                                                  _get(cfg, "scene", "reference_coherence"), 0.0, 1.0)}


def _parse_radar(cfg: dict, proto) -> RadarParams:
    """``[radar]`` over its preset; the receive window follows the geometry (``rda_nav_world.slant_range_span``)
    unless ``radar.near_range_m`` and ``radar.n_range_samples`` are given; PRF against the Doppler band and the echo
    block size checked before anything is allocated."""
    preset, fields = radar_fields(cfg, ignore=("snr_db", "range_margin_m", "near_range_m", "n_range_samples"))
    r = _table(cfg, "radar")
    base = make_radar(preset, fields)  # the preset's own window: to learn its pulse length and sampling
    if ("near_range_m" in r) != ("n_range_samples" in r):
        raise ConfigError("radar.near_range_m", "give both radar.near_range_m and radar.n_range_samples, or neither "
                          "(the receive window then follows the geometry)")
    if "near_range_m" in r:
        n = r["n_range_samples"]
        if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= 10**6:
            raise ConfigError("radar.n_range_samples", f"must be an integer in [2, 1e6], got {n!r}")
        window = {"near_range": _pos(cfg, "radar", "near_range_m", "m", hi=1.0e7), "n_range_samples": n}
    else:
        margin = require_finite("radar.range_margin_m", _get(cfg, "radar", "range_margin_m"), 0.0, 1.0e4, "m")
        span = world.slant_range_span(proto, margin)
        window = world.receive_window({"pulse_length": base.pulse_length, "sample_rate": base.sample_rate}, span)
    radar = make_radar(preset, fields, **window)
    size = round(radar.prf) * radar.n_range_samples
    if not size <= MAX_ECHO_SAMPLES:
        raise ConfigError("radar.prf_hz", f"a 1-s sub-aperture of {round(radar.prf)} pulses x "
                          f"{radar.n_range_samples} range samples is {size:.3g} samples; at most {MAX_ECHO_SAMPLES:.0e} "
                          "(lower radar.prf_hz or radar.sample_rate_mhz, or narrow the scene's ground-range band)")
    return radar  # the PRF against the Doppler band: scenarios.error_state (only when images are formed)


@dataclass(frozen=True)
class _Proto:
    """What the receive window needs before the radar exists: the trajectory, the scene, the look side."""

    trajectory: Trajectory
    scene: dict
    radar: object
    n_updates: int


def parse(cfg: dict) -> RdaNavParams:
    """Validate ``cfg`` and convert to SI; ConfigError names the first bad field and its range."""
    runs, seed = validate_campaign(cfg)
    traj = read_trajectory(cfg, types=("straight", "turning", "maneuver"), max_duration=3600.0)
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
    if sar["imaging"].algorithm == "rda" and sar["measurement"] == "image" and not isinstance(traj, StraightLevel):
        raise ConfigError("sar.algorithm", "'rda' assumes a straight track; a manoeuvring trajectory needs "
                          "sar.algorithm = 'bpa' (back-projection along the estimated track)")
    bias3 = np.array([_pos(cfg, "altimeter", "bias_3sigma", "m"), _pos(cfg, "sar", "bias_range_3sigma", "m"),
                      _pos(cfg, "sar", "bias_cross_3sigma", "m")])
    bias_tau = np.array([_pos(cfg, "altimeter", "tau", "s"), _pos(cfg, "sar", "tau_range", "s"), _pos(cfg, "sar", "tau_cross", "s")])
    scene = _parse_scene(cfg)
    side = _table(cfg, "radar").get("look_side", "right")
    proto = _Proto(traj, scene, type("R", (), {"look_side": side})(), int(math.floor(traj.duration + 1e-9)))
    radar = _parse_radar(cfg, proto)
    snr = require_finite("radar.snr_db", _get(cfg, "radar", "snr_db"), -60.0, 100.0, "dB")
    ini = read_initial(cfg, filt)
    p0 = np.concatenate([ini["p"], ini["v"], ini["th"], ini["ba"], ini["bg"], three(bias3)])
    return RdaNavParams(runs=runs, trajectory=traj, altitude=float(-traj.start[2]), imu=imu, imu_filter=filt,
                        imu_rate=imu_rate, alt_sigma=float(alt_sigma), bias_sigma=three(bias3), bias_tau=bias_tau,
                        radar=radar, snr_db=float(snr), scene=scene, p0_sigma=p0, **read_earth(cfg), **sar)


def measurement_sigma(prm: RdaNavParams, image: bool):
    """(sigma (2,) [range, cross] of R before the images are made, 0/1 factor of Table 2's white noise added to z).

    Oracle: Table 2's noise is the measurement's only error and R = its variance. Image: R comes from each image's
    predicted registration sigma (``sar.registration_sigma_m`` replaces it with constants); ``sar.image_added_noise``
    adds Table 2's noise on top (and to R).
    """
    if not image:
        return prm.sar_sigma.copy(), 1.0
    reg = np.ones(2) if prm.registration_sigma is None else prm.registration_sigma  # replaced by each image's
    if prm.image_added_noise:
        return np.hypot(prm.sar_sigma, reg), 1.0
    return reg.copy(), 0.0


def reference_targets(prm: RdaNavParams) -> np.ndarray:
    """(U, 3) the first geolocated reference target of each sub-aperture (``rda_nav_world.reference_targets`` gives
    all of them, (U, T, 3))."""
    return world.reference_targets(prm)[:, 0]


# --- the Monte Carlo ------------------------------------------------------------------------------

def _toc_state(nav: NavState, iv: Interval, eta) -> NavState:
    """The INS estimate at each run's TOC ``eta`` (R,): position and velocity interpolated in the aperture's
    history, the bias estimates of the update epoch."""
    p = np.stack([interpolate_state(iv.t, iv.p[r], eta[r]) for r in range(len(eta))])
    v = np.stack([interpolate_state(iv.t, iv.v[r], eta[r]) for r in range(len(eta))])
    return NavState(p=p, v=v, q=nav.q, ba=nav.ba, bg=nav.bg, bm=nav.bm)


class _Sar:
    """The SAR pairs of one sub-aperture (one per reference target): predictions, the delayed-state, map-geolocation
    and second-order strategies, z, and which runs have a measurement of which target (an image that failed, or a
    match refused, gives none)."""

    def __init__(self, prm: RdaNavParams, fl: ErrorStateFlight, imager):
        self.prm, self.fl, self.imager = prm, fl, imager
        self.T = prm.targets_per_image
        self.targets = world.reference_targets(prm)  # (U, T, 3) truth
        self.map = self.targets[None] + world.map_errors(prm, fl.extra)  # (R, U, T, 3) what the map says
        sig, self.add_white = measurement_sigma(prm, image=imager is not None)
        self.sigma = np.broadcast_to(sig, (fl.R, self.T, 2)).copy()
        self.sensitivity = self.focus_offset = None
        self.status = np.zeros((fl.R, self.T), dtype=np.int64)
        self.D = np.diag(np.asarray(prm.scene["geolocation_sigma"], dtype=np.float64) ** 2)

    def models(self, u: int, iv: Interval, k: int):
        L, targ = self.fl.layout, self.map[:, u, k]
        kw = {}
        if self.prm.cross_model == "paper":  # eq. 49: u_c and r_orig from each run's estimated aperture
            kw = dict(u_c=iv.p[:, -1] - iv.p[:, 0], r_orig=iv.p[:, 0])
        elif self.sensitivity is not None:
            kw = dict(focus_sensitivity=self.sensitivity[:, k], focus_offset=self.focus_offset[:, k])
        return (SarRangeMeasurement(targ, self.sigma[:, k, 0], L),
                SarCrossRangeMeasurement(targ, self.sigma[:, k, 1], L, model=self.prm.cross_model, **kw))

    def predict(self, u: int, iv: Interval, eta) -> Prediction:
        """The stacked prediction of every target's pair, each referred to its own TOC ``eta[:, k]`` and mapped to the
        update epoch (the process noise shared between two targets' TOC intervals is not correlated across pairs:
        docs §3)."""
        return stack_predictions([self._predict_one(u, iv, eta[:, k], k) for k in range(self.T)])

    def _predict_one(self, u, iv, eta, k) -> Prediction:
        fl, prm = self.fl, self.prm
        pred = stack_predictions([m.predict(_toc_state(fl.nav, iv, eta)) for m in self.models(u, iv, k)])
        if np.any(self.D > 0):
            pred = target_position_noise(pred, fl.layout, self.D, (0, 1))
        if prm.delayed_state:
            Phi_inv, Qd = delayed.back_transition(fl.model, quat_to_dcm(fl.nav.q), iv.f_mean, iv.t[-1] - eta)
            if prm.second_order:
                pred = second_order.with_second_order(pred, delayed.covariance_at(fl.P, Phi_inv, Qd))
            return delayed.map_to_update_epoch(pred, Phi_inv, Qd)
        if prm.second_order:
            pred = second_order.with_second_order(pred, fl.P)
        return pred.replace(hessians=None)

    def measure(self, u: int, iv: Interval, noise, record: dict):
        """(z (R, 2T), TOC each pair's prediction refers to (R, T)): from the images, or the oracle's truth."""
        fl, prm, R = self.fl, self.prm, self.fl.R
        j, steps = fl.j, fl.steps
        bm = fl.bm_truth[:, j]
        truth_track = fl.truth_out.position[u * steps:j + 1]
        true_toc = [closest_approach(self.targets[u, k], iv.t, truth_track) for k in range(self.T)]
        if self.imager is None:
            z, eta = [], np.empty((R, self.T))
            for k, (eta_true, _, p_true) in enumerate(true_toc):
                v_true = prm.trajectory.state(np.array([eta_true])).velocity[0]
                truth_toc = NavState(p=np.broadcast_to(p_true, (R, 3)), v=np.broadcast_to(v_true, (R, 3)),
                                     q=fl.nav.q, ba=fl.nav.ba, bg=fl.nav.bg, bm=bm)
                # the oracle measures the true target (the map's error enters only through the prediction)
                ms = [SarRangeMeasurement(self.targets[u, k], self.sigma[:, k, 0], fl.layout),
                      SarCrossRangeMeasurement(self.targets[u, k], self.sigma[:, k, 1], fl.layout,
                                               model=prm.cross_model, **(dict(u_c=iv.p[:, -1] - iv.p[:, 0],
                                                                              r_orig=iv.p[:, 0])
                                                                         if prm.cross_model == "paper" else {}))]
                z += [m.simulate(truth_toc, noise=noise[:, 2 * k + i:2 * k + i + 1]) for i, m in enumerate(ms)]
                eta[:, k] = eta_true
            return np.concatenate(z, axis=1), eta
        speed_sigma = directional_sigma(fl.P, fl.layout.slice("v"), fl.nav.v)
        am = self.imager.measure(u, iv.t, iv.p, iv.v, speed_sigma, map_targets=self.map[:, u],
                                 along_sigma=self._along_sigma(u, iv), ap_q=iv.q)
        self._take(am)
        n_add = (prm.sar_sigma[None, None, :] * noise.reshape(R, self.T, 2)) * self.add_white
        z = np.stack([am.range + bm[:, 1:2] + n_add[..., 0], bm[:, 2:3] + n_add[..., 1]], axis=2)  # cross: 0 at zero Doppler
        self._record(u, am, true_toc, record)
        centre = 0.5 * (iv.t[0] + iv.t[-1])
        return z.reshape(R, 2 * self.T), np.where(self.status == 0, am.toc, centre)

    def _along_sigma(self, u: int, iv: Interval) -> np.ndarray:
        """(R,) the filter's 1-sigma of the first target's zero-Doppler cross-range at the aperture centre: how far
        along track an image focused with the estimate may put it (sizes the BPA search grid)."""
        mid = iv.p.shape[1] // 2
        nav = NavState(p=iv.p[:, mid], v=iv.v[:, mid], q=self.fl.nav.q, ba=self.fl.nav.ba, bg=self.fl.nav.bg,
                       bm=self.fl.nav.bm)
        pred = self.models(u, iv, 0)[1].predict(nav)
        S = update.innovation_covariance(self.fl.P, pred.replace(R=np.zeros_like(pred.R), C=None))
        return np.sqrt(np.maximum(S[:, 0, 0], 0.0))

    def _record(self, u, am, true_toc, record) -> None:
        V = self.prm.trajectory.speed
        for k, (eta_true, r_true, _) in enumerate(true_toc):
            record["registration_error"][:, u, 1 + 2 * k] = am.range[:, k] - r_true
            # along track: what the image's TOC says beyond the truth, in the metres of the cross-range measurement
            # (the along-track offset of the target at the TOC, which moves at the rate along_rate: V on a straight
            # track), less the modelled shift of focusing with a speed that is not the true one (sensitivity x
            # (V_focus - V), §2): the registration error proper
            shift = (np.nan_to_num(am.sensitivity[:, k]) * (am.speed - V) + np.nan_to_num(am.focus_offset[:, k])
                     if self.prm.focus == "estimate" else 0.0)
            rate = along_rate(self.prm.trajectory, self.targets[u, k], eta_true)
            record["registration_error"][:, u, 2 + 2 * k] = rate * (am.toc[:, k] - eta_true) - shift
            record["registration_sigma"][:, u, 1 + 2 * k:3 + 2 * k] = am.sigma[:, k]
        record["autofocus_dk"][:, u] = am.autofocus_dk
        record["stage_seconds"][:, u, :len(IMAGE_STAGES)] += am.seconds
        if am.capture is not None:
            record["capture"] = am.capture

    def _take(self, am) -> None:
        """Per run and target: the noise the filter assumes (the image's own prediction, or the configured override,
        plus the added white noise where asked), the focus sensitivity, which pairs have a measurement."""
        prm = self.prm
        self.status = am.status.copy()
        ok = self.status == 0
        sigma = am.sigma if prm.registration_sigma is None else np.broadcast_to(prm.registration_sigma, am.sigma.shape)
        sigma = np.where(ok[..., None] & np.isfinite(sigma) & (sigma > 0), sigma, 1.0)
        if prm.image_added_noise:
            sigma = np.hypot(prm.sar_sigma, sigma)
        self.sigma = sigma
        if prm.focus == "estimate":
            self.sensitivity = np.where(ok, np.nan_to_num(am.sensitivity), 0.0)
            self.focus_offset = np.where(ok, np.nan_to_num(am.focus_offset), 0.0)


def _imager(prm: RdaNavParams, fl: ErrorStateFlight, capture_aperture=None):
    if not (prm.sar_enabled and prm.measurement == "image"):
        return None
    seeds = fl.extra  # the per-run clutter seeds (also keying the in-flight receiver noise)
    targets = world.reference_targets(prm)
    return SubApertureImager(
        radar=prm.radar, truth=prm.trajectory, targets=targets, scene_for=world.scene_factory(prm, targets),
        reflector_amplitude=prm.scene["reflector_amplitude"], snr_db=prm.snr_db, reference_seed=prm.scene["seed"],
        noise_seeds=seeds, clutter_seeds=seeds if prm.scene["clutter_per_run"] else None,
        reference_truth=world.reference_track(prm), settings=prm.imaging, capture_aperture=capture_aperture)


def simulate_runs(prm: RdaNavParams, run_ids, seeds) -> list[RunRecord]:
    """The batched Monte Carlo of :class:`RdaNavKind` (module docstring)."""
    return _simulate(prm, run_ids, seeds)[0]


def capture_images(prm: RdaNavParams, seed, aperture: int) -> dict:
    """The images of sub-aperture ``aperture`` of the run with ``seed`` (reference, in flight before and after
    mapdrift, correlation surface; ``measurements.sar_image.SubApertureImager``), for figures. The run's numbers
    are the same as without the capture."""
    return _simulate(prm, [0], [seed], capture_aperture=aperture)[1].get("capture")


def _new_record(R: int, n_upd: int, M: int) -> dict:
    nan = lambda *s: np.full(s, np.nan)  # noqa: E731
    return {"residual": nan(R, n_upd, M), "residual_sigma": nan(R, n_upd, M), "nis": np.empty((R, n_upd)),
            "nis_dof": np.zeros((R, n_upd), dtype=np.int64), "toc": nan(R, n_upd),
            "update_rejected": np.zeros((R, n_upd), dtype=np.int64), "pairs_fused": np.zeros((R, n_upd), dtype=np.int64),
            "registration_error": nan(R, n_upd, M), "registration_sigma": nan(R, n_upd, M),
            "autofocus_dk": nan(R, n_upd), "stage_seconds": np.zeros((R, n_upd, len(STAGES)))}


def _simulate(prm: RdaNavParams, run_ids, seeds, capture_aperture=None):
    L = STATE_LAYOUT
    spec = FlightSpec(prm.trajectory, prm.imu, prm.imu_rate, prm.bias_sigma, prm.bias_tau, prm.p0_sigma,
                      prm.n_updates, prm.samples_per_update, prm.samples_per_step, imu_filter=prm.imu_filter,
                      earth_rate=prm.earth_rate, filter_earth_rate=prm.filter_earth_rate)
    # the clutter seed is drawn after the bias drive, before IMU sample 0; F at the step's start attitude
    fl = ErrorStateFlight(spec, L, seeds, extra_draws=lambda rngs: [int(g.integers(2**63)) for g in rngs],
                          covariance_attitude="start")
    R, n_upd, T = fl.R, prm.n_updates, prm.targets_per_image
    alt = AltimeterMeasurement(prm.alt_sigma, L)
    sar = _Sar(prm, fl, _imager(prm, fl, capture_aperture)) if prm.sar_enabled else None
    rec = _new_record(R, n_upd, 1 + 2 * T)
    for u in range(n_upd):
        iv = fl.fly_interval(u)
        z_alt = alt.simulate(fl.truth, fl.rngs)
        pred = alt.predict(fl.nav).replace(hessians=None, C=np.zeros((R, L.n, 1)))
        z, status = z_alt, None
        if sar is not None:
            noise = np.stack([g.standard_normal(2 * T) for g in fl.rngs])  # (R, 2T), drawn in every mode
            z_sar, eta = sar.measure(u, iv, noise, rec)
            rec["toc"][:, u] = eta[:, 0]
            t0 = _time.perf_counter()
            pred = stack_predictions([pred.replace(C=None), sar.predict(u, iv, eta)])
            if pred.C is None:
                pred = pred.replace(C=np.zeros((R, L.n, pred.dim)))
            z = np.concatenate([z_alt, z_sar], axis=1)
            rec["stage_seconds"][:, u, -1] += (_time.perf_counter() - t0) / R
            status = _screen(prm, fl.navigator, pred, z, sar.status)
            first = np.where(status != 0, status, 0)
            rec["update_rejected"][:, u] = np.array([next((c for c in row if c), 0) for row in first])
            rec["pairs_fused"][:, u] = np.sum(status == 0, axis=1)
        _fuse(fl, pred, z, status, rec, u)
    return _records(prm, fl, run_ids, rec, image=sar is not None and sar.imager is not None), rec


def _screen(prm: RdaNavParams, navigator, pred: Prediction, z, status) -> np.ndarray:
    """(R, T) rejection code of each run's SAR pairs: the image's own (``measurements.sar_image.FAILURES``), else the
    chi-square innovation gate of the pair (``sar.gate_probability``), else 0 (fused)."""
    code = np.asarray(status, dtype=np.int64).copy()
    if prm.gate_probability > 0:
        T = code.shape[1]
        ok = np.repeat(code == 0, 2, axis=1)
        zz = np.where(np.concatenate([np.ones((z.shape[0], 1), bool), ok], axis=1), z, pred.z_hat)
        accepted = navigator.gate(pred, zz, [[1 + 2 * k, 2 + 2 * k] for k in range(T)], prm.gate_probability)
        code[(code == 0) & ~accepted] = REJECTIONS.index("innovation gate")
    return code


def _fuse(fl: ErrorStateFlight, pred: Prediction, z, status, rec: dict, u: int) -> None:
    """The navigator's update with the rejected SAR pairs left out (``keep``), and the record."""
    keep = np.ones(pred.z_hat.shape, dtype=bool)
    if status is not None:
        keep[:, 1:] = np.repeat(status == 0, 2, axis=1)
    fused = fl.navigator.update(pred, z, keep)
    fl.record_update()
    cols = slice(0, pred.dim)
    rec["residual"][:, u, cols] = fused.residual
    rec["residual_sigma"][:, u, cols] = fused.residual_sigma
    rec["nis"][:, u], rec["nis_dof"][:, u] = fused.nis, fused.dof


def _records(prm, fl, run_ids, rec, image: bool) -> list[RunRecord]:
    t_out = fl.t_out
    t_upd = t_out[fl.steps::fl.steps]
    records = []
    for i in range(fl.R):
        extras = {"toc": (("update",), rec["toc"][i])}
        if prm.sar_enabled:
            extras["update_rejected"] = (("update",), rec["update_rejected"][i])
            extras["pairs_fused"] = (("update",), rec["pairs_fused"][i])
        if image:
            extras["registration_error"] = (("update", "meas"), rec["registration_error"][i])
            extras["registration_sigma"] = (("update", "meas"), rec["registration_sigma"][i])
            extras["autofocus_dk"] = (("update",), rec["autofocus_dk"][i])
            extras["stage_seconds"] = (("update", "stage"), rec["stage_seconds"][i])
        records.append(RunRecord(
            run=int(run_ids[i]), time=t_out.copy(), error=fl.err[i], sigma=fl.sig[i], nees=fl.nees[i],
            update_time=t_upd.copy(), residual=rec["residual"][i], residual_sigma=rec["residual_sigma"][i],
            nis=rec["nis"][i], nis_dof=rec["nis_dof"][i], extras=extras))
    return records


def covariance_study(prm: RdaNavParams, range_sigma: float, cross_sigma: float, ground_ranges=None,
                     cross_model: str | None = None) -> dict:
    """The truth-linearised covariance study of this scenario's filter (``analysis.covariance.sar_covariance_study``)
    for a given SAR noise: its IMU model, altimeter, biases, P0, trajectory and (first) reference targets;
    ``cross_model`` defaults to ``sar.cross_range_model``; ``ground_ranges``: several targets per aperture."""
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
    measurement_names = tuple(meas_names(1))
    measurement_units = ("m", "m", "m")

    def meas_names(self, cfg: dict) -> list[str]:
        return meas_names(_targets(cfg))

    def meas_units(self, cfg: dict) -> list[str]:
        return ["m"] * (1 + 2 * _targets(cfg))

    def parse(self, cfg: dict):
        return parse(cfg)

    def simulate_runs(self, prm, run_ids, seeds) -> list[RunRecord]:
        return simulate_runs(prm, run_ids, seeds)

    def extra_attrs(self, cfg: dict) -> dict[str, dict]:
        return extra_attrs()

    def extra_coords(self, cfg: dict) -> dict:
        return {"stage": (list(STAGES), {"units": "", "description": "stages of the imaging chain and the update, "
                                         "timed per image (echoes: simulation, both noisy acquisitions, range "
                                         "compression, reference chip; rda: image formation, RDA or BPA)"})}

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
            if cap is not None:
                paths.append(plot_aperture_images(cap, outdir / "sar_images_run0.png"))
        if prm.sar_enabled:
            off = copy.deepcopy(cfg)
            off["sar"]["enabled"] = False
            rec = simulate_runs(parse(off), [0], [seed0])[0]
            pos = [list(results["state"].values).index(s) for s in ("pN", "pE", "pD")]
            paths.append(plot_sar_ablation(results["time"].values, results["sigma"].values[0][:, pos],
                                           rec.time, rec.sigma[:, :3], outdir / "position_3sigma_with_without_sar.png"))
        return paths


def _targets(cfg: dict) -> int:
    t = cfg.get("scene", {}).get("targets_per_image", 1) if isinstance(cfg.get("scene"), dict) else 1
    return t if isinstance(t, int) and not isinstance(t, bool) and 1 <= t <= 8 else 1
