"""A recording written by other software (numpy, sarkit and the csv module only, following docs/recording.md) reads
back exactly: the manifest, every log, the reference points and the CPHD apertures as the extractor's pulses; bad
input is one line naming the file, the line or key and the field."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
import sarkit.wgs84 as wgs84

from cphd_writer import write_cphd
from sarnav.errors import SarnavError
from sarnav.recording import read_recording

C = 299792458.0
ORIGIN = (58.4, 15.6, 120.0)
IMU_RATE, DURATION = 100.0, 2.0
PRF, FC, BW, FS, T_P, NEAR, NR = 50.0, 9.75e9, 100e6, 120e6, 1e-6, 1950.0, 128
N_FX, SCSS = 64, 0.5e6
NOISE = 2.5
IMU_OFFSET, RADAR_OFFSET = 0.25, -0.5

MANIFEST = f"""
[recording]
format = "sarnav-recording"
version = 1
description = "written by a test with numpy, sarkit and csv"

[platform]
name = "test rig"
lever_arm_m = [0.5, 0.0, -0.25]

[time]
epoch = 2026-03-01T12:00:00Z
imu_clock_offset_s = {IMU_OFFSET}
radar_clock_offset_s = {RADAR_OFFSET}

[frame]
origin_lat_deg = {ORIGIN[0]}
origin_lon_deg = {ORIGIN[1]}
origin_height_m = {ORIGIN[2]}
earth_rotation = true

[imu]
file = "imu.csv"
samples = "rates"
body_axes = "FRD"
grade = "tactical"
gyro_bias_3sigma = 2.0
rate_hz = {IMU_RATE}
tau_accel = 600.0
tau_gyro = 900.0

[altimeter]
file = "altimeter.csv"
sigma_3sigma = 3.0
bias_3sigma = 0.3
tau = 1200.0

[radar]
carrier_ghz = 9.75
bandwidth_mhz = 100.0
sample_rate_mhz = 120.0
pulse_length_us = 1.0
prf_hz = {PRF}
antenna_length_m = 0.5
look_side = "right"
range_window = "none"
azimuth_window = "none"
near_range_m = {NEAR}
n_range_samples = {NR}
noise_power = {NOISE}

[initial]
time_s = 0.0
position_ned_m = [1.0, -2.0, -1000.0]
velocity_ned_mps = [10.0, 0.1, 0.0]
roll_pitch_yaw_deg = [1.0, -2.0, 3.0]
accel_bias_mps2 = [0.001, 0.0, 0.0]
measurement_bias_m = [0.1, 0.0, 0.0]
p_3sigma = [3.0, 3.0, 6.0]
v_3sigma = [0.3, 0.3, 0.6]
theta_3sigma = [0.003, 0.003, 0.009]
gyro_bias_3sigma = 4.0

[reference]
kind = "cphd-pass"
points = "reference/points.csv"

[[aperture]]
file = "apertures/0000.cphd"
start_s = 0.5
end_s = 1.48
reference = "reference/0000.cphd"
reference_start_s = -86400.0

[[aperture]]
file = "apertures/0001.cphd"
start_s = 1.5
end_s = 2.48
reference = "reference/0001.cphd"

[gnss]
file = "gnss.csv"

[truth]
file = "truth.csv"
"""


def ned_to_ecef(ned):
    """The local NED frame of docs/recording.md §1, written out: origin + N north + E east - D up."""
    o = wgs84.geodetic_to_cartesian(np.array(ORIGIN))
    n, e, u = (np.asarray(f(np.array(ORIGIN))) for f in (wgs84.north, wgs84.east, wgs84.up))
    ned = np.asarray(ned, dtype=np.float64)
    return o + ned[..., :1] * n + ned[..., 1:2] * e - ned[..., 2:3] * u


def write_csv(path: Path, header, rows) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def pulses_of(samples, pvp, r):
    """docs/recording.md §5: s_k(r) = exp(-j4pi f_c r/c) sum_n S_k(f_n) exp(j4pi f_n (r - R_ref,k)/c), zero where
    the delay 2 (r - R_ref,k) / c is outside [TOA1_k, TOA2_k]."""
    f = pvp["SC0"][:, None] + np.arange(samples.shape[1])[None, :] * pvp["SCSS"][:, None]
    r_ref = np.linalg.norm(pvp["TxPos"] - pvp["SRPPos"], axis=1)
    phase = np.exp(4j * np.pi * f[:, :, None] * (r[None, None, :] - r_ref[:, None, None]) / C)
    s = np.exp(-4j * np.pi * FC * r / C)[None, :] * np.einsum("kn,knm->km", samples, phase)
    delay = 2 * (r[None, :] - r_ref[:, None]) / C
    return np.where((delay >= pvp["TOA1"][:, None]) & (delay <= pvp["TOA2"][:, None]), s, 0.0)


class Flight:
    """The recording's data, drawn once; ``write(folder)`` writes it the way docs/recording.md says."""

    def __init__(self, seed=5):
        rng = np.random.default_rng(seed)
        n = int(DURATION * IMU_RATE) + 1
        self.imu_t = np.arange(n) / IMU_RATE
        self.imu = rng.standard_normal((n, 6)) * [0.1, 0.1, 0.1, 1e-3, 1e-3, 1e-3] + [0, 0, -9.81, 0, 0, 0]
        self.alt_t = np.array([1.0, 2.0])
        self.height = 1000.0 + ORIGIN[2] + rng.standard_normal(2)
        self.gnss_t = np.arange(5) * 0.5
        self.gnss_ned = np.stack([10 * self.gnss_t, 0.1 * self.gnss_t, np.full(5, -1000.0)], axis=1)
        self.truth = rng.standard_normal((21, 12))
        self.truth[:, 0] = np.arange(21) * 0.1
        self.points = rng.standard_normal((2, 2, 9)) * [1, 1, 1, 1, 1, 1, 0.1, 0.1, 0.1] + [0, 1750, 0] * 3
        self.points[..., 6:] = np.abs(self.points[..., 6:])
        self.ap = [self._aperture(rng, u) for u in range(2)]

    def _aperture(self, rng, u):
        out = {}
        for name, east in (("flight", 0.0), ("reference", 5.0)):
            P = int(PRF)
            t = (np.arange(P)) / PRF
            t_abs = 0.5 + u + t + RADAR_OFFSET
            ned = np.stack([10 * t_abs, np.full(P, east), np.full(P, -1000.0)], axis=1)
            pos = ned_to_ecef(ned)
            vel = ned_to_ecef(np.array([10.0, 0.0, 0.0])) - ned_to_ecef(np.zeros(3))
            srp = ned_to_ecef(np.array([10 * (u + 0.5), 1750.0, 0.0]))
            z = np.zeros(P)
            pvp = {"TxTime": t, "TxPos": pos, "RcvPos": pos, "TxVel": np.tile(vel, (P, 1)),
                   "RcvVel": np.tile(vel, (P, 1)), "RcvTime": t, "SRPPos": np.tile(srp, (P, 1)), "aFDOP": z,
                   "aFRR1": z, "aFRR2": z, "FX1": np.full(P, FC - N_FX / 2 * SCSS),
                   "FX2": np.full(P, FC + (N_FX / 2 - 1) * SCSS), "TOA1": np.full(P, -0.6e-6),
                   "TOA2": np.full(P, 0.6e-6), "TDTropoSRP": z, "SC0": np.full(P, FC - N_FX / 2 * SCSS),
                   "SCSS": np.full(P, SCSS)}
            samples = rng.standard_normal((P, N_FX)) + 1j * rng.standard_normal((P, N_FX))
            out[name] = dict(ned=ned, pvp=pvp, samples=samples, srp=srp, times=0.5 + u + t + RADAR_OFFSET)
        return out

    def write(self, folder: Path, manifest: str = MANIFEST) -> Path:
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "flight.toml").write_text(manifest)
        write_csv(folder / "imu.csv", ["time_s", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2", "gyro_x_radps",
                                       "gyro_y_radps", "gyro_z_radps"],
                  [[t, *row] for t, row in zip(self.imu_t - IMU_OFFSET, self.imu)])
        write_csv(folder / "altimeter.csv", ["time_s", "height_m"], zip(self.alt_t, self.height))
        llh = wgs84.cartesian_to_geodetic(ned_to_ecef(self.gnss_ned))
        write_csv(folder / "gnss.csv", ["time_s", "latitude_deg", "longitude_deg", "height_m", "sigma_north_m",
                                        "sigma_east_m", "sigma_down_m", "v_north_mps", "v_east_mps", "v_down_mps",
                                        "sigma_v_north_mps", "sigma_v_east_mps", "sigma_v_down_mps"],
                  [[t, *p, 1.5, 1.5, 3.0, 10.0, 0.1, 0.0, 0.05, 0.05, 0.1] for t, p in zip(self.gnss_t, llh)])
        write_csv(folder / "truth.csv", ["time", "north", "east", "down", "v_north", "v_east", "v_down", "roll",
                                         "pitch", "yaw", "b_alt", "gyro_bias_z"], self.truth)
        write_csv(folder / "reference/points.csv",
                  ["aperture", "point", "anchor_north_m", "anchor_east_m", "anchor_down_m", "map_north_m",
                   "map_east_m", "map_down_m", "map_sigma_north_m", "map_sigma_east_m", "map_sigma_down_m"],
                  [[u, k, *self.points[u, k]] for u in (1, 0) for k in (1, 0)])  # any row order
        o = wgs84.geodetic_to_cartesian(np.array(ORIGIN))
        for u, ap in enumerate(self.ap):
            for name, sub in (("flight", "apertures"), ("reference", "reference")):
                a = ap[name]
                (folder / sub).mkdir(exist_ok=True)
                write_cphd(folder / f"{sub}/{u:04d}.cphd", a["samples"], a["pvp"], FC, N_FX * SCSS, a["srp"],
                           np.asarray(wgs84.east(np.array(ORIGIN))), np.asarray(wgs84.north(np.array(ORIGIN))))
        assert o.shape == (3,)
        return folder


@pytest.fixture(scope="module")
def flight():
    return Flight()


@pytest.fixture(scope="module")
def recording(flight, tmp_path_factory):
    return read_recording(flight.write(tmp_path_factory.mktemp("rec") / "FLIGHT"))


def test_manifest_reads_back(recording):
    m = recording.manifest
    assert m.description.startswith("written by a test") and m.platform == "test rig"
    np.testing.assert_array_equal(m.lever_arm, [0.5, 0.0, -0.25])
    assert m.time.epoch.isoformat() == "2026-03-01T12:00:00+00:00"
    assert (m.time.imu_clock_offset, m.time.radar_clock_offset) == (IMU_OFFSET, RADAR_OFFSET)
    np.testing.assert_array_equal(m.frame.origin, ORIGIN)
    assert m.frame.earth_rotation is True
    g = m.imu.spec.grade
    assert g.name == "tactical"
    assert g.gyro_bias == pytest.approx(2.0 / 3.0 * math.pi / 180.0 / 3600.0, rel=1e-15)  # the override
    assert g.vrw == pytest.approx(0.06 / 3.0 / 60.0, rel=1e-15)  # the grade's (m/s/sqrt(hr) -> m/s/sqrt(s))
    assert (m.imu.spec.tau_accel, m.imu.spec.tau_gyro, m.imu.rate_hz) == (600.0, 900.0, IMU_RATE)
    assert (m.altimeter.sigma, m.altimeter.bias_sigma, m.altimeter.tau) == pytest.approx((1.0, 0.1, 1200.0))
    r = m.radar
    assert (r.carrier_frequency, r.bandwidth, r.sample_rate, r.pulse_length, r.prf) == pytest.approx(
        (FC, BW, FS, T_P, PRF), rel=1e-15)
    assert (r.near_range, r.n_range_samples, r.antenna_length, m.noise_power) == (NEAR, NR, 0.5, NOISE)
    ini = m.initial
    np.testing.assert_array_equal(ini.p, [1.0, -2.0, -1000.0])
    roll, pitch, yaw = np.radians([1.0, -2.0, 3.0])  # q = q_yaw (x) q_pitch (x) q_roll, scalar first
    q_expected = _quat_mul(_quat_mul([math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)],
                                     [math.cos(pitch / 2), 0, math.sin(pitch / 2), 0]),
                           [math.cos(roll / 2), math.sin(roll / 2), 0, 0])
    np.testing.assert_allclose(ini.q, q_expected, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ini.bm, [0.1, 0.0, 0.0])
    np.testing.assert_allclose(ini.sigma["p"], [1.0, 1.0, 2.0], rtol=1e-15)
    np.testing.assert_allclose(ini.sigma["bg"], 4.0 / 3.0 * math.pi / 180.0 / 3600.0, rtol=1e-15)
    np.testing.assert_allclose(ini.sigma["ba"], g.accel_bias, rtol=0)  # the grade's by default
    assert [a.start for a in m.apertures] == [0.5, 1.5] and m.apertures[0].reference_start == -86400.0


def _quat_mul(a, b):
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return [a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0]


def test_logs_read_back_exactly(recording, flight):
    np.testing.assert_array_equal(recording.imu.time, flight.imu_t - IMU_OFFSET + IMU_OFFSET)
    np.testing.assert_array_equal(np.c_[recording.imu.accel, recording.imu.gyro], flight.imu)
    np.testing.assert_array_equal(recording.altimeter.altitude, flight.height - ORIGIN[2])
    np.testing.assert_allclose(recording.gnss.position, flight.gnss_ned, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(recording.gnss.position_sigma[0], [1.5, 1.5, 3.0])
    np.testing.assert_array_equal(recording.gnss.velocity[:, 0], 10.0)
    tr = recording.truth
    np.testing.assert_array_equal(np.c_[tr.time, tr.position, tr.velocity, tr.rpy], flight.truth[:, :10])
    np.testing.assert_array_equal(tr.extra["b_alt"], flight.truth[:, 10])
    np.testing.assert_array_equal(tr.extra["gyro_bias_z"], flight.truth[:, 11])
    pts = recording.points
    np.testing.assert_array_equal(np.concatenate([pts.anchors, pts.map, pts.map_sigma], axis=2), flight.points)
    assert recording.sar_offsets is None and recording.scenario_text is None and recording.noise_model_seed == 0


def test_apertures_read_back_as_the_extractors_pulses(recording, flight):
    src = recording.source()
    axis = NEAR + np.arange(NR) * C / (2 * FS)
    for u in range(2):
        ap = flight.ap[u]
        rc, seconds = src.flight(u, 0)
        ref = src.reference(u, 0)
        f, r = ap["flight"], ap["reference"]
        np.testing.assert_allclose(rc.slant_range, axis, rtol=1e-15)  # the radar's axis
        expected = pulses_of(f["samples"], f["pvp"], axis)
        assert np.linalg.norm(rc.data - expected) / np.linalg.norm(expected) < 1e-9
        np.testing.assert_allclose(rc.pulse_times, f["times"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(rc.positions, f["ned"], rtol=0, atol=1e-6)
        assert rc.compressed and rc.wavelength == pytest.approx(C / FC, rel=1e-12) and rc.bandwidth == BW
        expected = pulses_of(r["samples"], r["pvp"], axis)
        assert np.linalg.norm(ref.pulses.data - expected) / np.linalg.norm(expected) < 1e-9
        np.testing.assert_array_equal(ref.times, rc.pulse_times)  # paired with the in-flight pulses
        np.testing.assert_array_equal(ref.pulses.pulse_times, rc.pulse_times)
        np.testing.assert_allclose(ref.positions, r["ned"], rtol=0, atol=1e-6)
        np.testing.assert_allclose(ref.velocities, np.tile([10.0, 0.0, 0.0], (int(PRF), 1)), rtol=0, atol=1e-9)
        assert ref.raw.data.shape == (int(PRF), NR) and not ref.raw.compressed
        assert (ref.raw.sample_rate, ref.raw.pulse_length) == pytest.approx((FS, T_P), rel=1e-15)
        assert ref.amplitude**2 / 10 ** (ref.snr_db / 10) == pytest.approx(NOISE, rel=1e-15)
        assert seconds >= 0


def test_increments_and_compressed_noise(tmp_path, flight):
    text = (MANIFEST.replace('samples = "rates"', 'samples = "increments"')
            .replace(f"noise_power = {NOISE}", "compressed_noise_power = 0.01"))
    folder = flight.write(tmp_path / "F")
    (folder / "flight.toml").write_text(text)
    dt = 1.0 / IMU_RATE
    write_csv(folder / "imu.csv", ["time_s", "dv_x_mps", "dv_y_mps", "dv_z_mps", "dtheta_x_rad", "dtheta_y_rad",
                                   "dtheta_z_rad"], [[t, *(row * dt)] for t, row in zip(flight.imu_t, flight.imu)])
    rec = read_recording(folder)
    t, a, g = rec.imu.rates()
    np.testing.assert_allclose(t, flight.imu_t + IMU_OFFSET - dt / 2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.c_[a, g], flight.imu, rtol=1e-9, atol=1e-15)
    # no range window: the compressed noise is the raw noise / M, M = the replica's samples (fs T + 1 here: 121)
    assert rec.manifest.noise_power == pytest.approx(0.01 * 121, rel=1e-9)


def _bad(tmp_path, flight, change):
    folder = flight.write(tmp_path / "BAD")
    change(folder)
    with pytest.raises(SarnavError) as err:
        rec = read_recording(folder)
        src = rec.source()
        for u in range(len(rec.manifest.apertures)):
            src.flight(u, 0)
    msg = str(err.value)
    assert "\n" not in msg
    return msg


def _edit(rel, old, new, count=1):
    def change(folder):
        p = folder / rel
        text = p.read_text()
        assert old in text, old
        p.write_text(text.replace(old, new, count))
    return change


def _rows(rel, fn):
    def change(folder):
        p = folder / rel
        rows = list(csv.reader(open(p)))
        fn(rows)
        write_csv(p, rows[0], rows[1:])
    return change


def _swap(rows):
    rows[11][0], rows[12][0] = rows[12][0], rows[11][0]


def _dup(rows):
    rows[12][0] = rows[11][0]


def _nan(rows):
    rows[6][5] = "nan"


@pytest.mark.parametrize("change, expected", [
    (_edit("flight.toml", f"rate_hz = {IMU_RATE}\n", ""), "flight.toml:imu.rate_hz: missing"),
    (_edit("flight.toml", "rate_hz =", "rate ="), "flight.toml:imu.rate: unknown key (known: file,"),
    (_edit("flight.toml", f"rate_hz = {IMU_RATE}", "rate_hz = -100.0"), "flight.toml:imu.rate_hz: must be"),
    (_edit("flight.toml", 'grade = "tactical"', 'grade = "superb"'), "flight.toml:imu.grade: must be one of"),
    (_edit("flight.toml", 'body_axes = "FRD"', 'body_axes = "ENU"'), "flight.toml:imu.body_axes: must be 'FRD'"),
    (_edit("flight.toml", "[time]\nepoch = 2026-03-01T12:00:00Z", "[time]\nepoch = 2026-03-01T12:00:00"),
     "flight.toml:time.epoch: must be a date-time with its UTC offset"),
    (_edit("flight.toml", "start_s = 1.5", "start_s = 0.4"), "flight.toml:aperture[1].start_s: must be after"),
    (_edit("flight.toml", 'file = "imu.csv"', 'file = "../imu.csv"'), "flight.toml:imu.file: must be a path"),
    (_edit("flight.toml", 'reference = "reference/0001.cphd"', 'reference = "reference/9999.cphd"'),
     "flight.toml:aperture[1].reference: 'reference/9999.cphd' is not a file"),
    (_edit("flight.toml", "[[aperture]]", "[[apertures]]"), "flight.toml:apertures: unknown key"),
    (_rows("imu.csv", _swap), "imu.csv:13:time_s: -0.15 is earlier than -0.14 on line 12 (rows must be sorted"),
    (_rows("imu.csv", _dup), "imu.csv:13:time_s: duplicates the time -0.15 of line 12"),
    (_rows("imu.csv", _nan), "imu.csv:7:gyro_y_radps: must be finite, got nan"),
    (_rows("imu.csv", lambda rows: rows[0].__setitem__(1, "accel_x_g")),
     "imu.csv:1:accel_x_g: unknown column (known: time_s, accel_x_mps2,"),
    (_rows("imu.csv", lambda rows: rows[3].pop()), "imu.csv:4: has 6 fields, the header 7"),
    (_rows("imu.csv", lambda rows: rows[3].__setitem__(2, "1,5")), "imu.csv:4:accel_y_mps2: must be a number, got '1,5'"),
    (_rows("altimeter.csv", lambda rows: rows[0].append("altitude_m") or [r.append("1.0") for r in rows[1:]]),
     "altimeter.csv:1: must have exactly one of the column sets (altitude_m) or (height_m)"),
    (_rows("reference/points.csv", lambda rows: rows.pop(1)),
     "reference/points.csv:point: aperture 1 has points [0]; every aperture needs points 0 to 1"),
    (_rows("gnss.csv", lambda rows: rows[2].__setitem__(5, "0")), "gnss.csv:3:sigma_east_m: must be > 0"),
    (lambda folder: (folder / "truth.csv").unlink(), "truth.csv: missing file"),
])
def test_bad_input_is_one_line_naming_file_and_field(tmp_path, flight, change, expected):
    msg = _bad(tmp_path, flight, change)
    assert msg.startswith(expected), msg


def test_an_aperture_of_the_wrong_length_is_named(tmp_path, flight):
    def change(folder):
        a = flight.ap[1]["flight"]
        pvp = {k: v[:-1] for k, v in a["pvp"].items()}
        write_cphd(folder / "apertures/0001.cphd", a["samples"][:-1], pvp, FC, N_FX * SCSS, a["srp"],
                   np.asarray(wgs84.east(np.array(ORIGIN))), np.asarray(wgs84.north(np.array(ORIGIN))))
    msg = _bad(tmp_path, flight, change)
    assert msg.startswith("apertures/0001.cphd: has 49 pulses; an aperture is one second of the radar's pulses, "
                          "round(radar.prf_hz) = 50"), msg


def test_a_carrier_that_is_not_the_radars_is_named(tmp_path, flight):
    msg = _bad(tmp_path, flight, _edit("flight.toml", "carrier_ghz = 9.75", "carrier_ghz = 9.6"))
    assert msg.startswith("apertures/0000.cphd:Channel.Parameters.FxC: carrier 9.75e+09 Hz"), msg


def test_missing_manifest_is_named(tmp_path):
    tmp_path.joinpath("EMPTY").mkdir()
    with pytest.raises(SarnavError, match=r"^flight.toml: missing"):
        read_recording(tmp_path / "EMPTY")


def test_initial_state_from_gnss(tmp_path, flight):
    """With ``gnss_until_s`` the initial position and velocity may be left to the GNSS fixes; without a GNSS log the
    key is refused."""
    text = (MANIFEST.replace("position_ned_m = [1.0, -2.0, -1000.0]\nvelocity_ned_mps = [10.0, 0.1, 0.0]\n",
                             "gnss_until_s = 1.5\n"))
    folder = flight.write(tmp_path / "G", text)
    ini = read_recording(folder).manifest.initial
    assert ini.gnss_until == 1.5 and ini.p is None and ini.v is None
    (folder / "flight.toml").write_text(text.replace('[gnss]\nfile = "gnss.csv"\n', ""))
    with pytest.raises(SarnavError, match=r"^flight.toml:initial.gnss_until_s: needs a \[gnss\] log"):
        read_recording(folder)
    (folder / "flight.toml").write_text(text.replace("gnss_until_s = 1.5\n", ""))
    with pytest.raises(SarnavError, match=r"^flight.toml:initial.position_ned_m: missing"):
        read_recording(folder)
