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
from sarnav.errors import ConfigError
from sarnav.measurements.sar import CROSS_RANGE_MODELS
from sarnav.measurements.sar_image import ALGORITHMS, FOCUS, ImagingSettings
from sarnav.montecarlo.kind import validate_campaign
from sarnav.radar.params import RadarParams
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import bounded_vector, choice, integer, number
from sarnav.scenarios.fields import positive as _pos
from sarnav.scenarios.fields import table as _table
from sarnav.scenarios.fields import vector as _vector
from sarnav.scenarios.registry import packaged
from sarnav.scenarios.vocabulary import (IMU_OVERRIDES, RADAR_KEYS, filter_imu_keys, read_earth,
                                         flight_size_check, make_radar, radar_fields, read_filter_imu, read_imu,
                                         read_initial, read_trajectory, whole_number)
from sarnav.simulation.rda_nav import (COV_STEP, EXTRA_ATTRS, MEAS_NAMES, MEASUREMENT_MODES, REJECTIONS, STAGES,
                                       STATE_LAYOUT, RdaNavParams, run_capture_images, simulate_runs)
from sarnav.simulation.rda_nav_world import SCENE_TYPES
from sarnav.trajectory import StraightLevel

__all__ = ["RdaNavKind", "default_config", "optional_keys", "parse",
           # the experiment's names, kept importable from here (sarnav 0.2)
           "RdaNavParams", "STATE_LAYOUT", "COV_STEP", "STAGES", "REJECTIONS", "MEASUREMENT_MODES", "simulate_runs",
           "covariance_study", "MEAS_NAMES", "EXTRA_ATTRS"]

#: largest echo block of one sub-aperture (pulses x range samples): refused beyond it before anything is allocated
MAX_ECHO_SAMPLES = 2.0e7


# --- configuration ------------------------------------------------------------------------------

def default_config() -> dict:
    """Paper simulation (Tables 1-3, 200 runs, L1357): ``defaults/rda-nav.toml`` (gap fills commented there, see
    docs/scenarios/rda-nav.md); ``rda-nav-flexsar`` (paper Tables 4-6) and ``rda-nav-terrain`` (docs §4) beside it."""
    return packaged("rda-nav")


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
    return dict(gate_probability=number(cfg, "sar", "gate_probability", 0.0, 0.5),
                imaging=ImagingSettings(algorithm=choice(cfg, "sar", "algorithm", ALGORITHMS),
                                        focus=choice(cfg, "sar", "focus", FOCUS), autofocus=_bool(cfg, "sar", "autofocus"),
                                        min_correlation=number(cfg, "sar", "min_correlation", 0.0, 1.0),
                                        max_ambiguity=number(cfg, "sar", "max_ambiguity", 0.0, 1.0)))


def _parse_scene(cfg: dict) -> dict:
    gmin = _pos(cfg, "scene", "ground_range_min", "m", hi=1.0e6)
    gmax = _pos(cfg, "scene", "ground_range_max", "m", hi=1.0e6)
    if not gmax > gmin:
        raise ConfigError("scene.ground_range_max", f"must be > scene.ground_range_min = {gmin} m, got {gmax}")
    scale = _vector(cfg, "scene", "terrain_scale_m", n=2, positive=True, unit="m")
    geo = np.array(bounded_vector(cfg, "scene", "geolocation_sigma_m", 0.0, 100.0, unit="m"))
    offset = bounded_vector(cfg, "scene", "reference_offset_m", -1.0e4, 1.0e4, n=2, unit="m")
    return {"type": choice(cfg, "scene", "type", SCENE_TYPES), "seed": integer(cfg, "scene", "seed", 0, 2**63 - 1),
            "ground_range": (gmin, gmax), "toc_jitter": number(cfg, "scene", "toc_jitter_s", 0.0, 0.4, "s"),
            "targets_per_image": integer(cfg, "scene", "targets_per_image", 1, 8),
            "clutter": integer(cfg, "scene", "clutter_per_image", 0, 1000),
            "reflector_amplitude": _pos(cfg, "scene", "reflector_amplitude", hi=1.0e6),
            "clutter_per_run": _bool(cfg, "scene", "clutter_per_run"),
            "reference_offset": offset, "geolocation_sigma": geo,
            "terrain_relief": number(cfg, "scene", "terrain_relief_m", 0.0, 1000.0, "m"),
            "terrain_scale": (float(scale[0]), float(scale[1])),
            "clutter_density": _pos(cfg, "scene", "clutter_density_m2", "1/m^2", hi=1.0e3),
            "clutter_power": number(cfg, "scene", "clutter_power_m2", 0.0, 1.0e6),
            "bright_features": integer(cfg, "scene", "bright_features", 0, 100),
            "bright_amplitude": _pos(cfg, "scene", "bright_amplitude", hi=1.0e6),
            "reference_coherence": number(cfg, "scene", "reference_coherence", 0.0, 1.0)}


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
        window = {"near_range": _pos(cfg, "radar", "near_range_m", "m", hi=1.0e7),
                  "n_range_samples": integer(cfg, "radar", "n_range_samples", 2, 10**6)}
    else:
        margin = number(cfg, "radar", "range_margin_m", 0.0, 1.0e4, "m")
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
    snr = number(cfg, "radar", "snr_db", -60.0, 100.0, "dB")
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
