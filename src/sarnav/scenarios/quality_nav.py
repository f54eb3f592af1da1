"""The ``quality-nav`` scenario kind: the INS aided by the best-focus along-track velocity of its own SAR images
(Hathaway 2023; docs/quality.md §7). Configuration and wiring only: the defaults, ``parse`` (TOML ->
:class:`~sarnav.simulation.quality_nav.QualityNavParams`) and the kind; the experiment is
``sarnav.simulation.quality_nav``.
"""

from __future__ import annotations

import math

import numpy as np

from sarnav.errors import ConfigError
from sarnav.imaging.quality import QUALITY_MEASURES
from sarnav.measurements.focus_image import FocusSettings
from sarnav.montecarlo.kind import validate_campaign
from sarnav.radar.params import RadarParams
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.scenarios.fields import boolean, choice, integer, number
from sarnav.scenarios.registry import packaged
from sarnav.scenarios.vocabulary import (IMU_OVERRIDES, RADAR_KEYS, doppler_prf_check, filter_imu_keys,
                                         read_earth,
                                         flight_size_check, make_radar, radar_fields, read_filter_imu, read_imu,
                                         read_initial, read_trajectory, whole_number)
from sarnav.simulation.quality_nav import (COV_STEP, EXTRA_ATTRS, LAYOUT, MEAS_NAMES, MEAS_UNITS, QualityNavParams,
                                          simulate_runs)
from sarnav.tomlio import dump_toml
from sarnav.trajectory import StraightLevel

__all__ = ["QualityNavKind", "default_config", "parse", "simulate_runs", "QualityNavParams"]

MODES = ("image", "oracle")
#: echo work per fix (scatterers x pulses) and image work per fix (pixels x pulses)
MAX_ECHO_WORK = 2e7
MAX_IMAGE_WORK = 2e8


def default_config() -> dict:
    """The thesis' geometry (60 m/s, 1000 m, scene 1760 m east, PRF 1667 Hz) with the NAVIGATION paper's tactical IMU:
    ``defaults/quality-nav.toml``."""
    return packaged("quality-nav")


def optional_keys() -> list[str]:
    """IMU 3-sigma overrides, [filter.imu] and radar fields over the preset."""
    return [f"imu.{k}" for k in IMU_OVERRIDES] + filter_imu_keys() + [f"radar.{k}" for k in RADAR_KEYS]


def _settings(cfg: dict, prf: float, interval: float) -> FocusSettings:
    sc = lambda key, lo, hi, unit="": number(cfg, "scene", key, lo, hi, unit)  # noqa: E731
    st = FocusSettings(
        aperture_pulses=integer(cfg, "aperture", "n_pulses", 16, 100_000),
        ground_range=sc("ground_range", 10.0, 1e5, "m"), width=sc("width", 0.5, 1000.0, "m"),
        length=sc("length", 0.5, 1000.0, "m"), point_density=sc("point_density", 0.0, 100.0, "1/m^2"),
        point_to_clutter_db=sc("point_to_clutter_db", -40.0, 80.0, "dB"),
        clutter_density=sc("clutter_density", 0.0, 100.0, "1/m^2"),
        snr_db=number(cfg, "radar", "snr_db", -60.0, 100.0, "dB"),
        pixels=integer(cfg, "focus", "pixels", 8, 512), pixel_m=number(cfg, "focus", "pixel_m", 0.01, 10.0, "m"),
        span=number(cfg, "focus", "span", 0.01, 10.0, "m/s"), n_grid=integer(cfg, "focus", "n_grid", 3, 51),
        measure=choice(cfg, "focus", "measure", sorted(QUALITY_MEASURES)), mapdrift=boolean(cfg, "focus", "mapdrift"))
    if st.n_grid % 2 == 0:
        raise ConfigError("focus.n_grid", f"must be odd, got {st.n_grid}")
    if (st.aperture_pulses - 1) / prf > interval + 1e-9:
        raise ConfigError("aperture.n_pulses", f"{st.aperture_pulses} pulses at {prf:g} Hz last longer than "
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
    margin = number(cfg, "radar", "range_margin_m", 0.0, 1000.0, "m")
    h = -float(traj.start[2])
    track = 0.5 * traj.speed * (st_pulses - 1) / base.prf
    window = base.receive_window((math.sqrt(h * h + max(ground_range - half, 0.0) ** 2),
                                  math.sqrt(h * h + (ground_range + half) ** 2 + (track + half) ** 2)), margin)
    n = window["n_range_samples"]
    if n * st_pulses > 2**24:
        raise ConfigError("aperture.n_pulses", f"{st_pulses} pulses x {n} range samples; at most {2**24}")
    radar = make_radar(preset, fields, near_range=max(window["near_range"], 1.0), n_range_samples=n)
    doppler_prf_check(radar, traj.speed)
    return radar


def _calibration_key(cfg: dict) -> str:
    keep = {k: cfg[k] for k in ("trajectory", "initial", "radar", "scene", "aperture", "focus", "filter") if k in cfg}
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
    interval = number(cfg, "focus", "interval_s", COV_STEP, 60.0, "s")
    whole_number("focus.interval_s", interval, COV_STEP, f"{COV_STEP:g}-s covariance steps")
    whole_number("trajectory.duration", traj.duration, interval, "focus.interval_s update intervals")
    mode = choice(cfg, "focus", "measurement", MODES)
    preset, fields = radar_fields(cfg)
    if preset is None:
        raise ConfigError("radar.preset", "is required for quality-nav (e.g. 'flexsar')")
    st = _settings(cfg, make_radar(preset, fields).prf, interval)
    if number(cfg, "focus", "span_max", 0.01, 10.0, "m/s") < st.span:
        raise ConfigError("focus.span_max", f"must be >= focus.span = {st.span} m/s")
    radar = _radar(cfg, traj, st.aperture_pulses, st.ground_range, 0.5 * max(st.width, st.length))
    p0 = np.concatenate([ini["p"], ini["v"], ini["th"], ini["ba"], ini["bg"]])
    return QualityNavParams(
        runs=runs, trajectory=traj, imu=imu, imu_filter=filt, imu_rate=imu_rate, radar=radar, settings=st,
        p0_sigma=p0, interval=interval, enabled=boolean(cfg, "focus", "enabled"), measurement=mode,
        delayed_state=boolean(cfg, "focus", "delayed_state"),
        oracle_sigma=number(cfg, "focus", "oracle_sigma", 1e-6, 100.0, "m/s"), span_sigmas=number(cfg, "focus", "span_sigmas", 0.0, 20.0),
        span_max=number(cfg, "focus", "span_max", 0.01, 10.0, "m/s"),
        gate_sigmas=number(cfg, "focus", "gate_sigmas", 1.0, 1e6),
        calibration_apertures=integer(cfg, "focus", "calibration_apertures", 2, 1000),
        calibration_seed=integer(cfg, "focus", "calibration_seed", 0, 2**63 - 1),
        calibration_key=_calibration_key(cfg), **read_earth(cfg))


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

    parse = staticmethod(parse)
    simulate_runs = staticmethod(simulate_runs)
    extra = EXTRA_ATTRS

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
