"""The manifest of a flight recording, ``flight.toml`` (docs/recording.md §2): parsed into typed records in SI.

The IMU, radar and initial-uncertainty tables use the project's one vocabulary (docs/scenarios/vocabulary.md:
``[imu]`` grade or 3-sigma figures, ``[radar]`` fields in the units of their keys, ``[initial]`` 3-sigma values);
the recording adds what a flown sensor has and a simulated one need not state: the time system and the clocks'
offsets, the local frame's geodetic origin, the lever arm, the files. Every bad, missing or unknown key is one line
naming the file and the key (``flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got 0.0``).
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError
from sarnav.radar import presets
from sarnav.radar.params import RadarParams
from sarnav.recording.fields import MANIFEST, Table
from sarnav.recording.noise import compressed_noise_gain
from sarnav.rotations import euler_to_quat, quat_normalize
from sarnav.recording.imu_formats import BODY_AXES
from sarnav.sensors.imu import GRADE_THREE_SIGMA, ImuGrade, ImuSpec
from sarnav.tomlio import parse_toml

__all__ = ["FORMAT", "FORMAT_VERSION", "Manifest", "TimeSystem", "LocalFrame", "ImuInfo", "AltimeterInfo",
           "InitialState", "ApertureInfo", "ReferenceInfo", "SimulationInfo", "read_manifest", "RADAR_KEYS",
           "IMU_OVERRIDES", "SAMPLE_KINDS", "REFERENCE_KINDS"]

FORMAT = "sarnav-recording"
FORMAT_VERSION = 1
SAMPLE_KINDS = ("rates", "increments")
REFERENCE_KINDS = ("cphd-pass", "orthoimage")
IMU_OVERRIDES = ("vrw_3sigma", "accel_bias_3sigma", "arw_3sigma", "gyro_bias_3sigma")
#: ``[radar]`` key -> (RadarParams field, conversion to SI): the scenario vocabulary's keys (docs/scenarios/vocabulary.md)
RADAR_KEYS = {
    "carrier_ghz": ("carrier_frequency", units.ghz_to_hz), "bandwidth_mhz": ("bandwidth", units.mhz_to_hz),
    "sample_rate_mhz": ("sample_rate", units.mhz_to_hz), "pulse_length_us": ("pulse_length", units.us_to_s),
    "prf_hz": ("prf", float), "antenna_length_m": ("antenna_length", float), "look_side": ("look_side", None),
    "range_window": ("range_window", None), "azimuth_window": ("azimuth_window", None),
    "near_range_m": ("near_range", float), "n_range_samples": ("n_range_samples", None),
}
_PRESETS = {"nav-paper-sim": presets.nav_paper_sim, "flexsar": presets.flexsar, "sun-ku-cart": presets.sun_ku_cart}
_KEY_OF = {f: k for k, (f, _) in RADAR_KEYS.items()}
#: a recording's IMU rate and the 3-sigma figures' upper bound (as the scenarios': vocabulary.MAX_IMU_RATE)
MAX_IMU_RATE = 1.0e4


@dataclass(frozen=True)
class TimeSystem:
    """Recording time t [s] counts from ``epoch`` (UTC); a sensor's clock reads t - offset (so t = clock + offset)."""

    epoch: datetime.datetime
    imu_clock_offset: float
    radar_clock_offset: float


@dataclass(frozen=True)
class LocalFrame:
    """The local NED frame: origin (lat [deg], lon [deg], height above the WGS-84 ellipsoid [m]); ``earth_rotation``:
    the IMU senses the Earth's turn (true for any real IMU; false for a recording of the sources' non-rotating
    world)."""

    origin: np.ndarray
    earth_rotation: bool


@dataclass(frozen=True)
class ImuInfo:
    """The IMU log (``file``, ``samples``: "rates" or "increments"; its format: ``recording.imu_formats``) and its
    error model (``spec``, 1-sigma SI; ``rate_hz``: the nominal sample rate); samples read as body axes FRD."""

    file: str
    samples: str
    spec: ImuSpec
    rate_hz: float
    body_axes: str = "FRD"  # the log's axes: "FRD", or "FLU" (ROS REP-103), turned to FRD on reading
    topic: str | None = None  # a ROS bag's sensor_msgs/Imu topic (None: its only one)


@dataclass(frozen=True)
class AltimeterInfo:
    """The altimeter log and its errors: white-noise, bias 1-sigma [m], bias correlation time [s]."""

    file: str
    sigma: float
    bias_sigma: float
    tau: float


@dataclass(frozen=True)
class InitialState:
    """The navigator's initial estimate at ``time`` [s] and its 1-sigma (SI). ``p``, ``v`` (3,) NED [m, m/s] (None
    when taken from GNSS up to ``gnss_until``), ``q`` (4,) body-to-NED quaternion (scalar first), ``ba``, ``bg``
    (3,) bias estimates [m/s^2, rad/s], ``bm`` (3,) measurement-bias estimates (altimeter, SAR range, SAR
    cross-range) [m]; ``sigma``: "p", "v", "th", "ba", "bg" -> (3,) 1-sigma."""

    time: float
    p: np.ndarray | None
    v: np.ndarray | None
    q: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    bm: np.ndarray
    sigma: dict
    gnss_until: float | None


@dataclass(frozen=True)
class ApertureInfo:
    """One aperture: its CPHD (``file``), the recording times of its first and last pulse [s], its reference (the
    reference pass's CPHD, or with ``[reference] kind = "orthoimage"`` the aperture's orthoimage, default the
    table's ``image``) and that pass's own start time (None: not stated)."""

    file: str
    start: float
    end: float
    reference: str | None
    reference_start: float | None


@dataclass(frozen=True)
class ReferenceInfo:
    """The reference: ``kind`` ("cphd-pass": an earlier pass per aperture as CPHD with trusted positions;
    "orthoimage": a geocoded GeoTIFF orthoimage, ``image``, with an optional DEM, ``dem``, and its geolocation
    1-sigma ``geolocation_sigma`` (3,) NED [m]; ``noise_power``: the orthoimage's noise power per pixel, None:
    estimated from it) and the reference points' file."""

    kind: str
    points: str
    image: str | None = None
    dem: str | None = None
    geolocation_sigma: np.ndarray | None = None
    noise_power: float | None = None


@dataclass(frozen=True)
class SimulationInfo:
    """An exported recording's provenance and what reproducing its campaign run needs beyond the sensor data:
    the scenario (text file), its seed, the run and the campaign's runs, the noise model's seed of the image
    extractor, and the offsets the simulated world added to the image-derived measurements (file)."""

    scenario: str
    scenario_file: str
    seed: int
    run: int
    runs: int
    noise_model_seed: int
    sar_offsets: str | None


@dataclass(frozen=True)
class Manifest:
    """``flight.toml`` parsed (module docstring); tables not in the file are None."""

    version: int
    description: str
    platform: str
    lever_arm: np.ndarray
    time: TimeSystem
    frame: LocalFrame
    imu: ImuInfo
    altimeter: AltimeterInfo | None
    radar: RadarParams | None
    noise_power: float | None
    initial: InitialState
    apertures: tuple
    reference: ReferenceInfo | None
    gnss_file: str | None
    truth_file: str | None
    simulation: SimulationInfo | None


_TOP = ("recording", "platform", "time", "frame", "imu", "altimeter", "radar", "initial", "reference", "aperture",
        "gnss", "truth", "simulation")


def read_manifest(path) -> Manifest:
    """Parse ``path`` (a recording's ``flight.toml``); ConfigError ``flight.toml:<key>: ...`` on the first bad key."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(MANIFEST, f"missing: a recording's folder holds its manifest ({str(path)!r} not found)")
    try:
        text = path.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(MANIFEST, f"cannot read as UTF-8 text ({err})") from None
    return parse_manifest(parse_toml(text, MANIFEST))


def parse_manifest(doc: dict) -> Manifest:
    """The manifest from its parsed TOML ``doc``."""
    top = Table(doc, "", _TOP)
    head = Table(top.get("recording"), "recording", ("format", "version", "description"))
    if head.get("format") != FORMAT:
        raise ConfigError(head.field("format"), f"must be {FORMAT!r}, got {head.get('format')!r}")
    version = head.integer("version", 1, 10**6)
    if version != FORMAT_VERSION:
        raise ConfigError(head.field("version"), f"this sarnav reads version {FORMAT_VERSION}, got {version}")
    plat = Table(top.get("platform", {}), "platform", ("name", "lever_arm_m"))
    imu = _imu(Table(top.get("imu"), "imu", ("file", "samples", "body_axes", "topic", "grade", "rate_hz",
                                             "tau_accel", "tau_gyro") + IMU_OVERRIDES))
    apertures = _apertures(top.get("aperture", []))
    radar, noise = _radar(top.get("radar", None), bool(apertures))
    reference = _reference(top.get("reference", None), apertures)
    gnss = _file_table(top.get("gnss", None), "gnss")
    initial = _initial(Table(top.get("initial"), "initial", _INITIAL_KEYS), imu.spec.grade, gnss)
    return Manifest(version=version, description=head.string("description", default=""),
                    platform=plat.string("name", default=""),
                    lever_arm=plat.vector("lever_arm_m", 3, -1e3, 1e3, "m", default=[0.0, 0.0, 0.0]),
                    time=_time(Table(top.get("time"), "time", ("epoch", "imu_clock_offset_s", "radar_clock_offset_s"))),
                    frame=_frame(Table(top.get("frame"), "frame", ("origin_lat_deg", "origin_lon_deg",
                                                                  "origin_height_m", "earth_rotation"))),
                    imu=imu, altimeter=_altimeter(top.get("altimeter", None)), radar=radar, noise_power=noise,
                    initial=initial, apertures=apertures, reference=reference, gnss_file=gnss,
                    truth_file=_file_table(top.get("truth", None), "truth"),
                    simulation=_simulation(top.get("simulation", None)))


def _time(t: Table) -> TimeSystem:
    return TimeSystem(t.datetime("epoch"), t.number("imu_clock_offset_s", -1e9, 1e9, "s", default=0.0),
                      t.number("radar_clock_offset_s", -1e9, 1e9, "s", default=0.0))


def _frame(t: Table) -> LocalFrame:
    origin = np.array([t.number("origin_lat_deg", -90.0, 90.0, "deg"), t.number("origin_lon_deg", -180.0, 360.0, "deg"),
                       t.number("origin_height_m", -1e4, 1e5, "m")])
    return LocalFrame(origin, t.boolean("earth_rotation", default=True))


def _imu(t: Table) -> ImuInfo:
    axes = t.string("body_axes", default="FRD")
    if axes not in BODY_AXES:
        raise ConfigError(t.field("body_axes"), f"must be 'FRD' (x forward, y right, z down) or 'FLU' (x forward, y "
                          f"left, z up: ROS REP-103), got {axes!r}: rotate the samples into one of these first")
    name = t.string("grade")
    if name != "custom" and name not in GRADE_THREE_SIGMA:
        raise ConfigError(t.field("grade"), f"must be one of {sorted(GRADE_THREE_SIGMA)} or 'custom', got {name!r}")
    base = GRADE_THREE_SIGMA.get(name, (None,) * 4)
    three = []
    for key, b in zip(IMU_OVERRIDES, base):
        if not t.has(key) and b is None:
            raise ConfigError(t.field(key), "required when imu.grade = 'custom'")
        three.append(t.number(key, 0.0, 1e4, default=b))
    grade = ImuGrade.from_three_sigma(name, *three)
    spec = ImuSpec(grade, t.positive("tau_accel", "s", 1e9), t.positive("tau_gyro", "s", 1e9))
    return ImuInfo(t.path("file"), t.string("samples", SAMPLE_KINDS), spec, t.positive("rate_hz", "Hz", MAX_IMU_RATE),
                   axes, t.string("topic", default=None) if t.has("topic") else None)


def _altimeter(data) -> AltimeterInfo | None:
    if data is None:
        return None
    t = Table(data, "altimeter", ("file", "sigma_3sigma", "bias_3sigma", "tau"))
    three = units.three_sigma_to_sigma
    return AltimeterInfo(t.path("file"), float(three(t.positive("sigma_3sigma", "m", 1e4))),
                         float(three(t.number("bias_3sigma", 0.0, 1e4, "m"))), t.positive("tau", "s", 1e9))


def _radar(data, needed: bool) -> tuple[RadarParams | None, float | None]:
    """The radar of ``[radar]`` (a preset and/or every field; the receive window, ``near_range_m`` and
    ``n_range_samples``, always stated: it is the range axis the pulses are read on) and its noise power."""
    if data is None:
        if needed:
            raise ConfigError(f"{MANIFEST}:radar", "missing: a recording with apertures states its radar")
        return None, None
    t = Table(data, "radar", ("preset", "noise_power", "compressed_noise_power") + tuple(RADAR_KEYS))
    for key in ("near_range_m", "n_range_samples"):
        t.get(key)
    preset = t.string("preset", tuple(_PRESETS), default=None) if t.has("preset") else None
    kw = {}
    for key, (name, conv) in RADAR_KEYS.items():
        if not t.has(key):
            continue
        if key == "n_range_samples":
            kw[name] = t.integer(key, 2, 10**7)
        elif conv is None:
            kw[name] = t.get(key)
        else:
            kw[name] = float(conv(t.number(key)))
    try:
        radar = _PRESETS[preset](**kw) if preset else RadarParams(**kw)
    except ConfigError as err:
        base = err.field.split("[", 1)[0].split(".", 1)[0]
        raise ConfigError(t.field(_KEY_OF.get(base, base) + err.field[len(base):]), err.message) from None
    except TypeError as err:  # a field missing without a preset
        raise ConfigError(f"{MANIFEST}:radar", f"incomplete radar (give a preset or every field): {err}") from None
    if t.has("noise_power") and t.has("compressed_noise_power"):
        raise ConfigError(t.field("compressed_noise_power"), "give noise_power (per raw sample) or "
                          "compressed_noise_power (per range-compressed sample), not both")
    if t.has("compressed_noise_power"):
        return radar, t.positive("compressed_noise_power", hi=1e30) / compressed_noise_gain(radar)
    return radar, (t.positive("noise_power", hi=1e30) if (needed or t.has("noise_power")) else None)


_INITIAL_KEYS = ("time_s", "position_ned_m", "velocity_ned_mps", "attitude_quaternion", "roll_pitch_yaw_deg",
                 "accel_bias_mps2", "gyro_bias_radps", "measurement_bias_m", "p_3sigma", "v_3sigma", "theta_3sigma",
                 "accel_bias_3sigma", "gyro_bias_3sigma", "gnss_until_s")


def _initial(t: Table, grade: ImuGrade, gnss: str | None) -> InitialState:
    time_s = t.number("time_s", -1e9, 1e9, "s")
    until = t.number("gnss_until_s", time_s, 1e9, "s") if t.has("gnss_until_s") else None
    if until is not None and gnss is None:
        raise ConfigError(t.field("gnss_until_s"), "needs a [gnss] log (gnss.file)")
    free = until is not None  # position and velocity from GNSS
    p = t.vector("position_ned_m", 3, -1e7, 1e7, "m") if (t.has("position_ned_m") or not free) else None
    v = t.vector("velocity_ned_mps", 3, -1e4, 1e4, "m/s") if (t.has("velocity_ned_mps") or not free) else None
    if t.has("attitude_quaternion") == t.has("roll_pitch_yaw_deg"):
        raise ConfigError(t.field("attitude_quaternion"), "give exactly one of attitude_quaternion (body-to-NED, "
                          "scalar first) and roll_pitch_yaw_deg")
    if t.has("attitude_quaternion"):
        q = t.vector("attitude_quaternion", 4, -1.0 - 1e-6, 1.0 + 1e-6)
        if abs(np.linalg.norm(q) - 1.0) > 1e-6:
            raise ConfigError(t.field("attitude_quaternion"), f"must have unit norm, got {np.linalg.norm(q):.9g}")
        q = q if abs(np.linalg.norm(q) - 1.0) <= 1e-12 else quat_normalize(q)  # a written unit quaternion as is
    else:
        rpy = units.deg_to_rad(t.vector("roll_pitch_yaw_deg", 3, -360.0, 360.0, "deg"))
        q = np.asarray(euler_to_quat(*rpy), dtype=np.float64)
    three = units.three_sigma_to_sigma
    sigma = {"p": three(t.vector("p_3sigma", 3, 1e-6, 1e5, "m")), "v": three(t.vector("v_3sigma", 3, 1e-6, 1e3, "m/s")),
             "th": three(t.vector("theta_3sigma", 3, 1e-9, 0.5, "rad"))}
    sigma["ba"] = np.full(3, float(three(units.g_to_m_per_s2(t.positive("accel_bias_3sigma", "g", 1e4))))
                          if t.has("accel_bias_3sigma") else grade.accel_bias)
    sigma["bg"] = np.full(3, float(three(units.deg_per_hr_to_rad_per_s(t.positive("gyro_bias_3sigma", "deg/hr", 1e6))))
                          if t.has("gyro_bias_3sigma") else grade.gyro_bias)
    zero = [0.0, 0.0, 0.0]
    return InitialState(time_s, p, v, q, t.vector("accel_bias_mps2", 3, -1e3, 1e3, "m/s^2", default=zero),
                        t.vector("gyro_bias_radps", 3, -10.0, 10.0, "rad/s", default=zero),
                        t.vector("measurement_bias_m", 3, -1e4, 1e4, "m", default=zero), sigma, until)


def _apertures(data) -> tuple:
    if not isinstance(data, list):
        raise ConfigError(f"{MANIFEST}:aperture", "must be an array of tables ([[aperture]])")
    out, last = [], None
    for i, item in enumerate(data):
        t = Table(item, f"aperture[{i}]", ("file", "start_s", "end_s", "reference", "reference_start_s"))
        start = t.number("start_s", -1e9, 1e9, "s")
        end = t.number("end_s", start, 1e9, "s")
        if not end > start:
            raise ConfigError(t.field("end_s"), f"must be after start_s = {start!r} s, got {end!r}")
        if last is not None and not start > last:
            raise ConfigError(t.field("start_s"), f"must be after the previous aperture's start {last!r} s "
                              "(apertures in time order)")
        last = start
        ref_start = t.number("reference_start_s", -1e12, 1e12, "s") if t.has("reference_start_s") else None
        out.append(ApertureInfo(t.path("file"), start, end, t.path("reference", default=None), ref_start))
    return tuple(out)


def _reference(data, apertures: tuple) -> ReferenceInfo | None:
    needed = bool(apertures)
    if data is None:
        if needed:
            raise ConfigError(f"{MANIFEST}:reference", "missing: a recording with apertures states its reference")
        return None
    t = Table(data, "reference", ("kind", "points", "image", "dem", "geolocation_sigma_m", "noise_power"))
    kind = t.string("kind", REFERENCE_KINDS)
    if kind == "cphd-pass":
        for key in ("image", "dem", "geolocation_sigma_m", "noise_power"):
            if t.has(key):
                raise ConfigError(t.field(key), "belongs to kind = 'orthoimage' (a 'cphd-pass' reference is the "
                                  "apertures' reference CPHD files)")
        for i, ap in enumerate(apertures):
            if ap.reference is None:
                raise ConfigError(f"{MANIFEST}:aperture[{i}].reference", "missing: a 'cphd-pass' reference names each "
                                  "aperture's reference pass")
        return ReferenceInfo(kind, t.path("points"))
    image = t.path("image", default=None)
    if image is None and any(ap.reference is None for ap in apertures):
        raise ConfigError(t.field("image"), "missing: the orthoimage of the apertures that name no reference")
    sigma = t.vector("geolocation_sigma_m", 3, 0.0, 1e4, "m")
    noise = t.positive("noise_power", hi=1e30) if t.has("noise_power") else None
    return ReferenceInfo(kind, t.path("points"), image, t.path("dem", default=None), sigma, noise)


def _file_table(data, name: str) -> str | None:
    if data is None:
        return None
    return Table(data, name, ("file",)).path("file")


def _simulation(data) -> SimulationInfo | None:
    if data is None:
        return None
    t = Table(data, "simulation", ("scenario", "scenario_file", "seed", "run", "runs", "noise_model_seed", "sar_offsets"))
    runs = t.integer("runs", 1, 10**9)
    return SimulationInfo(t.string("scenario"), t.path("scenario_file"), t.integer("seed", 0, 2**63 - 1),
                          t.integer("run", 0, runs - 1), runs, t.integer("noise_model_seed", 0, 2**63 - 1),
                          t.path("sar_offsets", default=None))
