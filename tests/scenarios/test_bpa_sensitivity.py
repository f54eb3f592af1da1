"""bpa-sensitivity study (thesis ch. 4, Figs 4.11-4.13): every assertion compares an image measured from
simulated echoes with a prediction of analysis.sensitivity (eq. 4.41, Fresnel) or with theory."""

import csv
import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.scenarios import bpa_sensitivity as bpa
from sarnav.units import C


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("bpa")
    path = bpa.run_sensitivity(bpa.default_config(), out)
    with open(path) as fh:
        rows = {r["name"]: {k: (v if k in ("name", "unit") else float(v) if v else math.nan) for k, v in r.items()}
                for r in csv.DictReader(fh)}
    return rows, out


def _offset_error(r):
    meas = np.hypot(r["meas_offset_range"], r["meas_offset_along"])
    pred = np.hypot(r["pred_offset_range"], r["pred_offset_along"])
    diff = np.hypot(r["meas_offset_range"] - r["pred_offset_range"], r["meas_offset_along"] - r["pred_offset_along"])
    return diff, pred, meas


def test_writes_csv_with_every_thesis_error_and_a_figure(study):
    rows, out = study
    assert set(rows) == set(bpa.THESIS_SIM_ERRORS)
    assert (out / "sensitivity.png").stat().st_size > 10_000


@pytest.mark.parametrize("name", ["position_along", "position_cross", "position_elevation"])
def test_position_errors_shift_by_the_prediction_without_blur(study, name):
    r = study[0][name]
    diff, pred, _ = _offset_error(r)
    assert pred > 1.0
    assert diff < 0.05 * pred
    assert abs(r["meas_peak_loss"]) < 0.01
    assert r["irw_along"] == pytest.approx(r["irw_along_ref"], rel=0.02)


@pytest.mark.parametrize("name,shift", [("velocity_cross", 9.0), ("velocity_elevation", 5.0)])
def test_cross_and_elevation_velocity_errors_shift_along_track(study, name, shift):
    r = study[0][name]
    # y_t dv/V and h dv/V (extraction §11.5): 1800 * 0.05/10, 1000 * 0.05/10
    assert r["pred_offset_along"] == pytest.approx(shift, rel=1e-3)
    assert r["meas_offset_along"] == pytest.approx(r["pred_offset_along"], rel=0.05)
    assert abs(r["meas_peak_loss"]) < 0.01


def test_yaw_changes_nothing(study):
    r = study[0]["yaw"]
    assert abs(r["meas_peak_loss"]) < 0.01
    assert math.hypot(r["meas_offset_range"], r["meas_offset_along"]) < 0.02


@pytest.mark.parametrize("name", ["velocity_along", "roll", "pitch"])
def test_along_velocity_roll_and_pitch_blur(study, name):
    assert study[0][name]["meas_peak_loss"] > 0.10


def test_roll_blurs_more_than_pitch_at_the_thesis_magnitudes(study):
    rows = study[0]
    assert rows["roll"]["meas_peak_loss"] > rows["pitch"]["meas_peak_loss"]


def test_along_velocity_blur_matches_fresnel_prediction(study):
    r = study[0]["velocity_along"]
    # pure quadratic phase error (FM-rate error -2 dv/V): the Fresnel loss is the theory
    assert r["meas_peak_loss"] == pytest.approx(r["pred_peak_loss"], abs=0.02)
    assert r["irw_along"] > r["irw_along_ref"]


def test_reference_azimuth_irw_matches_theory(study):
    cfg = bpa.default_config()
    tr = cfg["trajectory"]
    lam = C / 9.75e9
    r0 = math.hypot(cfg["scene"]["target_ground_range"], tr["start_ned"][2])
    # uniform aperture of length V T: 3-dB IRW 0.886 lambda R0 / (2 V T)
    want = 0.886 * lam * r0 / (2 * tr["speed"] * tr["duration"])
    assert study[0]["yaw"]["irw_along_ref"] == pytest.approx(want, rel=0.03)


def test_exact_kinematics_agree_with_the_linear_model_for_small_errors():
    from sarnav.analysis import bpa_sensitivity as study
    from sarnav.analysis.sensitivity import propagate_nav_error

    geo = bpa.geometry(bpa.default_config())
    for name in ("velocity_cross", "pitch", "roll"):
        dx0 = study.injected_error(name, study.THESIS_SIM_ERRORS[name][2])
        p_hat, _ = study.estimated_trajectory(geo, dx0)
        lin = geo.truth_positions - propagate_nav_error(dx0, geo.times)[:, :3]
        # second-order attitude terms: g (1 - cos dth) t^2 / 2 <= 9.81 * 2e-4 * 18 = 0.036 m for pitch
        assert np.max(np.abs(p_hat - lin)) < 0.04


def test_bad_config_names_the_field():
    cfg = bpa.default_config()
    cfg["errors"]["heave"] = 1.0
    with pytest.raises(ConfigError, match="errors.heave"):
        bpa.validate(cfg)
    cfg = bpa.default_config()
    cfg["trajectory"]["duration"] = -1.0
    with pytest.raises(ConfigError, match="trajectory.duration"):
        bpa.validate(cfg)
    cfg = bpa.default_config()
    cfg["image"]["interpolation"] = "sinc"
    with pytest.raises(ConfigError, match="image.interpolation"):
        bpa.validate(cfg)


@pytest.mark.parametrize("key, value, field", [
    # show accepted them and run refused (or crashed) while simulating: validation now does what run needs
    ("radar.prf_hz", 1.0, "radar.prf_hz"),     # 6 pulses: was a run-time error naming radar.prf
    ("radar.prf_hz", 20.0, "radar.prf_hz"),    # below the Doppler band 88.5 Hz: was "radar.prf" at run time
    ("radar.prf_hz", 1e9, "radar.prf_hz"),     # 6e9 pulses
    ("trajectory.speed", 1e300, "trajectory.speed"),
    ("scene.target_ground_range", 1e12, "scene.target_ground_range"),
    ("image.spacing", 0.01, "image.spacing"),  # with a 50-m margin: 6e10 pixel-pulses
    ("errors.velocity_cross", 10.0, "errors.velocity_cross"),  # the target's closest approach leaves the aperture
])
def test_show_refuses_what_run_would_refuse(key, value, field, capsys):
    from sarnav.cli.main import main

    argv = ["show", "bpa-sensitivity", "--set", f"{key}={value}"]
    if key == "image.spacing":
        argv += ["--set", "image.margin=50.0"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"sarnav: error: {field}: ") and err.count("\n") == 1, err


def test_validation_plans_every_case_like_the_run():
    # the plan validation makes (closed-form closest approach of the true track) and the run's (eq. 4.41 root) agree
    from sarnav.analysis import bpa_sensitivity as ab
    from sarnav.analysis import sensitivity as sens

    cfg = bpa.default_config()
    geo = bpa.geometry(cfg)
    settings = ab.ImageSettings(0.1, 4.0, "cubic")
    for name, value in cfg["errors"].items():
        quick = ab.plan_case(name, value, geo, settings)
        dx0 = ab.injected_error(name, value)
        pred = sens.predict_shift(geo.target, geo.p0, geo.v0, dx0, (-geo.aperture, 2 * geo.aperture))
        exact = ab.plan_case(name, value, geo, settings, pred)
        np.testing.assert_allclose(quick.q_pred, exact.q_pred, atol=1e-6)
