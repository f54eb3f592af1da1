"""``sarnav navigate``: the navigator on a recording gives the campaign's run again, writes its files as documented,
marks an interrupted run incomplete and meets bad input with one line (or, for an aperture it cannot image, a
skipped aperture and the flight going on).

Same code, same numbers: run K of a short rda-nav campaign (the paper flight in image mode, the BPA turning flight,
the terrain flight) is exported (``simulation.export``) and navigated with ``sarnav navigate``; the estimate the
campaign had at every epoch is its truth minus its recorded error (``RunRecord.error`` is truth - estimate, the truth
read from the recording's ``truth.csv``), and navigate's estimate and 1-sigma must equal it to 1 mm / 1e-6 relative.
"""

from __future__ import annotations

import csv
import json
import shutil
import tomllib
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import sarkit.wgs84 as wgs84
import xarray as xr

from sarnav.cli.main import main
from sarnav.io.frames import ned_to_ecef
from sarnav.montecarlo.seeding import run_seeds
from sarnav.recording import read_recording
from sarnav.recording.navigate import COV_STEP, STATE_LAYOUT, navigate
from sarnav.report.navigate_files import STATUS_FILE, TRAJECTORY_COLUMNS, UPDATE_COLUMNS, run_navigate
from sarnav.rotations import corrupt_attitude, euler_to_quat
from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.config import load_scenario
from sarnav.scenarios.navigate import read_navigate_settings
from sarnav.simulation import rda_nav
from sarnav.simulation.export import export_rda_nav
from sarnav.tomlio import dump_toml

RUNS, RUN = 2, 1
CASES = {
    "rda-nav": ("rda-nav", ["trajectory.duration=3.0", "scene.geolocation_sigma_m=[0.3, 0.3, 0.5]"]),
    "turning-bpa": ("rda-nav", ["trajectory.duration=2.0", "sar.algorithm=bpa", "trajectory.type=turning"]),
    "terrain": ("rda-nav-terrain", ["trajectory.duration=2.0"]),
}


def _export(name, folder):
    scenario, sets = CASES[name]
    cfg = load_scenario(scenario, sets, runs=RUNS)
    seed = run_seeds(cfg["campaign"]["seed"], RUNS)[RUN]
    done = export_rda_nav(rn.parse(cfg), folder, seed, run=RUN, runs=RUNS, campaign_seed=cfg["campaign"]["seed"],
                          scenario_name=scenario, scenario_text=dump_toml(cfg))
    return done.record


@pytest.fixture(scope="module")
def paper(tmp_path_factory):
    """The 3-s paper flight exported, and navigated by the command."""
    root = tmp_path_factory.mktemp("paper")
    record = _export("rda-nav", root / "rec")
    assert main(["navigate", str(root / "rec"), "--out", str(root / "out"), "--quiet"]) == 0
    return root, record


def _campaign_estimate(folder, record):
    """The campaign's estimate at every epoch: truth (truth.csv) minus the record's error, in error-state terms."""
    tr = read_recording(folder).truth
    np.testing.assert_allclose(tr.time, record.time, rtol=0, atol=1e-12)
    x, e = tr.extra, record.error
    q = corrupt_attitude(np.asarray(euler_to_quat(*tr.rpy.T)), e[:, 6:9])
    ba = np.c_[x["accel_bias_x"], x["accel_bias_y"], x["accel_bias_z"]] - e[:, 9:12]
    bg = np.c_[x["gyro_bias_x"], x["gyro_bias_y"], x["gyro_bias_z"]] - e[:, 12:15]
    bm = np.c_[x["b_alt"], x["b_range"], x["b_cross"]] - e[:, 15:18]
    return {"p": tr.position - e[:, 0:3], "v": tr.velocity - e[:, 3:6], "q": q, "ba": ba, "bg": bg, "bm": bm}


def _check_same_numbers(out, folder, record):
    want = _campaign_estimate(folder, record)
    with xr.open_dataset(out / "trajectory.nc", engine="netcdf4") as ds:
        got = {"time": ds["time"].values, "p": np.c_[ds["north"], ds["east"], ds["down"]],
               "v": np.c_[ds["v_north"], ds["v_east"], ds["v_down"]], "q": ds["quaternion"].values,
               "ba": ds["accel_bias"].values, "bg": ds["gyro_bias"].values, "bm": ds["measurement_bias"].values,
               "sigma": ds["sigma"].values, "nis": ds["nis"].values, "residual": ds["residual"].values}
    np.testing.assert_allclose(got["time"], record.time, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["p"], want["p"], rtol=0, atol=1e-3)  # 1 mm
    np.testing.assert_allclose(got["v"], want["v"], rtol=0, atol=1e-3)  # 1 mm/s
    q = got["q"] * np.sign(np.sum(got["q"] * want["q"], axis=1))[:, None]
    np.testing.assert_allclose(q, want["q"], rtol=0, atol=1e-6)  # a microradian
    for key, block in (("ba", 9), ("bg", 12), ("bm", 15)):  # a millionth of their 1-sigma
        np.testing.assert_array_less(np.abs(got[key] - want[key]), 1e-6 * record.sigma[:, block:block + 3] + 1e-15)
    np.testing.assert_allclose(got["sigma"], record.sigma, rtol=1e-6, atol=0)
    np.testing.assert_allclose(got["nis"], record.nis, rtol=1e-5)
    np.testing.assert_allclose(got["residual"], record.residual, rtol=0, atol=1e-3)


def test_same_code_same_numbers_paper_flight(paper):
    root, record = paper
    _check_same_numbers(root / "out", root / "rec", record)
    doc = json.loads((root / "out" / STATUS_FILE).read_text())
    assert doc["complete"] is True and doc["updates"] == 3 and doc["pairs_fused"] == 3
    assert doc["consistency"]["nees"]["dof"] == 18


@pytest.mark.parametrize("name", ["turning-bpa", "terrain"])
def test_same_code_same_numbers(name, tmp_path):
    record = _export(name, tmp_path / "rec")
    assert main(["navigate", str(tmp_path / "rec"), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    _check_same_numbers(tmp_path / "out", tmp_path / "rec", record)


def test_settings_are_the_campaigns(paper):
    """An exported recording's defaults are its scenario's settings; nav.toml and --set change them."""
    root, _ = paper
    rec = read_recording(root / "rec")
    prm = rn.parse(load_scenario("rda-nav", CASES["rda-nav"][1], runs=RUNS))
    st = read_navigate_settings(rec)
    assert st.sar.gate_probability == prm.gate_probability and st.imaging == prm.imaging
    np.testing.assert_array_equal(st.sar_bias_sigma, prm.bias_sigma[1:])
    assert st.imu_filter == prm.imu_filter
    nav_toml = root / "nav.toml"
    nav_toml.write_text("[sar]\ngate_probability = 0.01\n\n[filter.imu]\ntau_accel = 100.0\n")
    st = read_navigate_settings(rec, nav_toml, ["sar.min_correlation=0.7"])
    assert st.sar.gate_probability == 0.01 and st.imaging.min_correlation == 0.7
    assert st.imu_filter.tau_accel == 100.0 and st.imu_filter.grade == prm.imu.grade


def test_csv_geojson_and_kml(paper):
    root, record = paper
    out = root / "out"
    with open(out / "trajectory.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert tuple(rows[0]) == TRAJECTORY_COLUMNS
    assert TRAJECTORY_COLUMNS[:10] == ("time", "north", "east", "down", "v_north", "v_east", "v_down", "roll",
                                       "pitch", "yaw")
    assert all(f"sigma_{c}" in TRAJECTORY_COLUMNS for c in TRAJECTORY_COLUMNS[1:10])
    data = np.array(rows[1:], dtype=float)
    K = record.time.size
    assert data.shape == (K, len(TRAJECTORY_COLUMNS))
    col = {c: data[:, i] for i, c in enumerate(TRAJECTORY_COLUMNS)}
    # latitude, longitude, height: the NED position through ECEF (io.frames) and sarkit's geodesy, not pymap3d
    origin = read_recording(root / "rec").manifest.frame.origin
    llh = wgs84.cartesian_to_geodetic(ned_to_ecef(np.c_[col["north"], col["east"], col["down"]], origin))
    np.testing.assert_allclose(np.c_[col["latitude"], col["longitude"]], llh[:, :2], rtol=0, atol=1e-10)
    np.testing.assert_allclose(col["height"], llh[:, 2], rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.diff(col["time"]), COV_STEP, rtol=0, atol=1e-9)
    # sigma of the Euler angles at zero roll and pitch: roll and pitch errors are the NED tilts turned by yaw
    np.testing.assert_allclose(col["sigma_yaw"], record.sigma[:, 8], rtol=1e-3)
    gj = json.loads((out / "trajectory.geojson").read_text())
    lines = [f for f in gj["features"] if f["geometry"]["type"] == "LineString"]
    points = [f for f in gj["features"] if f["geometry"]["type"] == "Point"]
    assert len(lines) == 1 and len(lines[0]["geometry"]["coordinates"]) == K and len(points) == 3
    np.testing.assert_allclose(lines[0]["geometry"]["coordinates"], np.c_[col["longitude"], col["latitude"],
                                                                          col["height"]], rtol=0, atol=1e-9)
    kml = ET.parse(out / "trajectory.kml").getroot()
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    coords = kml.find(".//k:LineString/k:coordinates", ns).text.split()
    assert len(coords) == K and len(kml.findall(".//k:Point", ns)) == 3
    np.testing.assert_allclose([float(v) for v in coords[-1].split(",")],
                               [col["longitude"][-1], col["latitude"][-1], col["height"][-1]], rtol=0, atol=1e-9)
    with open(out / "updates.csv", newline="") as fh:
        up = list(csv.DictReader(fh))
    assert tuple(up[0]) == UPDATE_COLUMNS and len(up) == 3
    assert [r["status"] for r in up] == ["fused"] * 3 and [r["fused"] for r in up] == ["1"] * 3
    np.testing.assert_allclose([float(r["sigma_range"]) for r in up], record.extras["registration_sigma"][1][:, 1],
                               rtol=1e-5)
    errors = np.genfromtxt(out / "errors.csv", delimiter=",", names=True)
    np.testing.assert_allclose(errors["nees"], record.nees, rtol=1e-5)


def test_interrupted_run_is_marked_incomplete(paper, tmp_path):
    root, _ = paper
    rec = read_recording(root / "rec")

    def stop(u, n, nav):
        if u == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_navigate(rec, tmp_path / "out", read_navigate_settings(rec), progress=stop)
    doc = json.loads((tmp_path / "out" / STATUS_FILE).read_text())
    assert doc["complete"] is False and doc["interrupted"].startswith("KeyboardInterrupt")
    assert doc["updates"] == 2 and doc["updates_planned"] == 3
    assert not (tmp_path / "out" / "trajectory.csv").exists()
    rows = (tmp_path / "out" / "trajectory.csv.partial").read_text().splitlines()
    assert len(rows) == 1 + 21  # header + epochs 0 .. 2 s
    with xr.open_dataset(tmp_path / "out" / "trajectory.nc.partial", engine="netcdf4") as ds:
        assert ds.attrs["complete"] == 0 and ds.sizes["update"] == 2


def test_missing_recording(tmp_path, capsys):
    assert main(["navigate", str(tmp_path / "none"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sarnav: error: ") and "is not a folder" in err and "\n" not in err


def _copy(paper, tmp_path):
    root, _ = paper
    folder = tmp_path / "rec"
    shutil.copytree(root / "rec", folder)
    return folder


def test_missing_manifest_key(paper, tmp_path, capsys):
    folder = _copy(paper, tmp_path)
    doc = tomllib.loads((folder / "flight.toml").read_text())
    del doc["initial"]["p_3sigma"]
    (folder / "flight.toml").write_text(dump_toml(doc))
    assert main(["navigate", str(folder), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sarnav: error: flight.toml:initial.p_3sigma:") and "\n" not in err, err


@pytest.mark.parametrize("args, message", [
    (["--set", "scene.seed=3"], "scene.seed: not a setting of the navigator"),
    (["--set", "sar.measurement=oracle"], "sar.measurement: navigate forms the images"),
    (["--set", "sar.gate_probability=0.9"], "sar.gate_probability: must be in [0, 0.5]"),
    (["--config", "NAV"], "nav.toml:radar.prf_hz: not a setting of the navigator"),
])
def test_bad_settings(paper, tmp_path, capsys, args, message):
    root, _ = paper
    (tmp_path / "nav.toml").write_text("[radar]\nprf_hz = 100.0\n")
    args = [str(tmp_path / "nav.toml") if a == "NAV" else a for a in args]
    assert main(["navigate", str(root / "rec"), "--out", str(tmp_path / "out"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sarnav: error: {message}") and "\n" not in err, err
    assert not (tmp_path / "out").exists()


def test_reference_that_does_not_cover_an_aperture_skips_it(paper, tmp_path):
    """Aperture 1's reference point moved 3 km away from its reference pass: its chip cannot be cut (outside the
    receive window), the aperture is skipped and recorded, the other apertures are fused and the run completes."""
    folder = _copy(paper, tmp_path)
    path = folder / "reference" / "points.csv"
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    rows[1]["anchor_east_m"] = repr(float(rows[1]["anchor_east_m"]) + 3000.0)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    rec = read_recording(folder)
    doc = run_navigate(rec, tmp_path / "out", read_navigate_settings(rec))
    assert doc["complete"] is True and doc["updates"] == 3
    assert (doc["pairs_fused"], doc["pairs_skipped"]) == (2, 1)
    assert any("aperture 1" in n and "skipped" in n for n in doc["notices"])
    with open(tmp_path / "out" / "updates.csv", newline="") as fh:
        up = list(csv.DictReader(fh))
    assert up[1]["aperture"] == "1" and up[1]["status"].startswith("skipped: images not formed")
    assert up[1]["fused"] == "0" and up[0]["fused"] == up[2]["fused"] == "1"
    with xr.open_dataset(tmp_path / "out" / "trajectory.nc", engine="netcdf4") as ds:
        assert ds["update_aperture"].values.tolist() == [0, -1, 2]
        assert ds["nis_dof"].values.tolist() == [3, 1, 3]  # the altimeter alone at t = 2 s


def test_a_recording_without_altimeter(paper, tmp_path):
    """SAR pairs alone: every update has the two components of its pair; the altimeter bias state, never
    uncertain, is left out of the NEES."""
    folder = _copy(paper, tmp_path)
    doc = tomllib.loads((folder / "flight.toml").read_text())
    del doc["altimeter"]
    (folder / "flight.toml").write_text(dump_toml(doc))
    rec = read_recording(folder)
    out = run_navigate(rec, tmp_path / "out", read_navigate_settings(rec))
    assert out["complete"] is True and out["pairs_fused"] == 3 and out["consistency"]["nees"]["dof"] == 17
    with xr.open_dataset(tmp_path / "out" / "trajectory.nc", engine="netcdf4") as ds:
        assert ds["nis_dof"].values.tolist() == [2, 2, 2] and np.all(np.isnan(ds["residual"].values[:, 0]))
        assert np.all(np.isfinite(ds["residual"].values[:, 1:]))


def test_the_files_in_flight_positions_are_never_used(paper, monkeypatch):
    """The in-flight pulses' antenna positions moved by 50 m: the images are formed along the navigator's own
    track, so the estimate is the same to the last bit."""
    from dataclasses import replace

    from sarnav.recording.apertures import RecordedApertures

    root, _ = paper
    rec = read_recording(root / "rec")
    settings = read_navigate_settings(rec)
    plain = navigate(rec, settings).estimate()
    flight = RecordedApertures.flight

    def moved(self, u, run):
        rc, seconds = flight(self, u, run)
        return replace(rc, positions=rc.positions + [50.0, -30.0, 20.0]), seconds

    monkeypatch.setattr(RecordedApertures, "flight", moved)
    got = navigate(read_recording(root / "rec"), settings).estimate()
    for key in ("p", "v", "q", "P"):
        np.testing.assert_array_equal(got[key], plain[key])


def test_any_imu_rate_steps_at_the_samples_nearest_the_epochs(paper, tmp_path):
    """The covariance steps follow time, not sample counts (recording.timeline): a rate that is no multiple of 10 Hz
    is integrated; stated 105 Hz for the 100-Hz log, the steps fall on the same samples (within half a stated
    interval of each 0.1-s epoch) and the estimate is the 100-Hz one up to the span arithmetic."""
    folder = _copy(paper, tmp_path)
    text = (folder / "flight.toml").read_text().replace("rate_hz = 100.0", "rate_hz = 105.0")
    (folder / "flight.toml").write_text(text)
    from sarnav.recording.timeline import plan_flight
    rec, base = read_recording(folder), read_recording(paper[0] / "rec")
    plan, plan0 = plan_flight(rec), plan_flight(base)
    assert not plan.uniform and plan0.uniform
    assert all(np.array_equal(a, b) for a, b in zip(plan.bounds, plan0.bounds))
    settings = read_navigate_settings(base)
    got, want = navigate(rec, settings).estimate(), navigate(base, settings).estimate()
    np.testing.assert_allclose(got["p"], want["p"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got["sigma"], want["sigma"], rtol=1e-6)


def test_layout_and_step_are_the_campaigns():
    assert STATE_LAYOUT == rda_nav.STATE_LAYOUT and COV_STEP == rda_nav.COV_STEP


def test_trajectory_nc_follows_cf(paper):
    """trajectory.nc passes the CF attribute check every campaign results file passes (tests/report/test_cf.py)."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("cf_check", Path(__file__).parents[1] / "report" / "test_cf.py")
    cf_check = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cf_check)
    root, _ = paper
    with xr.open_dataset(root / "out" / "trajectory.nc") as ds:
        assert cf_check.cf_problems(ds) == []
