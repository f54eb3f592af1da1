"""The ``rda-nav`` scenario kind: INS + altimeter + SAR range/cross-range from 1-s RDA sub-apertures.

Lindstrom et al., NAVIGATION 69(3) (extraction seed-001) and thesis ch. 5; design and gap decisions in
docs/scenarios/rda-nav.md. Scenarios ``rda-nav`` (paper sim, Tables 1-3), ``rda-nav-flexsar`` (simulated
FlexSAR-like flight, Tables 4-6) and ``rda-nav-terrain``. Configuration and wiring only: the defaults, ``parse``
(TOML -> :class:`~sarnav.simulation.rda_nav.RdaNavParams`, every bad key named) and the kind; the experiment is
``sarnav.simulation.rda_nav`` (the world, the navigator of ``sarnav.navigation``, the records).
"""

from __future__ import annotations

import numpy as np

from sarnav import units
from sarnav.analysis.covariance import rda_nav_covariance_study as covariance_study
from sarnav.errors import ConfigError, require_finite
from sarnav.measurements.sar import CROSS_RANGE_MODELS
from sarnav.measurements.sar_image import ALGORITHMS, FOCUS, ImagingSettings
from sarnav.montecarlo.kind import validate_campaign
from sarnav.radar.params import RadarParams
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import get as _get
from sarnav.scenarios.fields import positive as _pos
from sarnav.scenarios.fields import table as _table
from sarnav.scenarios.fields import vector as _vector
from sarnav.scenarios.vocabulary import (EARTH_DEFAULT, IMU_OVERRIDES, RADAR_KEYS, filter_imu_keys, read_earth,
                                         flight_size_check, make_radar, radar_fields, read_filter_imu, read_imu,
                                         read_initial, read_trajectory, whole_number)
from sarnav.simulation.rda_nav import (COV_STEP, EXTRA_ATTRS, MEAS_NAMES, MEASUREMENT_MODES, REJECTIONS, STAGES,
                                       STATE_LAYOUT, RdaNavParams, run_capture_images, simulate_runs)
from sarnav.simulation.rda_nav_world import SCENE_TYPES
from sarnav.trajectory import StraightLevel

__all__ = ["RdaNavKind", "default_config", "flexsar_config", "terrain_config", "optional_keys", "parse",
           # the experiment's names, kept importable from here (sarnav 0.2)
           "RdaNavParams", "STATE_LAYOUT", "COV_STEP", "STAGES", "REJECTIONS", "MEASUREMENT_MODES", "simulate_runs",
           "covariance_study", "MEAS_NAMES", "EXTRA_ATTRS"]

#: slant-range margin of the receive window beyond the imaged scene [m] (``radar.range_margin_m``)
DEFAULT_RANGE_MARGIN_M = 30.0
#: largest echo block of one sub-aperture (pulses x range samples): refused beyond it before anything is allocated
MAX_ECHO_SAMPLES = 2.0e7
#: [scene] keys of the terrain scene (in every configuration; used with scene.type = "terrain")
TERRAIN_KEYS = ("terrain_relief_m", "terrain_scale_m", "clutter_density_m2", "clutter_power_m2", "bright_features",
                "bright_amplitude", "reference_coherence")


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
    if stype not in SCENE_TYPES:
        raise ConfigError("scene.type", f"must be one of {SCENE_TYPES}, got {stype!r}")
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


def _parse_radar(cfg: dict, trajectory, scene: dict, side: str) -> RadarParams:
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
        window = RdaNavParams.receive_window(trajectory, scene, side, base.pulse_length, base.sample_rate, margin)
    radar = make_radar(preset, fields, **window)
    size = round(radar.prf) * radar.n_range_samples
    if not size <= MAX_ECHO_SAMPLES:
        raise ConfigError("radar.prf_hz", f"a 1-s sub-aperture of {round(radar.prf)} pulses x "
                          f"{radar.n_range_samples} range samples is {size:.3g} samples; at most {MAX_ECHO_SAMPLES:.0e} "
                          "(lower radar.prf_hz or radar.sample_rate_mhz, or narrow the scene's ground-range band)")
    return radar  # the PRF against the Doppler band: scenarios.error_state (only when images are formed)


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
    radar = _parse_radar(cfg, traj, scene, side)
    snr = require_finite("radar.snr_db", _get(cfg, "radar", "snr_db"), -60.0, 100.0, "dB")
    ini = read_initial(cfg, filt)
    p0 = np.concatenate([ini["p"], ini["v"], ini["th"], ini["ba"], ini["bg"], three(bias3)])
    return RdaNavParams(runs=runs, trajectory=traj, altitude=float(-traj.start[2]), imu=imu, imu_filter=filt,
                        imu_rate=imu_rate, alt_sigma=float(alt_sigma), bias_sigma=three(bias3), bias_tau=bias_tau,
                        radar=radar, snr_db=float(snr), scene=scene, p0_sigma=p0, **read_earth(cfg), **sar)


class RdaNavKind(ErrorStateKind):
    """NAVIGATION paper / thesis ch. 5 image-aided INS Monte Carlo (module docstring)."""

    kind = "rda-nav"

    def default_config(self) -> dict:
        return default_config()

    def optional_keys(self) -> list[str]:
        return optional_keys()

    layout = STATE_LAYOUT
    measurement_names = MEAS_NAMES[:3]
    measurement_units = ("m", "m", "m")

    def meas_names(self, cfg: dict) -> list[str]:
        return list(MEAS_NAMES[:1 + 2 * _targets(cfg)])

    def meas_units(self, cfg: dict) -> list[str]:
        return ["m"] * (1 + 2 * _targets(cfg))

    parse = staticmethod(parse)
    simulate_runs = staticmethod(simulate_runs)
    extra = EXTRA_ATTRS

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
            cap = run_capture_images(prm, seed0, min(10, prm.n_updates - 1))
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
