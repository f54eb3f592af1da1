"""One configuration vocabulary: the tables every kind shares, read in one place.

``[trajectory]``, ``[imu]``, ``[filter.imu]`` (the filter's model of the IMU, each key defaulting to ``[imu]``'s),
``[earth]``, ``[initial]``, ``[radar]`` (a preset and/or fields with their units in the key) and ``[aperture]``: every
key, its unit and range, in docs/scenarios/vocabulary.md. Values are validated where they are used (``RadarParams``
validates the radar, ``StraightLevel`` the track); a :class:`~sarnav.errors.ConfigError` always names the user's key.
Every key, shared or a kind's own, is read through the typed readers of :mod:`sarnav.scenarios.fields`.
"""

from __future__ import annotations


import numpy as np

from sarnav import units
from sarnav.errors import ConfigError, require_finite
from sarnav.montecarlo.budgets import (BYTES_PER_BLOCK_SAMPLE, MAX_BLOCK_SAMPLES, MAX_IMU_SAMPLES,  # noqa: F401
                                       echo_block_check, flight_size_check, result_bytes_check, whole_number)
from sarnav.radar.params import RadarParams
from sarnav.radar.presets import PRESETS
from sarnav.scenarios.fields import boolean, bounded_positive, get, known_keys, positive, table, vector
from sarnav.sensors.imu import GRADE_THREE_SIGMA, ImuGrade
from sarnav.simulation.flight import FlightSpec, ImuSpec
from sarnav.trajectory import Maneuvering, StraightLevel

__all__ = ["IMU_OVERRIDES", "TRAJECTORY_TYPES", "read_trajectory", "read_imu", "read_filter_imu", "read_initial",
           "RADAR_KEYS", "radar_fields", "make_radar", "filter_imu_keys", "flight_size_check", "MAX_IMU_SAMPLES",
           "INITIAL_RANGES", "echo_block_check", "MAX_BLOCK_SAMPLES", "EARTH_DEFAULT", "read_earth", "read_altitude"]

#: optional 3-sigma overrides of an IMU grade, in source units (``sensors.imu.ImuGrade.from_three_sigma``)
IMU_OVERRIDES = ("vrw_3sigma", "accel_bias_3sigma", "arw_3sigma", "gyro_bias_3sigma")
TRAJECTORY_TYPES = ("straight", "maneuver", "turning")
#: turn rate of the level S-turn ``turning`` [deg/s]: at 10 m/s its radius (2.3 km) exceeds the rda-nav stand-off
#: (1.8 km); a standard-rate 3 deg/s turn (radius 191 m) would put a side-looking radar's targets beyond the turn's
#: centre, where their range is a maximum, not a minimum
DEFAULT_TURN_RATE_DEG_S = 0.25
#: an aircraft's speed [m/s] and an IMU's sample rate [Hz]: validation limits
MAX_SPEED = 1.0e4
MAX_IMU_RATE = 1.0e4
#: the attitude error is a small angle (thesis eq. 4.9): larger initial 3-sigma values are refused [rad]
MAX_THETA_3SIGMA = 0.5
#: physical ranges of the ``[initial]`` 3-sigma values (SI): key -> (lo, hi, unit). Up to 100 km of position and
#: 1 km/s of velocity error (an aircraft's speed is at most ``MAX_SPEED``); below the lower bounds, or with a velocity
#: 3-sigma of 1e7 m/s, the initial covariance spans more orders of magnitude than float64 keeps positive definite
#: (telemetry then wrote NaN sigma). Every corner of these ranges gives finite sigma (tests/scenarios/test_vocabulary.py).
INITIAL_RANGES = {"p_3sigma": (1e-6, 1e5, "m"), "v_3sigma": (1e-6, 1e3, "m/s"),
                  "theta_3sigma": (1e-9, MAX_THETA_3SIGMA, "rad")}


def positive_up_to(field: str, value, hi: float, unit: str) -> float:
    """``value`` as a float in (0, hi], else ConfigError naming ``field`` and that range (``must be in (0, 10000] Hz``)."""
    rng = f"(0, {hi:g}] {unit}"
    try:
        v = require_finite(field, value)
    except ConfigError:
        raise ConfigError(field, f"must be a finite number in {rng}, got {value!r}") from None
    if not 0 < v <= hi:
        raise ConfigError(field, f"must be in {rng}, got {v!r}")
    return v


# ----------------------------------------------------------------------------- trajectory
def read_trajectory(cfg: dict, types=("straight",), max_duration: float | None = None):
    """The truth trajectory of ``[trajectory]``: ``StraightLevel`` or ``Maneuvering`` (``type``, when offered).

    ``types``: the trajectory types the kind accepts; with a single type the ``type`` key may be absent.
    """
    tr = table(cfg, "trajectory")
    ttype = tr.get("type", types[0] if len(types) == 1 else None)
    if ttype not in types:
        raise ConfigError("trajectory.type", f"must be one of {list(types)}, got {ttype!r}")
    start = vector(cfg, "trajectory", "start_ned", unit="m")
    speed = positive_up_to("trajectory.speed", get(cfg, "trajectory", "speed"), MAX_SPEED, "m/s")
    heading = float(units.deg_to_rad(require_finite("trajectory.heading_deg", get(cfg, "trajectory", "heading_deg"),
                                                    lo=-360.0, hi=360.0, unit="deg")))
    if max_duration is None:
        duration = positive(cfg, "trajectory", "duration", "s")
    else:
        duration = require_finite("trajectory.duration", get(cfg, "trajectory", "duration"), 1.0, max_duration, "s")
    if ttype == "maneuver":
        return Maneuvering.s_turn_climb(start, speed, heading, duration)
    if ttype == "turning":
        rate = require_finite("trajectory.turn_rate_deg_s", tr.get("turn_rate_deg_s", DEFAULT_TURN_RATE_DEG_S),
                              lo=0.0, hi=30.0, unit="deg/s")
        return Maneuvering.s_turn(start, speed, heading, duration, rate)
    return StraightLevel(start, speed, heading, duration)


def read_altitude(cfg: dict, lo: float, hi: float, over_origin: bool = False) -> float:
    """The altitude [m] of ``trajectory.start_ned`` (-start_ned[2], NED down) in [lo, hi], for kinds whose track is
    fixed but for its height; ``over_origin``: the track passes over the NED origin (start_ned[0] = start_ned[1] =
    0)."""
    start = vector(cfg, "trajectory", "start_ned", unit="m")
    for i in (0, 1) if over_origin else ():
        if start[i] != 0.0:
            raise ConfigError(f"trajectory.start_ned[{i}]", f"must be 0 m: this kind's track passes over the NED "
                              f"origin (start_ned = [0, 0, -altitude]), got {start[i]}")
    if not start[2] < 0:
        raise ConfigError("trajectory.start_ned[2]", f"must be < 0 m (above the ground, NED down), got {start[2]}")
    altitude = -float(start[2])
    if not lo <= altitude <= hi:
        raise ConfigError("trajectory.start_ned[2]", f"must be in [{-hi:g}, {0.0 - lo:g}] m (an altitude of {lo:g} "
                          f"to {hi:g} m), got {start[2]}")
    return altitude


# ----------------------------------------------------------------------------- Earth
#: the ``[earth]`` table of the kinds on the flight spine: the sources' non-rotating Earth; the latitude (not given by
#: the sources, a mid-latitude value) is used only with ``rotation = true``
EARTH_DEFAULT = {"rotation": False, "latitude_deg": 40.0, "modelled": True}


def read_earth(cfg: dict) -> dict:
    """``[earth]`` as FlightSpec fields: ``earth_rate`` (omega_ie^t (3,) [rad/s] when ``rotation`` is true, else None)
    and ``filter_earth_rate`` (the same when ``modelled``, else None: a flat-Earth filter)."""
    rotation, modelled = boolean(cfg, "earth", "rotation"), boolean(cfg, "earth", "modelled")
    lat = require_finite("earth.latitude_deg", get(cfg, "earth", "latitude_deg"), lo=-90.0, hi=90.0, unit="deg")
    return FlightSpec.earth_fields(units.deg_to_rad(lat), rotation, modelled)


# ----------------------------------------------------------------------------- IMU
def _grade(t: dict, prefix: str, inherit: dict | None = None) -> ImuGrade:
    name = t.get("grade")
    if name == "custom":
        base3 = [None] * 4
    elif name in GRADE_THREE_SIGMA:
        base3 = list(GRADE_THREE_SIGMA[name])
    else:
        raise ConfigError(f"{prefix}.grade", f"must be one of {sorted(GRADE_THREE_SIGMA)} or 'custom', got {name!r}")
    inherit = inherit or {}
    vals3 = [t.get(k, inherit.get(k, b)) for k, b in zip(IMU_OVERRIDES, base3)]
    for k, v in zip(IMU_OVERRIDES, vals3):
        if v is None:
            raise ConfigError(f"{prefix}.{k}", f"required when {prefix}.grade = 'custom'")
        bounded_positive(f"{prefix}.{k}", v, hi=1e4)
    return ImuGrade.from_three_sigma(name, *vals3)


def read_imu(cfg: dict) -> tuple[ImuSpec, float]:
    """(the truth IMU, its sample rate [Hz]) of ``[imu]``."""
    t = table(cfg, "imu")
    grade = _grade(t, "imu")
    rate = positive_up_to("imu.rate_hz", get(cfg, "imu", "rate_hz"), MAX_IMU_RATE, "Hz")
    return ImuSpec(grade, positive(cfg, "imu", "tau_accel", "s"), positive(cfg, "imu", "tau_gyro", "s")), rate


def filter_imu_keys() -> list[str]:
    """Dotted keys of ``[filter.imu]`` (accepted although a default scenario leaves the table out)."""
    return ["filter", "filter.imu"] + [f"filter.imu.{k}" for k in ("grade", "tau_accel", "tau_gyro", *IMU_OVERRIDES)]


def read_filter_imu(cfg: dict, truth: ImuSpec) -> ImuSpec:
    """The filter's IMU model: ``[filter.imu]`` over ``[imu]`` (module docstring); ``truth`` itself when absent."""
    f = cfg.get("filter")
    if f is None:
        return truth
    if not isinstance(f, dict) or not isinstance(f.get("imu", {}), dict):
        raise ConfigError("filter", "must be a table with an [filter.imu] table")
    known_keys(f, ("imu",), "filter")
    fi = f.get("imu", {})
    known = {"grade", "tau_accel", "tau_gyro", *IMU_OVERRIDES}
    known_keys(fi, known, "filter.imu")
    if not fi:
        return truth
    imu = cfg["imu"]
    merged = {"grade": fi.get("grade", imu.get("grade"))}
    inherit = {} if "grade" in fi else {k: imu[k] for k in IMU_OVERRIDES if k in imu}
    merged.update({k: fi[k] for k in IMU_OVERRIDES if k in fi})
    grade = _grade(merged, "filter.imu", inherit)
    taus = [bounded_positive(f"filter.imu.{k}", fi[k], "s") if k in fi else getattr(truth, k)
            for k in ("tau_accel", "tau_gyro")]
    return ImuSpec(grade, *taus)


# ----------------------------------------------------------------------------- initial uncertainty
def read_initial(cfg: dict, filter_imu: ImuSpec) -> dict:
    """1-sigma SI initial uncertainty of ``[initial]``: ``p``, ``v``, ``th`` (3,) and ``ba``, ``bg`` (3,).

    The bias entries default to the filter's IMU grade (its steady-state sigma); ``initial.accel_bias_3sigma``
    [g] and ``initial.gyro_bias_3sigma`` [deg/hr] override them.
    """
    three = units.three_sigma_to_sigma
    ini = table(cfg, "initial")
    th = ini.get("theta_3sigma")
    if isinstance(th, list) and any(isinstance(v, (int, float)) and not isinstance(v, bool) and v > MAX_THETA_3SIGMA
                                    for v in th):
        raise ConfigError("initial.theta_3sigma", f"must be <= {MAX_THETA_3SIGMA} rad on each axis (the attitude error "
                          f"state is a small angle, thesis eq. 4.9), got {th}")
    p3, v3, th3 = (vector(cfg, "initial", key, positive=True, unit=unit, lo=lo, hi=hi)
                   for key, (lo, hi, unit) in INITIAL_RANGES.items())
    g = filter_imu.grade
    if "accel_bias_3sigma" in ini:
        ba = float(three(units.g_to_m_per_s2(bounded_positive("initial.accel_bias_3sigma", ini["accel_bias_3sigma"],
                                                               hi=1e4))))
    else:
        ba = g.accel_bias
    if "gyro_bias_3sigma" in ini:
        bg = float(three(units.deg_per_hr_to_rad_per_s(bounded_positive("initial.gyro_bias_3sigma",
                                                                         ini["gyro_bias_3sigma"], hi=1e6))))
    else:
        bg = g.gyro_bias
    return {"p": three(p3), "v": three(v3), "th": three(th3), "ba": np.full(3, ba), "bg": np.full(3, bg)}


# ----------------------------------------------------------------------------- radar
#: ``[radar]`` key -> (RadarParams field, conversion to SI)
RADAR_KEYS = {
    "carrier_ghz": ("carrier_frequency", units.ghz_to_hz),
    "bandwidth_mhz": ("bandwidth", units.mhz_to_hz),
    "sample_rate_mhz": ("sample_rate", units.mhz_to_hz),
    "pulse_length_us": ("pulse_length", units.us_to_s),
    "prf_hz": ("prf", float),
    "antenna_length_m": ("antenna_length", float),
    "look_side": ("look_side", str),
    "range_window": ("range_window", None),
    "azimuth_window": ("azimuth_window", None),
}
#: RadarParams field -> [radar] key (for error messages)
_KEY_OF = {f: k for k, (f, _) in RADAR_KEYS.items()}
_RADAR_FIELDS = frozenset(RadarParams.__dataclass_fields__)


def radar_fields(cfg: dict, ignore=("snr_db", "range_margin_m", "antenna_pattern")) -> tuple[str | None, dict]:
    """(preset name or None, RadarParams fields in SI) of ``[radar]``; keys in ``ignore`` are the kind's."""
    r = table(cfg, "radar")
    preset = r.get("preset")
    if preset is not None and preset not in PRESETS:
        raise ConfigError("radar.preset", f"must be one of {sorted(PRESETS)}, got {preset!r}")
    out = {}
    for key, value in r.items():
        if key == "preset" or key in ignore:
            continue
        if key not in RADAR_KEYS:
            raise ConfigError(f"radar.{key}", f"unknown key (known: preset, {', '.join(sorted(RADAR_KEYS))})")
        field, conv = RADAR_KEYS[key]
        if conv is None:
            out[field] = value
        elif conv is str:
            if not isinstance(value, str):
                raise ConfigError(f"radar.{key}", f"must be a string, got {value!r}")
            out[field] = value
        else:
            out[field] = float(conv(require_finite(f"radar.{key}", value)))
    return preset, out


def make_radar(preset: str | None, fields: dict, **window) -> RadarParams:
    """``RadarParams`` from a preset (or none) and SI fields; ``window``: ``near_range``, ``n_range_samples``.

    Validation is RadarParams' own; its errors are re-raised naming the ``[radar]`` key.
    """
    kw = dict(fields, **window)
    try:
        if preset is not None:
            return PRESETS[preset](**kw)
        return RadarParams(**kw)
    except ConfigError as err:
        raise ConfigError(radar_key(err.field), err.message) from None
    except TypeError as err:  # a field the preset or RadarParams lacks
        raise ConfigError("radar", f"incomplete radar: {err}") from None


def radar_key(field: str) -> str:
    """The ``[radar]`` key of a :class:`RadarParams` error's field (``prf`` -> ``radar.prf_hz``,
    ``azimuth_window[2]`` -> ``radar.azimuth_window[2]``, ``near_range`` -> ``radar.near_range``); other fields
    (``speed``, ``scene``...) unchanged."""
    name = field.split("[", 1)[0].split(".", 1)[0]
    if name in _KEY_OF:
        return f"radar.{_KEY_OF[name]}{field[len(name):]}"
    return f"radar.{field}" if name in _RADAR_FIELDS else field


def doppler_prf_check(params: RadarParams, speed: float) -> None:
    """The PRF must cover the -3 dB Doppler band at ``speed`` (azimuth Nyquist, ``RadarParams.check_doppler``),
    named as ``radar.prf_hz``."""
    try:
        params.check_doppler(speed)
    except ConfigError as err:
        raise ConfigError(radar_key(err.field), err.message) from None
