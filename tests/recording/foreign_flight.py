"""A recorded flight written by "other software": numpy, sarkit (through ``cphd_writer``) and ``csv`` only, following
docs/recording.md. No sarnav code is imported here: the world, the sensors' errors, the echoes and the unit
conversions are written out from the document.

The flight: straight and level towards north at about 9.5 m/s and 1000 m, its speed varying by 0.2 m/s with a 10-s
period (so that the specific force varies and the IMU's sample times matter); a custom IMU (errors drawn from the
manifest's own 3-sigma figures) sampled at 100 Hz with +-10 % jitter, a few single dropped samples and a 0.5-s gap;
an altimeter at each whole second; GNSS fixes (position and velocity) for the first 5 s, the initial position and
velocity taken from the first; one point scatterer on the ground per 1-s aperture about 1.8 km to the right; the
in-flight pulses echoed from the true track, the reference pass 20 m to the left along a trusted track. ``MAP_SIGMA``
is the 1-sigma of an error in the reference pass's stated positions (its image, and so the point's anchor and map
position, move with it; docs/recording.md §6): 0.3 m here, stated in the manifest as the product's
geolocation 1-sigma; the reference pass's data are compensated along its stated (erroneous) track, as a radar
does. The radar and IMU clocks are offset from the recording time.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import sarkit.wgs84 as wgs84

from cphd_writer import write_cphd

C = 299792458.0
G = 9.81  # the unit "g" of the manifest's accel_bias_3sigma and the navigator's gravity (docs/recording.md §1)
ORIGIN = (45.0, 7.0, 300.0)
IMU_RATE = 100.0
IMU_OFFSET, RADAR_OFFSET = -0.125, 0.25  # recording time = clock + offset
SPEED, SPEED_VAR, PERIOD, HEIGHT = 9.5, 0.2, 10.0, 1000.0
FC, BW, FS, PRF = 9.75e9, 500e6, 1000e6, 100.0
NEAR, N_RANGE = 1919.3, 2458
N_FX = 1250
SCSS = BW / N_FX
GROUND_EAST, REF_ASIDE = 1800.0, -20.0
AMPLITUDE, COMPRESSED_NOISE = 1.0, 1.0
# custom IMU, 3-sigma figures in the manifest's units
VRW3, ACC_B3, ARW3, GYR_B3 = 0.05, 0.003, 0.05, 3.0  # m/s/sqrt(hr), g, deg/sqrt(hr), deg/hr
ALT_SIGMA3, ALT_BIAS3 = 3.0, 0.3
GNSS_SIGMA, GNSS_VSIGMA = np.array([1.5, 1.5, 3.0]), np.array([0.05, 0.05, 0.1])
MAP_SIGMA = 0.3
P3, V3, TH3 = (3.0, 3.0, 6.0), (0.3, 0.3, 0.5), (0.002, 0.002, 0.006)


def truth_at(t):
    """Position (N, 3), velocity (N, 3) and specific force (N, 3) (NED = body: level, heading north) at times t."""
    t = np.asarray(t, dtype=np.float64)
    w = 2.0 * math.pi / PERIOD
    n = SPEED * t + SPEED_VAR / w * (1.0 - np.cos(w * t))
    z = np.zeros_like(t)
    p = np.stack([n, z, z - HEIGHT], axis=-1)
    v = np.stack([SPEED + SPEED_VAR * np.sin(w * t), z, z], axis=-1)
    f = np.stack([SPEED_VAR * w * np.cos(w * t), z, z - G], axis=-1)
    return p, v, f


def ned_to_ecef(ned):
    o = wgs84.geodetic_to_cartesian(np.array(ORIGIN))
    n, e, u = (np.asarray(f(np.array(ORIGIN))) for f in (wgs84.north, wgs84.east, wgs84.up))
    ned = np.asarray(ned, dtype=np.float64)
    return o + ned[..., :1] * n + ned[..., 1:2] * e - ned[..., 2:3] * u


def write_csv(path: Path, header, rows) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows([[repr(float(x)) if not isinstance(x, (int, np.integer)) else int(x) for x in row] for row in rows])


def _imu(rng, duration, gap):
    """Jittered sample times on the recording clock (a 0.5-s gap and three single dropped samples) and the IMU's
    output at them: truth + bias + white noise of the manifest's figures."""
    dt = 1.0 / IMU_RATE
    k = np.arange(int(round((duration + 0.5) * IMU_RATE)) + 1)
    t = k * dt + rng.uniform(-0.1, 0.1, k.size) * dt
    t[0] = 0.0
    keep = ~((t > gap[0]) & (t < gap[1]))
    for drop in rng.choice(np.arange(150, k.size - 10), 3, replace=False):
        keep[drop] = False
    t = t[keep]
    _, _, f = truth_at(t)
    accel_bias = rng.standard_normal(3) * ACC_B3 / 3.0 * G
    gyro_bias = rng.standard_normal(3) * math.radians(GYR_B3 / 3.0) / 3600.0
    vrw, arw = VRW3 / 3.0 / 60.0, math.radians(ARW3 / 3.0) / 60.0  # per sqrt(s)
    accel = f + accel_bias + rng.standard_normal(f.shape) * vrw / math.sqrt(dt)
    gyro = gyro_bias + rng.standard_normal(f.shape) * arw / math.sqrt(dt)
    return t, accel, gyro, accel_bias, gyro_bias


def _phase_history(rng, pos, srp, target, stated=None):
    """FX samples of one point scatterer echoed at the antenna positions ``pos``, SGN = -1 (docs/recording.md §5),
    + white noise of COMPRESSED_NOISE / N per sample (the formed pulse sums N samples); the PVPs. ``stated``: the
    positions the radar believes and the file states (default ``pos``): the data are compensated to the SRP along
    them, as a radar does with its own positions."""
    stated = pos if stated is None else stated
    P = pos.shape[0]
    f = FC - BW / 2 + SCSS * np.arange(N_FX)
    r_t = np.linalg.norm(pos - target, axis=1)
    r_ref = np.linalg.norm(stated - srp, axis=1)
    samples = AMPLITUDE / N_FX * np.exp(-2j * math.pi * f[None] * 2.0 * (r_t - r_ref)[:, None] / C)
    samples += math.sqrt(COMPRESSED_NOISE / N_FX / 2.0) * (rng.standard_normal(samples.shape)
                                                         + 1j * rng.standard_normal(samples.shape))
    far = NEAR + (N_RANGE - 1) * C / (2.0 * FS)
    zeros = np.zeros(P)
    pvp = {"TxTime": np.arange(P) / PRF, "TxPos": stated, "RcvPos": stated, "RcvTime": np.arange(P) / PRF,
           "SRPPos": np.tile(srp, (P, 1)), "aFDOP": zeros, "aFRR1": zeros, "aFRR2": zeros,
           "FX1": np.full(P, f[0]), "FX2": np.full(P, f[-1]), "TOA1": 2.0 * (NEAR - r_ref) / C,
           "TOA2": 2.0 * (far - r_ref) / C, "TDTropoSRP": zeros, "SC0": np.full(P, f[0]), "SCSS": np.full(P, SCSS)}
    return samples, pvp


ORTHO_NOISE, ORTHO_SPACING, ORTHO_HALF = 1e-3, 0.1, 30.0  # noise power per pixel, pixel [m], tile half-size [m]


def write_orthoimage(path: Path, centre, rng) -> None:
    """A GeoTIFF orthoimage tile (docs/recording.md §6b) written with rasterio, EPSG:4326, north-up: the amplitude of
    the radar's point-target response where the product puts the point (``centre``, NED), |sinc(dn / rho_a)
    sinc(de / rho_g)| with the azimuth and ground-range resolutions of the flight, plus complex noise of
    ORTHO_NOISE per pixel."""
    import rasterio
    from rasterio.transform import from_origin

    slant = math.hypot(GROUND_EAST, HEIGHT)
    rho_g, rho_a = C / (2 * BW) * slant / GROUND_EAST, C / FC * slant / (2 * SPEED * 1.0)
    n_pix = int(round(2 * ORTHO_HALF / ORTHO_SPACING))
    corner = ned_to_ecef(np.array([centre[0] + ORTHO_HALF, centre[1] - ORTHO_HALF, 0.0]))
    lat0, lon0, _ = wgs84.cartesian_to_geodetic(corner)
    step_n = ned_to_ecef(np.array([centre[0] + ORTHO_HALF - ORTHO_SPACING, centre[1] - ORTHO_HALF, 0.0]))
    step_e = ned_to_ecef(np.array([centre[0] + ORTHO_HALF, centre[1] - ORTHO_HALF + ORTHO_SPACING, 0.0]))
    dlat = lat0 - wgs84.cartesian_to_geodetic(step_n)[0]
    dlon = wgs84.cartesian_to_geodetic(step_e)[1] - lon0
    rows, cols = np.meshgrid(np.arange(n_pix) + 0.5, np.arange(n_pix) + 0.5, indexing="ij")
    llh = np.stack([lat0 - rows * dlat, lon0 + cols * dlon, np.zeros_like(rows)], axis=-1)
    ecef = wgs84.geodetic_to_cartesian(llh)
    o = np.array(ORIGIN)
    basis = np.stack([np.asarray(f(o)) for f in (wgs84.north, wgs84.east, wgs84.up)])
    rel = (ecef - wgs84.geodetic_to_cartesian(o)) @ basis.T - [centre[0], centre[1], 0.0]
    amp = np.sinc(rel[..., 0] / rho_a) * np.sinc(rel[..., 1] / rho_g)
    noise = math.sqrt(ORTHO_NOISE / 2) * (rng.standard_normal(amp.shape) + 1j * rng.standard_normal(amp.shape))
    values = np.abs(amp + noise).astype(np.float32)
    with rasterio.open(path, "w", driver="GTiff", width=n_pix, height=n_pix, count=1, dtype="float32",
                       crs="EPSG:4326", transform=from_origin(lon0, lat0, dlon, dlat), nodata=float("nan")) as f:
        f.write(values, 1)


class ForeignFlight:
    """One flight of ``duration`` s drawn from ``seed``; ``write(folder)`` writes its recording."""

    def __init__(self, seed: int, duration: int = 12, gnss_until: float = 5.0, gap=(7.2, 7.7),
                 reference: str = "cphd-pass"):
        rng = np.random.default_rng(seed)
        self.duration, self.gnss_until, self.reference = duration, gnss_until, reference
        self.imu_t, self.accel, self.gyro, self.accel_bias, self.gyro_bias = _imu(rng, duration, gap)
        self.alt_t = np.arange(1, duration + 1, dtype=np.float64)
        self.alt_bias = rng.standard_normal() * ALT_BIAS3 / 3.0
        p, _, _ = truth_at(self.alt_t)
        self.altitude = -p[:, 2] + self.alt_bias + rng.standard_normal(self.alt_t.size) * ALT_SIGMA3 / 3.0
        self.gnss_t = np.arange(0.0, gnss_until + 0.5, 1.0)
        gp, gv, _ = truth_at(self.gnss_t)
        self.gnss_p = gp + rng.standard_normal(gp.shape) * GNSS_SIGMA
        self.gnss_v = gv + rng.standard_normal(gv.shape) * GNSS_VSIGMA
        self.theta0 = rng.standard_normal(3) * np.array(TH3) / 3.0  # initial attitude error (small angles)
        self.apertures = [self._aperture(rng, u) for u in range(duration)]

    def _aperture(self, rng, u):
        times = u + np.arange(int(PRF)) / PRF  # recording time of each pulse
        p_mid, _, _ = truth_at(np.array([u + 0.5]))
        target = np.array([p_mid[0, 0] + rng.uniform(-3.0, 3.0), GROUND_EAST + rng.uniform(-20.0, 20.0), 0.0])
        geo = rng.standard_normal(3) * MAP_SIGMA  # the reference pass's position error: its product's geolocation
        if self.reference == "orthoimage":
            geo[2] = 0.0  # the product's heights are the flat ground's, exactly
        srp = ned_to_ecef(np.array([p_mid[0, 0], GROUND_EAST, 0.0]))
        out = {"times": times, "target": target, "map": target + geo}
        for name, aside, stated in (("flight", 0.0, np.zeros(3)), ("reference", REF_ASIDE, geo)):
            ned, vel, _ = truth_at(times)
            ned = ned + [0.0, aside, 0.0]
            samples, pvp = _phase_history(rng, ned_to_ecef(ned), srp, ned_to_ecef(target), ned_to_ecef(ned + stated))
            ecef_v = ned_to_ecef(vel) - ned_to_ecef(np.zeros(3))
            pvp["TxVel"] = pvp["RcvVel"] = ecef_v
            out[name] = (samples, pvp, srp)
        return out

    def manifest(self) -> str:
        aps = "".join(f"""
[[aperture]]
file = "apertures/{u:04d}.cphd"
start_s = {u - RADAR_OFFSET!r}
end_s = {u + 0.99 - RADAR_OFFSET!r}
reference = "reference/{u:04d}.{'cphd' if self.reference == 'cphd-pass' else 'tif'}"
""" for u in range(self.duration))
        roll, pitch, yaw = (math.degrees(a) for a in self.theta0)
        return f"""
[recording]
format = "sarnav-recording"
version = 1
description = "a foreign test flight (numpy, sarkit, csv)"

[time]
epoch = 2026-06-01T08:00:00Z
imu_clock_offset_s = {IMU_OFFSET!r}
radar_clock_offset_s = {RADAR_OFFSET!r}

[frame]
origin_lat_deg = {ORIGIN[0]!r}
origin_lon_deg = {ORIGIN[1]!r}
origin_height_m = {ORIGIN[2]!r}
earth_rotation = false

[imu]
file = "imu.csv"
samples = "rates"
grade = "custom"
vrw_3sigma = {VRW3!r}
accel_bias_3sigma = {ACC_B3!r}
arw_3sigma = {ARW3!r}
gyro_bias_3sigma = {GYR_B3!r}
rate_hz = {IMU_RATE!r}
tau_accel = 3600.0
tau_gyro = 3600.0

[altimeter]
file = "altimeter.csv"
sigma_3sigma = {ALT_SIGMA3!r}
bias_3sigma = {ALT_BIAS3!r}
tau = 3600.0

[radar]
carrier_ghz = {FC / 1e9!r}
bandwidth_mhz = {BW / 1e6!r}
sample_rate_mhz = {FS / 1e6!r}
pulse_length_us = 1.0
prf_hz = {PRF!r}
antenna_length_m = 0.2
look_side = "right"
range_window = "none"
azimuth_window = "none"
near_range_m = {NEAR!r}
n_range_samples = {N_RANGE}
compressed_noise_power = {COMPRESSED_NOISE!r}

[initial]
time_s = 0.0
roll_pitch_yaw_deg = [{roll!r}, {pitch!r}, {yaw!r}]
p_3sigma = [{P3[0]!r}, {P3[1]!r}, {P3[2]!r}]
v_3sigma = [{V3[0]!r}, {V3[1]!r}, {V3[2]!r}]
theta_3sigma = [{TH3[0]!r}, {TH3[1]!r}, {TH3[2]!r}]
gnss_until_s = {self.gnss_until!r}

[gnss]
file = "gnss.csv"

[truth]
file = "truth.csv"

{self._reference_table()}
{aps}"""

    def _reference_table(self) -> str:
        if self.reference == "cphd-pass":
            return '[reference]\nkind = "cphd-pass"\npoints = "reference/points.csv"\n'
        return ('[reference]\nkind = "orthoimage"\npoints = "reference/points.csv"\n'
                f'geolocation_sigma_m = [{MAP_SIGMA!r}, {MAP_SIGMA!r}, 0.0]\nnoise_power = {ORTHO_NOISE!r}\n')

    def write(self, folder: Path) -> Path:
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "flight.toml").write_text(self.manifest())
        write_csv(folder / "imu.csv", ["time_s", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2", "gyro_x_radps",
                                       "gyro_y_radps", "gyro_z_radps"],
                  [[t - IMU_OFFSET, *a, *g] for t, a, g in zip(self.imu_t, self.accel, self.gyro)])
        write_csv(folder / "altimeter.csv", ["time_s", "altitude_m"], zip(self.alt_t, self.altitude))
        write_csv(folder / "gnss.csv", ["time_s", "north_m", "east_m", "down_m", "sigma_north_m", "sigma_east_m",
                                        "sigma_down_m", "v_north_mps", "v_east_mps", "v_down_mps", "sigma_v_north_mps",
                                        "sigma_v_east_mps", "sigma_v_down_mps"],
                  [[t, *p, *GNSS_SIGMA, *v, *GNSS_VSIGMA] for t, p, v in zip(self.gnss_t, self.gnss_p, self.gnss_v)])
        tt = np.arange(0, int(round((self.duration + 0.5) * 100)) + 1) / 100.0  # as long as the IMU log
        p, v, _ = truth_at(tt)
        zero = np.zeros(tt.size)
        write_csv(folder / "truth.csv", ["time", "north", "east", "down", "v_north", "v_east", "v_down", "roll",
                                         "pitch", "yaw", "accel_bias_x", "accel_bias_y", "accel_bias_z",
                                         "gyro_bias_x", "gyro_bias_y", "gyro_bias_z", "b_alt", "b_range", "b_cross"],
                  np.column_stack([tt, p, v, zero, zero, zero, np.tile(self.accel_bias, (tt.size, 1)),
                                   np.tile(self.gyro_bias, (tt.size, 1)), np.full(tt.size, self.alt_bias), zero,
                                   zero]))
        write_csv(folder / "reference/points.csv",
                  ["aperture", "point", "anchor_north_m", "anchor_east_m", "anchor_down_m", "map_north_m",
                   "map_east_m", "map_down_m", "map_sigma_north_m", "map_sigma_east_m", "map_sigma_down_m"],
                  [[u, 0, *ap["map"], *ap["map"], *([MAP_SIGMA] * 3 if self.reference == "cphd-pass" else [0.0] * 3)]
                   for u, ap in enumerate(self.apertures)])
        if self.reference == "orthoimage":
            for u, ap in enumerate(self.apertures):
                write_orthoimage(folder / f"reference/{u:04d}.tif", ap["map"], np.random.default_rng([u, 7]))
        uiax, uiay = (np.asarray(f(np.array(ORIGIN))) for f in (wgs84.east, wgs84.north))
        for u, ap in enumerate(self.apertures):
            for name, sub in (("flight", "apertures"), ("reference", "reference"))[
                    :2 if self.reference == "cphd-pass" else 1]:
                samples, pvp, srp = ap[name]
                (folder / sub).mkdir(exist_ok=True)
                write_cphd(folder / f"{sub}/{u:04d}.cphd", samples, pvp, FC, BW, srp, uiax, uiay, fmt="CF8")
        return folder
