"""``sarnav export``: run K of an rda-nav campaign written as a flight recording (docs/recording.md §8).

The run is flown by the experiment itself (``simulation.rda_nav.run`` with an observer), so the recording holds
exactly what the campaign's navigator was handed: the IMU samples of the truth sensor, errors included (the blocks of
``ErrorStateFlight``); the altimeter measurements it fused; every aperture's in-flight acquisition (range compressed,
with the run's receiver noise) and the reference pass's, as CPHD (CF16: the round trip is within -180 dB); the
reference points (anchors: the true targets the reference chips are cut around; map: the run's map, with the map's
geolocation 1-sigma); the corrupted initial estimate the navigator starts from and its 3-sigma; the receiver noise
power; the truth at the campaign's output epochs. What reproducing the run needs beyond the sensor data goes to the
manifest's ``[simulation]`` table: the scenario (``scenario.toml``: the navigator's settings), the campaign seed and
run, the extractor's noise-model seed (the scenario's ``scene.seed``) and ``sar_offsets.csv`` (the truth biases and
any white noise the world added to each image-derived range and cross-range).
"""

from __future__ import annotations

import datetime
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError
from sarnav.io.cphd import write_collect
from sarnav.record import RunRecord
from sarnav.recording.logs import IMU_COLUMNS, OFFSET_COLUMNS, POINT_COLUMNS, TRUTH_COLUMNS, TRUTH_EXTRA
from sarnav.recording.manifest import FORMAT, FORMAT_VERSION, REFERENCE_KINDS
from sarnav.recording.tables import write_columns
from sarnav.rotations import dcm_to_euler, quat_to_dcm
from sarnav.sensors.imu import IMU_GRADES
from sarnav.signal.windows import Window
from sarnav.simulation import rda_nav, rda_nav_world
from sarnav.simulation.export_ortho import geolocation_errors, horizontal, write_dem, write_ortho_tile
from sarnav.tomlio import dump_toml

__all__ = ["export_rda_nav", "check_exportable", "prepare_folder", "Export", "EXPORT_KINDS", "RECORDING_FILES", "DEFAULT_EPOCH",
           "DEFAULT_ORIGIN"]

#: the scenario kinds a recording can be written of
EXPORT_KINDS = ("rda-nav",)
#: what an export writes (globs in the recording's folder): all that ``prepare_folder`` removes with ``overwrite``
RECORDING_FILES = ("flight.toml", "flight.toml.partial", "imu.csv", "altimeter.csv", "truth.csv", "gnss.csv", "sar_offsets.csv",
                   "scenario.toml", "apertures/*.cphd", "reference/*.cphd", "reference/*.tif", "reference/points.csv")

#: the recording's time 0 (the simulated flight's t = 0) and the NED origin of a non-rotating world (lat, lon, h)
DEFAULT_EPOCH = datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc)
DEFAULT_ORIGIN = (40.0, 0.0, 0.0)


@dataclass
class Export:
    """What :func:`export_rda_nav` wrote: the folder, the files (relative), and the run's record of the campaign
    (its estimate's error, 1-sigma, NEES, residuals: what navigating the recording must give again)."""

    folder: Path
    files: list = field(default_factory=list)
    record: RunRecord | None = None


def export_rda_nav(prm: rda_nav.RdaNavParams, out, seed: np.random.SeedSequence, *, run: int, runs: int,
                   campaign_seed: int, scenario_name: str, scenario_text: str,
                   epoch: datetime.datetime = DEFAULT_EPOCH, reference: str = "cphd-pass", progress=None) -> Export:
    """Fly run ``run`` (its seed ``seed``: ``montecarlo.seeding.run_seeds(campaign_seed, runs)[run]``) and write it
    to the folder ``out`` as a recording (module docstring). ``scenario_text``: the scenario as TOML. ``reference``:
    "cphd-pass" (reference (a)) or "orthoimage" (reference (b), ``simulation.export_ortho``). ``progress(u, n)``:
    called after each of the n intervals is written (the CLI's progress line)."""
    check_exportable(prm)
    if reference not in REFERENCE_KINDS:
        raise ConfigError("--reference", f"must be one of {list(REFERENCE_KINDS)}, got {reference!r}")
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    rec = _Recorder(prm, folder, epoch)
    rec.progress = progress
    if reference == "orthoimage":
        rec.ortho = geolocation_errors(seed, prm.n_updates, prm.scene["geolocation_sigma"])
    record = rda_nav.run(prm, [seed], [run], observer=rec)[0]
    (folder / "scenario.toml").write_text(scenario_text, encoding="utf-8")
    sim = {"scenario": scenario_name, "scenario_file": "scenario.toml", "seed": int(campaign_seed), "run": int(run),
           "runs": int(runs), "noise_model_seed": int(prm.scene["seed"])}
    files = rec.finish(sim) + ["scenario.toml"]
    return Export(folder, sorted(files), record)


def check_exportable(prm: rda_nav.RdaNavParams) -> None:
    """Refuse what a recording cannot hold (ConfigError naming the key): SAR measurements synthesised from the truth
    (``sar.measurement = "oracle"``)."""
    if prm.sar_enabled and prm.measurement != "image":
        raise ConfigError("sar.measurement", "a recording holds the radar's pulses: export needs 'image' (the oracle "
                          f"makes its measurements from the truth), got {prm.measurement!r}")


def prepare_folder(out, overwrite: bool = False, files=RECORDING_FILES, what: str = "a recording") -> Path:
    """The folder ``out``, created; one that holds files already is refused (ConfigError ``--out``) unless
    ``overwrite``, which removes the files matching the globs ``files`` (default a recording's,
    :data:`RECORDING_FILES`) and keeps anything else; ``what``: what ``--overwrite`` replaces (the message)."""
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise ConfigError("--out", f"{str(folder)!r} is a file, not a folder")
    if folder.is_dir() and any(folder.iterdir()):
        if not overwrite:
            raise ConfigError("--out", f"{str(folder)!r} is not empty (--overwrite replaces {what} there)")
        for pattern in files:
            for f in folder.glob(pattern):
                if f.is_file():
                    f.unlink()
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _origin(prm) -> tuple[float, float, float]:
    """The NED origin: on a rotating Earth at the latitude of its rate (omega_ie^t = Omega [cos lat, 0, -sin lat])."""
    if prm.earth_rate is None:
        return DEFAULT_ORIGIN
    w = np.asarray(prm.earth_rate, dtype=np.float64)
    return (math.degrees(math.atan2(-w[2], w[0])), DEFAULT_ORIGIN[1], DEFAULT_ORIGIN[2])


class _Recorder:
    """The observer of ``rda_nav.run``: keeps the IMU blocks, altimeter values and truth, writes each aperture's CPHD
    files as the run reaches it."""

    def __init__(self, prm, folder: Path, epoch):
        self.prm, self.folder, self.epoch = prm, folder, epoch
        self.origin = _origin(prm)
        self.imu, self.bias, self.alt, self.apertures, self.points, self.offsets = [], [], [], [], [], []
        self.files: list[str] = []
        self.ortho = None  # reference (b): (U, 3) each tile's geolocation error
        self.progress = None  # progress(u, n) after each interval

    def start(self, fl, sar) -> None:
        if fl.R != 1:
            raise ConfigError("runs", f"a recording is one run, the flight has {fl.R}")
        self.fl, self.sar = fl, sar
        nav = fl.navigator.nav
        self.initial = (nav.p[0].copy(), nav.v[0].copy(), nav.q[0].copy(), nav.ba[0].copy(), nav.bg[0].copy(),
                        nav.bm[0].copy(), np.asarray(fl.spec.p0_sigma, dtype=np.float64))
        if sar is not None:
            sar.imager.source = _Tap(sar.imager.source)

    def interval(self, u: int, fl, z_alt, sar) -> None:
        self._interval(u, fl, z_alt, sar)
        if self.progress is not None:
            self.progress(u, self.prm.n_updates)

    def _interval(self, u: int, fl, z_alt, sar) -> None:
        t, nu, om, ba, bg = fl.imu_block
        first = 0 if u == 0 else 1  # a block starts with the previous block's last sample
        self.imu.append((t[first:], nu[0, first:], om[0, first:]))
        k0 = 0 if u == 0 else fl.c  # the truth biases at the output epochs (every c-th sample)
        self.bias.append((ba[0, k0::fl.c], bg[0, k0::fl.c]))
        self.alt.append((fl.t_out[fl.j], float(z_alt[0, 0])))
        if sar is not None:
            self._aperture(u, sar)

    def _aperture(self, u: int, sar) -> None:
        ref, (rc, _) = sar.imager.source.last[u]
        targets = sar.targets[u]
        names = (f"apertures/{u:04d}.cphd", f"reference/{u:04d}.cphd")
        passes = zip(names, (rc, ref.pulses), (None, ref.velocities))  # the trusted velocities
        if self.ortho is not None:  # reference (b): the pass imaged on the ground instead of its pulses
            names = (names[0], f"reference/{u:04d}.tif")
            (self.folder / "reference").mkdir(exist_ok=True)
            write_ortho_tile(self.folder / names[1], ref, targets, self.origin, rda_nav_world.terrain_of(self.prm),
                             self.ortho[u])
            passes = [(names[0], rc, None)]
        for rel, pulses, vel in passes:
            (self.folder / rel).parent.mkdir(exist_ok=True)
            start = self.epoch + datetime.timedelta(seconds=float(pulses.pulse_times[0]))
            write_collect(self.folder / rel, pulses, self.origin, signal_format="CF16",
                          scene_point=targets.mean(axis=0), collection_start=start, velocities=vel)
        times = rc.pulse_times
        self.apertures.append({"file": names[0], "start_s": float(times[0]), "end_s": float(times[-1]),
                               "reference": names[1], "reference_start_s": float(ref.pulses.pulse_times[0])})
        if self.ortho is not None:
            del self.apertures[-1]["reference_start_s"]
        sigma = np.asarray(self.prm.scene["geolocation_sigma"], dtype=np.float64)
        for k in range(targets.shape[0]):
            if self.ortho is not None:  # where the product puts the point is the map; its sigma is the manifest's
                self.points.append([u, k, *(targets[k] + self.ortho[u]), *(targets[k] + self.ortho[u]), 0, 0, 0])
            else:
                self.points.append([u, k, *targets[k], *sar.map[0, u, k], *sigma])
            self.offsets.append([u, k, *sar.added[0, k]])
        self.files += list(names)

    def finish(self, simulation: dict) -> list[str]:
        """Write the logs and the manifest; the files written (relative)."""
        t = np.concatenate([b[0] for b in self.imu])
        nu = np.concatenate([b[1] for b in self.imu])
        om = np.concatenate([b[2] for b in self.imu])
        write_columns(self.folder / "imu.csv", dict(zip(IMU_COLUMNS["rates"], [t, *nu.T, *om.T])))
        alt = np.array(self.alt)
        write_columns(self.folder / "altimeter.csv", {"time_s": alt[:, 0], "altitude_m": alt[:, 1]})
        self._truth()
        self.files += ["flight.toml", "imu.csv", "altimeter.csv", "truth.csv"]
        if self.apertures:
            for rel, rows, names in (("reference/points.csv", self.points, POINT_COLUMNS),
                                     ("sar_offsets.csv", self.offsets, OFFSET_COLUMNS)):
                index = np.array([r[:2] for r in rows], dtype=np.int64)  # aperture, point: integers
                values = np.array([r[2:] for r in rows], dtype=np.float64)
                write_columns(self.folder / rel, dict(zip(names, [*index.T, *values.T])))
            simulation["sar_offsets"] = "sar_offsets.csv"
            self.files += ["reference/points.csv", "sar_offsets.csv"]
        # the manifest last, whole or not at all: an interrupted export has no flight.toml and never reads as a
        # recording (read_recording: "flight.toml: missing")
        part = self.folder / "flight.toml.partial"
        part.write_text(dump_toml(self._manifest(simulation)), encoding="utf-8")
        part.replace(self.folder / "flight.toml")
        return self.files

    def _truth(self) -> None:
        fl = self.fl
        tr = fl.truth_out
        roll, pitch, yaw = dcm_to_euler(quat_to_dcm(tr.quaternion))
        ba = np.concatenate([b[0] for b in self.bias])
        bg = np.concatenate([b[1] for b in self.bias])
        cols = dict(zip(TRUTH_COLUMNS, [fl.t_out, *tr.position.T, *tr.velocity.T, roll, pitch, yaw]))
        cols.update(zip(TRUTH_EXTRA, [*ba.T, *bg.T, *fl.bm_truth[0].T]))
        write_columns(self.folder / "truth.csv", cols)

    def _manifest(self, simulation: dict) -> dict:
        prm = self.prm
        lat, lon, h = self.origin
        doc = {
            "recording": {"format": FORMAT, "version": FORMAT_VERSION,
                          "description": f"{simulation['scenario']}: run {simulation['run']} of the campaign of seed "
                                         f"{simulation['seed']}, exported by sarnav"},
            "platform": {"name": f"simulated ({simulation['scenario']})", "lever_arm_m": [0.0, 0.0, 0.0]},
            "time": {"epoch": self.epoch, "imu_clock_offset_s": 0.0, "radar_clock_offset_s": 0.0},
            "frame": {"origin_lat_deg": lat, "origin_lon_deg": lon, "origin_height_m": h,
                      "earth_rotation": prm.earth_rate is not None},
            "imu": {"file": "imu.csv", "samples": "rates", "body_axes": "FRD", **_imu_keys(prm.imu),
                    "rate_hz": float(prm.imu_rate)},
            "altimeter": {"file": "altimeter.csv", "sigma_3sigma": 3.0 * prm.alt_sigma,
                          "bias_3sigma": 3.0 * float(prm.bias_sigma[0]), "tau": float(prm.bias_tau[0])},
        }
        if self.apertures:
            amp = float(prm.scene["reflector_amplitude"])
            doc["radar"] = dict(_radar_keys(prm.radar), noise_power=amp**2 / 10.0 ** (prm.snr_db / 10.0))
        doc["initial"] = self._initial()
        if self.apertures:
            doc["reference"] = {"kind": "cphd-pass", "points": "reference/points.csv"}
            if self.ortho is not None:
                doc["reference"] = self._ortho_reference()
            doc["aperture"] = self.apertures
        doc["truth"] = {"file": "truth.csv"}
        doc["simulation"] = simulation
        return doc

    def _ortho_reference(self) -> dict:
        """``[reference]`` of reference (b); the terrain's DEM written."""
        out = {"kind": "orthoimage", "points": "reference/points.csv",
               "geolocation_sigma_m": [float(x) for x in horizontal(self.prm.scene["geolocation_sigma"])]}
        terrain = rda_nav_world.terrain_of(self.prm)
        if terrain is not None:
            write_dem(self.folder / "reference/dem.tif", rda_nav_world.swath_extent(self.prm), self.origin, terrain)
            out["dem"] = "reference/dem.tif"
            self.files.append("reference/dem.tif")
        return out

    def _initial(self) -> dict:
        p, v, q, ba, bg, bm, s = self.initial
        f = lambda a: [float(x) for x in a]  # noqa: E731
        return {"time_s": float(self.fl.t_out[0]), "position_ned_m": f(p), "velocity_ned_mps": f(v),
                "attitude_quaternion": f(q), "accel_bias_mps2": f(ba), "gyro_bias_radps": f(bg),
                "measurement_bias_m": f(bm), "p_3sigma": f(3 * s[0:3]), "v_3sigma": f(3 * s[3:6]),
                "theta_3sigma": f(3 * s[6:9]), "accel_bias_3sigma": 3 * float(s[9]) / units.G0,
                "gyro_bias_3sigma": 3 * float(s[12]) / units.deg_per_hr_to_rad_per_s(1.0)}


class _Tap:
    """The simulated source, passed through, keeping the pulses of each aperture the extractor asked for; the
    reference as the recording carries it: a 'cphd-pass' reference has no DEM (docs/recording.md §6), so the run
    recorded is the one ``sarnav navigate`` makes of the recording (no ``ImagingSettings.terrain_correction``)."""

    def __init__(self, source):
        self.source, self.last = source, {}

    @property
    def runs(self) -> int:
        return self.source.runs

    def reference(self, u: int, run: int):
        ref = replace(self.source.reference(u, run), surface=None)
        self.last[u] = (ref, self.last.get(u, (None, None))[1])
        return ref

    def flight(self, u: int, run: int):
        out = self.source.flight(u, run)
        self.last = {u: (self.last[u][0], out)}  # only the aperture being measured is kept
        return out


def _imu_keys(spec) -> dict:
    """``[imu]`` keys of an ``ImuSpec``: its grade's name, and its 3-sigma figures when they are not the preset's."""
    g = spec.grade
    out = {"grade": g.name if g.name in IMU_GRADES else "custom"}
    if IMU_GRADES.get(g.name) != g:
        out.update(vrw_3sigma=3 * g.vrw / float(units.m_per_s_per_sqrt_hr_to_si(1.0)),
                   accel_bias_3sigma=3 * g.accel_bias / units.G0,
                   arw_3sigma=3 * g.arw / float(units.deg_per_sqrt_hr_to_rad_per_sqrt_s(1.0)),
                   gyro_bias_3sigma=3 * g.gyro_bias / float(units.deg_per_hr_to_rad_per_s(1.0)))
    return dict(out, tau_accel=float(spec.tau_accel), tau_gyro=float(spec.tau_gyro))


def _window(w: Window):
    return w.name if w == Window(w.name) else {"name": w.name, "nbar": w.nbar, "sll_db": w.sll_db, "beta": w.beta}


def _radar_keys(radar) -> dict:
    """The ``[radar]`` keys of a ``RadarParams``: every field, in the units of its key."""
    if radar.antenna_length is None:
        raise ConfigError("radar.antenna_length_m", "a recording states the antenna length (the radar has only a "
                          "beamwidth)")
    return {"carrier_ghz": radar.carrier_frequency / 1e9, "bandwidth_mhz": radar.bandwidth / 1e6,
            "sample_rate_mhz": radar.sample_rate / 1e6, "pulse_length_us": radar.pulse_length / 1e-6,
            "prf_hz": float(radar.prf), "antenna_length_m": float(radar.antenna_length), "look_side": radar.look_side,
            "range_window": _window(radar.range_window), "azimuth_window": _window(radar.azimuth_window),
            "near_range_m": float(radar.near_range), "n_range_samples": int(radar.n_range_samples)}
