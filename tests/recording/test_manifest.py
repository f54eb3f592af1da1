"""``sarnav.recording.manifest``: ``flight.toml`` (docs/recording.md §2) read into typed records in SI.

The manifests are written here with tomli_w from dicts built after the document (the minimal manifest of §2 is the
base); the expected SI values are converted by hand from the document's units (3-sigma figures over 3, m/s/sqrt(hr)
over 60, g = 9.81 m/s^2, deg/hr over 3600, GHz, MHz, us). Bad input is one line naming ``flight.toml``, the key and
the valid range.
"""

from __future__ import annotations

import copy
import datetime
import math

import numpy as np
import pytest
import tomli_w

from sarnav.errors import ConfigError
from sarnav.radar.params import RadarParams
from sarnav.radar.presets import nav_paper_sim
from sarnav.recording.manifest import (FORMAT, FORMAT_VERSION, RADAR_KEYS, Manifest, parse_manifest,
                                       read_manifest)
from sarnav.recording.noise import compressed_noise_gain
from sarnav.sensors.imu import GRADE_THREE_SIGMA

G = 9.81  # the unit "g" of the *_3sigma figures (docs/recording.md §1)

#: the minimal manifest of docs/recording.md §2 (values of the rda-nav paper simulation)
MINIMAL = {
    "recording": {"format": "sarnav-recording", "version": 1},
    "time": {"epoch": datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc)},
    "frame": {"origin_lat_deg": 40.0, "origin_lon_deg": 0.0, "origin_height_m": 0.0, "earth_rotation": False},
    "imu": {"file": "imu.csv", "samples": "rates", "grade": "nav-paper-tactical", "rate_hz": 100.0,
            "tau_accel": 3600.0, "tau_gyro": 3600.0},
    "altimeter": {"file": "altimeter.csv", "sigma_3sigma": 4.0, "bias_3sigma": 0.25, "tau": 3600.0},
    "radar": {"preset": "nav-paper-sim", "near_range_m": 1919.3, "n_range_samples": 2458, "noise_power": 99.856},
    "initial": {"time_s": 0.0, "position_ned_m": [0.0, 0.0, -1000.0], "velocity_ned_mps": [10.0, 0.0, 0.0],
                "roll_pitch_yaw_deg": [0.0, 0.0, 0.0], "p_3sigma": [1.9, 1.9, 4.4], "v_3sigma": [0.3, 0.3, 0.5],
                "theta_3sigma": [0.002, 0.002, 0.006]},
    "reference": {"kind": "cphd-pass", "points": "reference/points.csv"},
    "aperture": [{"file": "apertures/0000.cphd", "start_s": 0.0, "end_s": 0.99,
                  "reference": "reference/0000.cphd"}],
}

#: the manifest of an INS + altimeter recording: no radar, reference or apertures
INS_ONLY = {k: v for k, v in MINIMAL.items() if k not in ("radar", "reference", "aperture")}


def doc(base=MINIMAL, **tables) -> dict:
    """A deep copy of ``base`` with tables replaced (``None``: removed)."""
    out = copy.deepcopy(base)
    for name, table in tables.items():
        if table is None:
            out.pop(name, None)
        else:
            out[name] = table
    return out


def edit(base=MINIMAL, **changes) -> dict:
    """A copy of ``base`` with ``table__key=value`` changes (``None``: the key removed)."""
    out = copy.deepcopy(base)
    for dotted, value in changes.items():
        table, key = dotted.split("__", 1)
        if value is None:
            out[table].pop(key, None)
        else:
            out[table][key] = value
    return out


def write(tmp_path, d) -> Manifest:
    """``d`` written as ``flight.toml`` with tomli_w and read back with ``read_manifest``."""
    path = tmp_path / "flight.toml"
    path.write_text(tomli_w.dumps(d), encoding="utf-8")
    return read_manifest(path)


def refused(d) -> str:
    """The one-line message of the ConfigError ``parse_manifest(d)`` raises."""
    with pytest.raises(ConfigError) as err:
        parse_manifest(d)
    msg = str(err.value)
    assert "\n" not in msg, msg
    assert msg.startswith("flight.toml:"), msg
    return msg


def imu_sigma(vrw3, acc3, arw3, gyr3):
    """1-sigma SI of 3-sigma figures in m/s/sqrt(hr), g, deg/sqrt(hr), deg/hr (by hand)."""
    return (vrw3 / 3.0 / 60.0, acc3 / 3.0 * G, math.radians(arw3 / 3.0) / 60.0, math.radians(gyr3 / 3.0) / 3600.0)


def dcm(q):
    """Body-to-NED rotation matrix of a scalar-first Hamilton quaternion."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


# ---- the documented minimal manifest -------------------------------------------------------------------------------


def test_documented_minimal_manifest_reads_in_si(tmp_path):
    """docs/recording.md's minimal manifest: every value in SI, the defaults of the table filled in."""
    m = write(tmp_path, MINIMAL)
    assert (m.version, m.description, m.platform) == (1, "", "")
    np.testing.assert_array_equal(m.lever_arm, [0.0, 0.0, 0.0])
    assert m.time.epoch == datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc)
    assert (m.time.imu_clock_offset, m.time.radar_clock_offset) == (0.0, 0.0)
    np.testing.assert_array_equal(m.frame.origin, [40.0, 0.0, 0.0])
    assert m.frame.earth_rotation is False
    assert (m.imu.file, m.imu.samples, m.imu.rate_hz, m.imu.body_axes, m.imu.topic) == \
        ("imu.csv", "rates", 100.0, "FRD", None)
    assert (m.imu.spec.tau_accel, m.imu.spec.tau_gyro) == (3600.0, 3600.0)
    alt = m.altimeter
    assert alt.file == "altimeter.csv"
    assert alt.sigma == pytest.approx(4.0 / 3.0, rel=1e-14)
    assert alt.bias_sigma == pytest.approx(0.25 / 3.0, rel=1e-14)
    assert alt.tau == 3600.0
    assert m.radar == nav_paper_sim(near_range=1919.3, n_range_samples=2458)
    assert m.noise_power == 99.856
    ini = m.initial
    assert ini.time == 0.0 and ini.gnss_until is None
    np.testing.assert_array_equal(ini.p, [0.0, 0.0, -1000.0])
    np.testing.assert_array_equal(ini.v, [10.0, 0.0, 0.0])
    np.testing.assert_allclose(ini.q, [1.0, 0.0, 0.0, 0.0], atol=1e-15)
    for name, three in (("p", [1.9, 1.9, 4.4]), ("v", [0.3, 0.3, 0.5]), ("th", [0.002, 0.002, 0.006])):
        np.testing.assert_allclose(ini.sigma[name], np.array(three) / 3.0, rtol=1e-14)
    for name in ("ba", "bg", "bm"):
        np.testing.assert_array_equal(getattr(ini, name), np.zeros(3))
    assert m.reference.kind == "cphd-pass" and m.reference.points == "reference/points.csv"
    assert m.reference.image is None and m.reference.geolocation_sigma is None
    (ap,) = m.apertures
    assert (ap.file, ap.start, ap.end, ap.reference, ap.reference_start) == \
        ("apertures/0000.cphd", 0.0, 0.99, "reference/0000.cphd", None)
    assert (m.gnss_file, m.truth_file, m.simulation) == (None, None, None)


def test_format_constants_are_the_documented_ones():
    assert (FORMAT, FORMAT_VERSION) == ("sarnav-recording", 1)


def test_named_grade_is_converted_to_one_sigma_si_and_sets_the_initial_bias_sigmas():
    """imu.grade's 3-sigma figures (m/s/sqrt(hr), g, deg/sqrt(hr), deg/hr) become 1-sigma SI; the initial bias
    1-sigmas default to the grade's."""
    for name, three in GRADE_THREE_SIGMA.items():
        m = parse_manifest(edit(imu__grade=name))
        g = m.imu.spec.grade
        np.testing.assert_allclose([g.vrw, g.accel_bias, g.arw, g.gyro_bias], imu_sigma(*three), rtol=1e-12)
        np.testing.assert_allclose(m.initial.sigma["ba"], np.full(3, three[1] / 3.0 * G), rtol=1e-12)
        np.testing.assert_allclose(m.initial.sigma["bg"], np.full(3, math.radians(three[3] / 3.0) / 3600.0),
                                   rtol=1e-12)


def test_custom_grade_takes_its_four_figures():
    figures = {"vrw_3sigma": 0.05, "accel_bias_3sigma": 0.003, "arw_3sigma": 0.05, "gyro_bias_3sigma": 3.0}
    m = parse_manifest(edit(imu__grade="custom", **{f"imu__{k}": v for k, v in figures.items()}))
    g = m.imu.spec.grade
    np.testing.assert_allclose([g.vrw, g.accel_bias, g.arw, g.gyro_bias], imu_sigma(*figures.values()), rtol=1e-12)


@pytest.mark.parametrize("absent", ["vrw_3sigma", "accel_bias_3sigma", "arw_3sigma", "gyro_bias_3sigma"])
def test_custom_grade_needs_all_four_figures(absent):
    figures = {"vrw_3sigma": 0.05, "accel_bias_3sigma": 0.003, "arw_3sigma": 0.05, "gyro_bias_3sigma": 3.0}
    figures.pop(absent)
    msg = refused(edit(imu__grade="custom", **{f"imu__{k}": v for k, v in figures.items()}))
    assert msg == f"flight.toml:imu.{absent}: required when imu.grade = 'custom'"


def test_a_figure_overrides_the_named_grades():
    """A 3-sigma figure given with a named grade replaces the grade's, the other three stay."""
    three = GRADE_THREE_SIGMA["tactical"]
    g = parse_manifest(edit(imu__grade="tactical", imu__gyro_bias_3sigma=2.0)).imu.spec.grade
    np.testing.assert_allclose([g.vrw, g.accel_bias, g.arw, g.gyro_bias],
                               imu_sigma(three[0], three[1], three[2], 2.0), rtol=1e-12)


def test_initial_bias_sigmas_override_the_grades():
    ini = parse_manifest(edit(initial__accel_bias_3sigma=0.006, initial__gyro_bias_3sigma=9.0)).initial
    np.testing.assert_allclose(ini.sigma["ba"], np.full(3, 0.002 * G), rtol=1e-12)
    np.testing.assert_allclose(ini.sigma["bg"], np.full(3, math.radians(3.0) / 3600.0), rtol=1e-12)


def test_optional_tables_and_keys_read_as_given():
    """[platform], clock offsets, body_axes, topic, bias estimates, gnss, truth and simulation, as documented."""
    d = doc(platform={"name": "rig", "lever_arm_m": [0.5, 0.0, -0.25]}, gnss={"file": "gnss.csv"},
            truth={"file": "logs/truth.csv"},
            simulation={"scenario": "rda-nav", "scenario_file": "scenario.toml", "seed": 7, "run": 2, "runs": 4,
                        "noise_model_seed": 11, "sar_offsets": "sar_offsets.csv"})
    d["recording"]["description"] = "free text"
    d["time"].update(imu_clock_offset_s=-0.125, radar_clock_offset_s=0.25)
    d["imu"].update(body_axes="FLU", topic="/imu/data")
    d["initial"].update(accel_bias_mps2=[0.01, -0.02, 0.03], gyro_bias_radps=[1e-5, 0.0, -1e-5],
                        measurement_bias_m=[1.0, -2.0, 0.5])
    d["aperture"][0]["reference_start_s"] = 12.5
    m = parse_manifest(d)
    assert (m.description, m.platform) == ("free text", "rig")
    np.testing.assert_array_equal(m.lever_arm, [0.5, 0.0, -0.25])
    assert (m.time.imu_clock_offset, m.time.radar_clock_offset) == (-0.125, 0.25)
    assert (m.imu.body_axes, m.imu.topic) == ("FLU", "/imu/data")
    np.testing.assert_array_equal(m.initial.ba, [0.01, -0.02, 0.03])
    np.testing.assert_array_equal(m.initial.bg, [1e-5, 0.0, -1e-5])
    np.testing.assert_array_equal(m.initial.bm, [1.0, -2.0, 0.5])
    assert m.apertures[0].reference_start == 12.5
    assert (m.gnss_file, m.truth_file) == ("gnss.csv", "logs/truth.csv")
    s = m.simulation
    assert (s.scenario, s.scenario_file, s.seed, s.run, s.runs, s.noise_model_seed, s.sar_offsets) == \
        ("rda-nav", "scenario.toml", 7, 2, 4, 11, "sar_offsets.csv")


def test_ins_only_recording_has_no_radar_reference_or_apertures():
    """[radar], [reference] and [[aperture]] come together; without apertures all three may be absent."""
    m = parse_manifest(INS_ONLY)
    assert (m.radar, m.noise_power, m.reference, m.apertures) == (None, None, None, ())


# ---- time, attitude ------------------------------------------------------------------------------------------------


def test_epoch_as_string_and_other_offsets_read_as_utc():
    """The epoch may be the date-time's text; an offset other than Z is converted to UTC."""
    utc = datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc)
    assert parse_manifest(edit(time__epoch="2026-01-01T00:00:00Z")).time.epoch == utc
    east = datetime.datetime(2026, 1, 1, 2, 0, tzinfo=datetime.timezone(datetime.timedelta(hours=2)))
    got = parse_manifest(edit(time__epoch=east)).time.epoch
    assert got == utc and got.utcoffset() == datetime.timedelta(0)


@pytest.mark.parametrize("epoch, start", [
    (datetime.datetime(2026, 1, 1), "flight.toml:time.epoch: must be a date-time with its UTC offset"),
    ("2026-01-01T00:00:00", "flight.toml:time.epoch: must be a date-time with its UTC offset"),
    ("yesterday", "flight.toml:time.epoch: must be an ISO 8601 date-time, got 'yesterday'"),
    (0.0, "flight.toml:time.epoch: must be a date-time"),
])
def test_epoch_without_utc_offset_is_refused(epoch, start):
    assert refused(edit(time__epoch=epoch)).startswith(start)


def test_roll_pitch_yaw_is_the_3_2_1_rotation():
    """T = Rz(yaw) Ry(pitch) Rx(roll) (docs/recording.md §1), from degrees."""
    roll, pitch, yaw = 10.0, -20.0, 135.0
    q = parse_manifest(edit(initial__roll_pitch_yaw_deg=[roll, pitch, yaw])).initial.q
    r, p, y = (math.radians(a) for a in (roll, pitch, yaw))
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(dcm(q), rz @ ry @ rx, atol=1e-14)


def test_attitude_quaternion_is_read_scalar_first():
    half = math.radians(30.0) / 2
    q = [math.cos(half), 0.0, 0.0, math.sin(half)]  # yaw 30 deg
    d = edit(initial__roll_pitch_yaw_deg=None, initial__attitude_quaternion=q)
    np.testing.assert_allclose(parse_manifest(d).initial.q, q, rtol=0, atol=1e-16)


def test_nearly_unit_quaternion_is_normalised_and_a_non_unit_one_refused():
    q = np.array([0.6, 0.0, 0.0, 0.8]) * (1 + 5e-7)
    d = edit(initial__roll_pitch_yaw_deg=None, initial__attitude_quaternion=q.tolist())
    got = parse_manifest(d).initial.q
    assert np.linalg.norm(got) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(got, [0.6, 0.0, 0.0, 0.8], atol=1e-15)
    d = edit(initial__roll_pitch_yaw_deg=None, initial__attitude_quaternion=[0.5, 0.0, 0.0, 0.5])
    assert refused(d).startswith("flight.toml:initial.attitude_quaternion: must have unit norm, got 0.7071")


@pytest.mark.parametrize("both", [True, False])
def test_exactly_one_attitude_is_given(both):
    d = edit(initial__attitude_quaternion=[1.0, 0.0, 0.0, 0.0]) if both else edit(initial__roll_pitch_yaw_deg=None)
    assert refused(d).startswith("flight.toml:initial.attitude_quaternion: give exactly one of")


# ---- the radar -----------------------------------------------------------------------------------------------------


def test_radar_from_every_field_is_converted_to_si():
    """Without a preset, the vocabulary's keys in their units (GHz, MHz, us) make the RadarParams."""
    radar = {"carrier_ghz": 9.6, "bandwidth_mhz": 150.0, "sample_rate_mhz": 187.5, "pulse_length_us": 0.5,
             "prf_hz": 400.0, "antenna_length_m": 1.0, "look_side": "left", "range_window": "hamming",
             "azimuth_window": "none", "near_range_m": 1960.0, "n_range_samples": 320, "noise_power": 2.0}
    m = parse_manifest(doc(radar=radar))
    want = RadarParams(carrier_frequency=9.6e9, bandwidth=150e6, sample_rate=187.5e6, pulse_length=0.5e-6,
                       prf=400.0, antenna_length=1.0, look_side="left", range_window="hamming",
                       azimuth_window="none", near_range=1960.0, n_range_samples=320)
    assert m.radar == want
    assert m.noise_power == 2.0


def test_radar_keys_cover_the_documented_vocabulary():
    documented = {"carrier_ghz", "bandwidth_mhz", "sample_rate_mhz", "pulse_length_us", "prf_hz",
                  "antenna_length_m", "look_side", "range_window", "azimuth_window", "near_range_m",
                  "n_range_samples"}
    assert set(RADAR_KEYS) == documented


def test_preset_fields_are_overridden_by_keys():
    m = parse_manifest(edit(radar__prf_hz=125.0, radar__look_side="left"))
    assert m.radar == nav_paper_sim(near_range=1919.3, n_range_samples=2458, prf=125.0, look_side="left")


def test_compressed_noise_power_is_divided_by_the_filters_noise_gain():
    """compressed_noise_power P gives the raw noise power N = P / g (docs/recording.md §5)."""
    m = parse_manifest(edit(radar__noise_power=None, radar__compressed_noise_power=3.0))
    assert m.noise_power == pytest.approx(3.0 / compressed_noise_gain(m.radar), rel=1e-14)
    assert refused(edit(radar__compressed_noise_power=3.0)).startswith(
        "flight.toml:radar.compressed_noise_power: give noise_power (per raw sample) or compressed_noise_power")


@pytest.mark.parametrize("key", ["near_range_m", "n_range_samples"])
def test_receive_window_is_required_even_with_a_preset(key):
    assert refused(edit(**{f"radar__{key}": None})) == f"flight.toml:radar.{key}: missing"


def test_noise_power_is_required_with_apertures_only():
    assert refused(edit(radar__noise_power=None)) == "flight.toml:radar.noise_power: missing"
    d = doc(INS_ONLY, radar={k: v for k, v in MINIMAL["radar"].items() if k != "noise_power"})
    m = parse_manifest(d)
    assert m.radar is not None and m.noise_power is None


def test_incomplete_radar_without_a_preset_is_refused():
    radar = {k: v for k, v in MINIMAL["radar"].items() if k != "preset"}
    msg = refused(doc(radar=radar))
    assert msg.startswith("flight.toml:radar: incomplete radar (give a preset or every field)")


@pytest.mark.parametrize("key, value, start", [
    ("prf_hz", 0.0, "flight.toml:radar.prf_hz: must be finite and > 0"),
    ("prf_hz", -100.0, "flight.toml:radar.prf_hz: must be finite and > 0"),
    ("pulse_length_us", 20000.0, "flight.toml:radar.pulse_length_us: must be shorter than"),
    ("bandwidth_mhz", 30000.0, "flight.toml:radar.bandwidth_mhz: must be < 2 x carrier_frequency"),
    ("look_side", "up", "flight.toml:radar.look_side: must be one of"),
    ("n_range_samples", 1, "flight.toml:radar.n_range_samples: must be an integer in [2, 10000000], got 1"),
    ("n_range_samples", 2458.0, "flight.toml:radar.n_range_samples: must be an integer in [2, 10000000], got"),
    ("preset", "x-band", "flight.toml:radar.preset: must be one of ['nav-paper-sim', 'flexsar', 'sun-ku-cart']"),
    ("carrier_ghz", "9.75", "flight.toml:radar.carrier_ghz: must be a number, got '9.75'"),
    ("noise_power", 0.0, "flight.toml:radar.noise_power: must be a finite number in (0, 1e+30], got 0.0"),
])
def test_bad_radar_value_names_the_manifest_key(key, value, start):
    """A radar value refused by RadarParams is named by its manifest key (with its unit suffix), not the field."""
    msg = refused(edit(**{f"radar__{key}": value}))
    assert msg.startswith(start), msg
    assert str(value) in msg or key == "bandwidth_mhz" or key == "pulse_length_us"


def test_radar_and_reference_are_required_with_apertures():
    assert refused(doc(radar=None)).startswith("flight.toml:radar: missing: a recording with apertures")
    assert refused(doc(reference=None)).startswith("flight.toml:reference: missing: a recording with apertures")


# ---- required tables and keys, unknown keys ------------------------------------------------------------------------


@pytest.mark.parametrize("table", ["recording", "time", "frame", "imu", "initial"])
def test_required_table_missing_is_named(table):
    assert refused(doc(**{table: None})) == f"flight.toml:{table}: missing"


@pytest.mark.parametrize("table, key", [
    ("recording", "format"), ("recording", "version"), ("time", "epoch"), ("frame", "origin_lat_deg"),
    ("frame", "origin_lon_deg"), ("frame", "origin_height_m"), ("imu", "file"), ("imu", "samples"),
    ("imu", "grade"), ("imu", "rate_hz"), ("imu", "tau_accel"), ("imu", "tau_gyro"), ("altimeter", "file"),
    ("altimeter", "sigma_3sigma"), ("altimeter", "bias_3sigma"), ("altimeter", "tau"), ("initial", "time_s"),
    ("initial", "position_ned_m"), ("initial", "velocity_ned_mps"), ("initial", "p_3sigma"),
    ("initial", "v_3sigma"), ("initial", "theta_3sigma"), ("reference", "kind"), ("reference", "points"),
])
def test_required_key_missing_is_named(table, key):
    assert refused(edit(**{f"{table}__{key}": None})) == f"flight.toml:{table}.{key}: missing"


@pytest.mark.parametrize("key", ["file", "start_s", "end_s"])
def test_required_aperture_key_missing_is_named(key):
    d = doc()
    del d["aperture"][0][key]
    assert refused(d) == f"flight.toml:aperture[0].{key}: missing"


@pytest.mark.parametrize("table, key", [
    ("recording", "author"), ("time", "epoch_utc"), ("frame", "origin_alt_m"), ("imu", "rate"),
    ("imu", "rate_Hz"), ("altimeter", "sigma"), ("radar", "prf_khz"), ("initial", "position_m"),
    ("reference", "image_file"),
])
def test_unknown_key_is_refused_listing_the_known_ones(table, key):
    d = doc()
    d[table][key] = 1.0
    msg = refused(d)
    assert msg.startswith(f"flight.toml:{table}.{key}: unknown key (known: "), msg


def test_unknown_table_and_aperture_key_are_refused():
    assert refused(doc(gps={"file": "gps.csv"})).startswith("flight.toml:gps: unknown key (known: recording, ")
    d = doc()
    d["aperture"][0]["stop_s"] = 1.0
    assert refused(d).startswith("flight.toml:aperture[0].stop_s: unknown key")
    assert refused(doc(platform={"name": "x", "lever_arm": [0, 0, 0]})).startswith(
        "flight.toml:platform.lever_arm: unknown key")


def test_a_table_given_as_a_value_is_refused():
    assert refused(doc(imu="imu.csv")) == "flight.toml:imu: must be a table, got str"
    assert refused(doc(aperture={"file": "a.cphd"})) == \
        "flight.toml:aperture: must be an array of tables ([[aperture]])"


def test_format_and_version_are_checked():
    assert refused(edit(recording__format="sarnav")) == \
        "flight.toml:recording.format: must be 'sarnav-recording', got 'sarnav'"
    assert refused(edit(recording__version=2)) == "flight.toml:recording.version: this sarnav reads version 1, got 2"
    assert refused(edit(recording__version="1")).startswith("flight.toml:recording.version: must be an integer in")


# ---- ranges and types: one line naming file, key and range ---------------------------------------------------------


@pytest.mark.parametrize("table, key, value, start", [
    ("frame", "origin_lat_deg", 91.0, "flight.toml:frame.origin_lat_deg: must be in [-90, 90] deg, got 91.0"),
    ("frame", "origin_lat_deg", math.nan, "flight.toml:frame.origin_lat_deg: must be finite in [-90, 90] deg"),
    ("frame", "origin_lon_deg", -181.0, "flight.toml:frame.origin_lon_deg: must be in [-180, 360] deg, got -181.0"),
    ("frame", "origin_height_m", 2e5, "flight.toml:frame.origin_height_m: must be in [-10000, 100000] m"),
    ("frame", "earth_rotation", 1, "flight.toml:frame.earth_rotation: must be true or false, got 1"),
    ("imu", "rate_hz", -100.0, "flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got -100.0"),
    ("imu", "rate_hz", 0.0, "flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got 0.0"),
    ("imu", "rate_hz", 2e4, "flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got 20000.0"),
    ("imu", "rate_hz", "100", "flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got '100'"),
    ("imu", "rate_hz", True, "flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got True"),
    ("imu", "rate_hz", math.inf, "flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got inf"),
    ("imu", "tau_accel", -1.0, "flight.toml:imu.tau_accel: must be a finite number in (0, "),
    ("imu", "samples", "deltas", "flight.toml:imu.samples: must be one of ['rates', 'increments'], got 'deltas'"),
    ("imu", "grade", "superb", "flight.toml:imu.grade: must be one of"),
    ("imu", "body_axes", "ENU", "flight.toml:imu.body_axes: must be 'FRD'"),
    ("imu", "vrw_3sigma", -0.1, "flight.toml:imu.vrw_3sigma: must be in [0, 10000], got -0.1"),
    ("altimeter", "sigma_3sigma", 0.0, "flight.toml:altimeter.sigma_3sigma: must be a finite number in (0, "),
    ("altimeter", "bias_3sigma", -1.0, "flight.toml:altimeter.bias_3sigma: must be in [0, 10000] m, got -1.0"),
    ("time", "imu_clock_offset_s", 2e9, "flight.toml:time.imu_clock_offset_s: must be in [-1e+09, 1e+09] s"),
    ("initial", "p_3sigma", [1.0, 0.0, 1.0], "flight.toml:initial.p_3sigma[1]: must be in [1e-06, 100000] m, got 0.0"),
    ("initial", "theta_3sigma", [0.1, 0.1, 0.6], "flight.toml:initial.theta_3sigma[2]: must be in [1e-09, 0.5] rad"),
    ("initial", "v_3sigma", [0.3, 0.3], "flight.toml:initial.v_3sigma: must be a list of 3 numbers [m/s], got"),
    ("initial", "roll_pitch_yaw_deg", [0.0, 0.0, 400.0],
     "flight.toml:initial.roll_pitch_yaw_deg[2]: must be in [-360, 360] deg, got 400.0"),
    ("initial", "position_ned_m", "0, 0, -1000", "flight.toml:initial.position_ned_m: must be a list of 3 numbers"),
])
def test_out_of_range_or_mistyped_value_names_key_and_range(table, key, value, start):
    msg = refused(edit(**{f"{table}__{key}": value}))
    assert msg.startswith(start), msg


def test_lever_arm_is_checked():
    msg = refused(doc(platform={"lever_arm_m": [0.0, 2e3, 0.0]}))
    assert msg.startswith("flight.toml:platform.lever_arm_m[1]: must be in [-1000, 1000] m, got 2000.0")


@pytest.mark.parametrize("path", ["/data/imu.csv", "../imu.csv", "logs/../../imu.csv", "logs\\imu.csv", "", 3])
def test_file_path_must_be_relative_inside_the_recording(path):
    msg = refused(edit(imu__file=path))
    assert msg.startswith("flight.toml:imu.file: must be a path relative to the recording's folder"), msg


def test_file_path_is_normalised_posix():
    assert parse_manifest(edit(imu__file="logs/./imu.csv")).imu.file == "logs/imu.csv"


# ---- apertures, reference, GNSS, simulation ------------------------------------------------------------------------


def _apertures(*spans, reference=True):
    return [{"file": f"apertures/{i:04d}.cphd", "start_s": a, "end_s": b,
             **({"reference": f"reference/{i:04d}.cphd"} if reference else {})} for i, (a, b) in enumerate(spans)]


def test_apertures_in_time_order_read_in_order():
    m = parse_manifest(doc(aperture=_apertures((0.0, 0.99), (1.0, 1.99), (2.5, 3.49))))
    assert [(a.file, a.start, a.end) for a in m.apertures] == [
        ("apertures/0000.cphd", 0.0, 0.99), ("apertures/0001.cphd", 1.0, 1.99), ("apertures/0002.cphd", 2.5, 3.49)]


def test_apertures_out_of_order_or_empty_are_refused():
    assert refused(doc(aperture=_apertures((1.0, 1.99), (0.5, 1.49)))).startswith(
        "flight.toml:aperture[1].start_s: must be after the previous aperture's start 1.0 s")
    assert refused(doc(aperture=_apertures((1.0, 1.99), (1.0, 1.5)))).startswith("flight.toml:aperture[1].start_s")
    assert refused(doc(aperture=_apertures((1.0, 1.0)))).startswith(
        "flight.toml:aperture[0].end_s: must be after start_s = 1.0 s, got 1.0")
    assert refused(doc(aperture=_apertures((1.0, 0.5)))).startswith("flight.toml:aperture[0].end_s: must be in [1, ")


def test_cphd_pass_reference_names_each_apertures_pass_and_no_orthoimage_keys():
    assert refused(doc(aperture=_apertures((0.0, 0.99), reference=False))).startswith(
        "flight.toml:aperture[0].reference: missing: a 'cphd-pass' reference names each aperture's reference pass")
    for key, value in (("image", "a.tif"), ("dem", "dem.tif"), ("geolocation_sigma_m", [1.0, 1.0, 0.0]),
                       ("noise_power", 1.0)):
        assert refused(edit(**{f"reference__{key}": value})).startswith(
            f"flight.toml:reference.{key}: belongs to kind = 'orthoimage'")


def test_orthoimage_reference_reads_its_keys():
    ref = {"kind": "orthoimage", "points": "reference/points.csv", "image": "reference/all.tif",
           "dem": "reference/dem.tif", "geolocation_sigma_m": [0.3, 0.4, 0.0], "noise_power": 1e-3}
    m = parse_manifest(doc(reference=ref, aperture=_apertures((0.0, 0.99), reference=False)))
    r = m.reference
    assert (r.kind, r.points, r.image, r.dem, r.noise_power) == \
        ("orthoimage", "reference/points.csv", "reference/all.tif", "reference/dem.tif", 1e-3)
    np.testing.assert_array_equal(r.geolocation_sigma, [0.3, 0.4, 0.0])
    # each aperture naming its own tile: no image needed, the noise power estimated (None)
    del ref["image"], ref["noise_power"], ref["dem"]
    m = parse_manifest(doc(reference=ref))
    assert (m.reference.image, m.reference.dem, m.reference.noise_power) == (None, None, None)


def test_orthoimage_reference_needs_sigma_and_an_image_for_apertures_without_one():
    ref = {"kind": "orthoimage", "points": "reference/points.csv", "geolocation_sigma_m": [0.3, 0.3, 0.0]}
    assert refused(doc(reference=ref, aperture=_apertures((0.0, 0.99), reference=False))).startswith(
        "flight.toml:reference.image: missing: the orthoimage of the apertures that name no reference")
    del ref["geolocation_sigma_m"]
    assert refused(doc(reference=ref)) == "flight.toml:reference.geolocation_sigma_m: missing"
    ref["kind"] = "sicd"
    assert refused(doc(reference=ref)).startswith(
        "flight.toml:reference.kind: must be one of ['cphd-pass', 'orthoimage'], got 'sicd'")


def test_gnss_until_leaves_position_and_velocity_to_the_gnss_log():
    d = edit(initial__gnss_until_s=5.0, initial__position_ned_m=None, initial__velocity_ned_mps=None)
    assert refused(d) == "flight.toml:initial.gnss_until_s: needs a [gnss] log (gnss.file)"
    d["gnss"] = {"file": "gnss.csv"}
    ini = parse_manifest(d).initial
    assert (ini.p, ini.v, ini.gnss_until) == (None, None, 5.0)
    d["initial"]["gnss_until_s"] = -1.0  # before the initial time
    assert refused(d).startswith("flight.toml:initial.gnss_until_s: must be in [0, 1e+09] s, got -1.0")


def test_simulation_run_must_be_one_of_the_runs():
    sim = {"scenario": "rda-nav", "scenario_file": "scenario.toml", "seed": 7, "run": 4, "runs": 4,
           "noise_model_seed": 11}
    assert refused(doc(simulation=sim)) == "flight.toml:simulation.run: must be an integer in [0, 3], got 4"
    sim.update(run=0, seed=-1)
    assert refused(doc(simulation=sim)).startswith("flight.toml:simulation.seed: must be an integer in [0, ")
    sim.update(seed=0)
    assert parse_manifest(doc(simulation=sim)).simulation.sar_offsets is None


# ---- the file itself -----------------------------------------------------------------------------------------------


def test_missing_manifest_is_named(tmp_path):
    with pytest.raises(ConfigError) as err:
        read_manifest(tmp_path / "flight.toml")
    assert str(err.value).startswith("flight.toml: missing: a recording's folder holds its manifest")


def test_manifest_that_is_not_utf8_or_not_toml_is_named(tmp_path):
    path = tmp_path / "flight.toml"
    path.write_bytes(b"[recording]\ndescription = \"caf\xe9\"\n")
    with pytest.raises(ConfigError, match=r"^flight.toml: cannot read as UTF-8 text"):
        read_manifest(path)
    path.write_text("[recording]\nformat = \n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"^flight.toml: malformed TOML: .*line 2"):
        read_manifest(path)
