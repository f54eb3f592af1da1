"""The ``multi-imu-sar`` kind (scenario ``multi-imu-sar-fix``): GPS-denied multi-IMU fusion, the absolute fix that aids
each IMU's particle filter and weights the SIR fusion made from SAR images (range and cross-range to a geolocated
reference every second, as in rda-nav) instead of GPS; beyond Sun (2022) (gap G29). Configuration and wiring of
``sarnav.simulation.multi_imu_sar`` (``SarFixSetup`` -> ``run_sar_fix_records``); docs/particles.md.

``fix.source``: ``"sar"`` (image-derived), ``"oracle"`` (the same pair from the truth plus N(0,
sar.registration_sigma_m^2): the only mode in which truth enters the SAR measurement) or ``"gps"`` (20 Hz GPS fixes).
"""

from __future__ import annotations

import math

from sarnav.analysis.consistency import registration_statistics
from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import validate_campaign
from sarnav.scenarios.fields import boolean as _bool
from sarnav.scenarios.fields import bounded_vector, choice, integer, number
from sarnav.montecarlo.record import RunRecord
from sarnav.scenarios.multi_imu import MAX_PARTICLES, MIN_PARTICLES, MultiImuKind, SourceKind, settle_time
from sarnav.scenarios.vocabulary import make_radar, radar_fields
from sarnav.simulation.imu_rig import ADIS_LEVER_ARMS
from sarnav.simulation.multi_imu_sar import FIX_SOURCES, SAR_FIX_ATTRS, SAR_UPDATES, SarFixSetup, run_sar_fix_records

__all__ = ["MultiImuSarKind"]

#: slant-range half-window the imager searches around the predicted range (measurements.sar_image) [m]
SEARCH_HALF_RANGE = 12.0


def _scene(cfg, altitude, radar):
    seed = integer(cfg, "scene", "seed", 0, 2**63 - 1)
    gmin = number(cfg, "scene", "ground_range_min", 1.0, 1e5, "m")
    gmax = number(cfg, "scene", "ground_range_max", 1.0, 1e5, "m")
    if not gmax > gmin:
        raise ConfigError("scene.ground_range_max", f"must be > scene.ground_range_min = {gmin} m, got {gmax}")
    lo, hi = radar.target_range_limits
    if math.hypot(gmin, altitude) - SEARCH_HALF_RANGE < lo:
        raise ConfigError("scene.ground_range_min", f"slant range {math.hypot(gmin, altitude):.1f} m - "
                          f"{SEARCH_HALF_RANGE} m leaves the receive window (targets from {lo:.1f} m)")
    if math.hypot(gmax, altitude) + SEARCH_HALF_RANGE > hi:
        raise ConfigError("scene.ground_range_max", f"slant range {math.hypot(gmax, altitude):.1f} m + "
                          f"{SEARCH_HALF_RANGE} m leaves the receive window (targets up to {hi:.1f} m)")
    return dict(scene_seed=seed, ground_range=(gmin, gmax),
                toc_jitter=number(cfg, "scene", "toc_jitter_s", 0.0, 0.4, "s"),
                clutter=integer(cfg, "scene", "clutter_per_image", 0, 1000),
                clutter_per_run=_bool(cfg, "scene", "clutter_per_run"),
                reflector_amplitude=number(cfg, "scene", "reflector_amplitude", 1e-3, 1e6))


def parse(cfg: dict) -> tuple[SarFixSetup, float]:
    """(setup, settling time [s]); ConfigError names the first bad field and its range."""
    validate_campaign(cfg)
    duration = number(cfg, "flight", "duration", 2.0, 600.0, "s")
    if abs(duration - round(duration)) > 1e-9:
        raise ConfigError("flight.duration", f"must be a whole number of 1-s sub-apertures, got {duration}")
    altitude = number(cfg, "flight", "altitude", 100.0, 20_000.0, "m")
    speed = number(cfg, "flight", "speed", 1.0, 100.0, "m/s")
    preset, fields = radar_fields(cfg)
    if preset != "nav-paper-sim":
        raise ConfigError("radar.preset", f"must be 'nav-paper-sim' (rda-nav's radar and window), got {preset!r}")
    radar = make_radar(preset, fields)
    try:
        radar.check_doppler(speed)
    except ConfigError as err:
        raise ConfigError("flight.speed", f"too fast for the radar: radar.prf_hz {err.message}") from None
    settle = settle_time(cfg, 600.0, duration, 1.0, "flight.duration")
    reg = bounded_vector(cfg, "sar", "registration_sigma_m", 1e-5, 100.0, n=2, unit="m")
    p3 = bounded_vector(cfg, "initial", "p_3sigma", 1e-3, 1e4, unit="m")
    v3 = bounded_vector(cfg, "initial", "v_3sigma", 1e-4, 100.0, unit="m/s")
    setup = SarFixSetup(
        duration=duration, speed=speed, altitude=altitude, radar=radar,
        snr_db=number(cfg, "radar", "snr_db", -60.0, 100.0, "dB"),
        **_scene(cfg, altitude, radar), sar_sigma=reg,
        alt_sigma=number(cfg, "sar", "altimeter_sigma_m", 1e-3, 100.0, "m"),
        fix_source=choice(cfg, "fix", "source", FIX_SOURCES),
        gps_sigma=bounded_vector(cfg, "fix", "gps_sigma_m", 1e-3, 100.0, unit="m"),
        gps_rate=number(cfg, "fix", "gps_rate_hz", 1.0, 100.0, "Hz"),
        n_adis=integer(cfg, "imu", "n_adis", 1, len(ADIS_LEVER_ARMS)),
        n_particles=integer(cfg, "filter", "n_particles", MIN_PARTICLES, MAX_PARTICLES),
        psd_scale=number(cfg, "filter", "accel_psd_scale", 1e-6, 1e6),
        n_draws=integer(cfg, "fusion", "n_draws", 1, 10_000), per_axis=_bool(cfg, "fusion", "per_axis"),
        p0_sigma=tuple(x / 3.0 for x in p3 + v3), update=choice(cfg, "filter", "sar_update", SAR_UPDATES))
    return setup, settle


class MultiImuSarKind(SourceKind):
    """GPS-denied multi-IMU fusion with SAR fixes (module docstring)."""

    kind, scenario = "multi-imu-sar", "multi-imu-sar-fix"

    def parse(self, cfg: dict):
        return parse(cfg)

    def filters(self, prm) -> list[str]:
        return prm[0].sensor_names

    def sources(self, prm) -> list[str]:
        return prm[0].sensor_names + ["mean", "sir"]

    def extra_attrs(self, cfg: dict) -> dict:
        return dict(SAR_FIX_ATTRS)

    def extra_coords(self, cfg: dict) -> dict:
        out = super().extra_coords(cfg)
        setup, _ = self.parse(cfg)
        out["aperture"] = (list(range(setup.n_apertures)), {"units": "", "description": "1-s sub-aperture index"})
        out["sar_axis"] = (["range", "along_track"], {"units": "", "description": "registration error components"})
        return out

    def run_batch(self, prm, seeds, run_ids) -> list[RunRecord]:
        setup, settle = prm
        return run_sar_fix_records(setup, seeds, run_ids, settle)

    gain_pairs = MultiImuKind.gain_pairs  # the multi-imu-adis comparison (T21-T23) on SAR fixes

    def summary_extras(self, results) -> dict:
        out = super().summary_extras(results)
        reg = results["sar_registration_error"].values
        if reg.size and (reg == reg).any():  # image-derived fixes: the numbers that justify R
            out["registration"] = registration_statistics(reg, ["range", "along_track"], ["m", "m"])
        return out
