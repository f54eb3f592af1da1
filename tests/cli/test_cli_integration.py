"""The pieces wired together by the lead: every subcommand reachable from ``sarnav``, image
scenarios listed and shown, and input errors that survive worker processes."""

import pickle

import pytest

from sarnav.cli.main import main
from sarnav.errors import ConfigError, InputDataError


def test_errors_pickle_round_trip_keeps_field_and_message():
    for cls in (ConfigError, InputDataError):
        err = pickle.loads(pickle.dumps(cls("imu.tau_accel", "must be > 0 s, got -1.0")))
        assert type(err) is cls
        assert err.field == "imu.tau_accel" and str(err) == "imu.tau_accel: must be > 0 s, got -1.0"


def test_scenarios_lists_campaigns_and_images(capsys):
    assert main(["scenarios"]) == 0
    names = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    for name in ("telemetry", "telemetry-imu-grade", "telemetry-noise", "telemetry-geometry", "rda-nav",
                 "rda-nav-flexsar", "bpa-sensitivity", "point-target", "scatterers"):
        assert name in names


def test_show_image_scenario_is_toml(capsys):
    import tomllib

    assert main(["show", "point-target", "--set", "trajectory.speed=50"]) == 0
    cfg = tomllib.loads(capsys.readouterr().out)
    assert cfg["scenario"]["kind"] == "image" and cfg["trajectory"]["speed"] == 50
    # the 0.1 name still works, with a one-line notice naming the new key
    assert main(["show", "point-target", "--set", "trajectory.speed_mps=40"]) == 0
    captured = capsys.readouterr()
    assert tomllib.loads(captured.out)["trajectory"]["speed"] == 40
    assert captured.err.strip() == ("sarnav: notice: trajectory.speed_mps is now trajectory.speed "
                                    "(the old name is accepted until sarnav 0.3)")


def test_image_subcommand_is_wired(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["image", "--help"])
    assert exc.value.code == 0
    assert "--algorithm" in capsys.readouterr().out


def test_image_unknown_scenario_is_one_line_error(capsys):
    assert main(["image", "no-such-scenario"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sarnav: error:")


def test_plain_run_is_a_reduced_default_campaign(monkeypatch, tmp_path):
    """``sarnav run`` with no scenario runs DEFAULT_SCENARIO with DEFAULT_RUNS runs (the README's main
    job); an explicit --runs wins. The campaign itself is replaced by a recorder here."""
    from sarnav.scenarios import registry

    seen = {}

    def fake_campaign(cfg, out, kind=None, **opts):
        seen["name"], seen["runs"] = cfg["scenario"]["name"], cfg["campaign"]["runs"]
        raise SystemExit(0)

    monkeypatch.setattr("sarnav.montecarlo.campaign.run_campaign", fake_campaign)
    for argv, runs in ((["run", "--out", str(tmp_path / "a")], registry.DEFAULT_RUNS),
                       (["run", "--runs", "3", "--out", str(tmp_path / "b")], 3)):
        with pytest.raises(SystemExit):
            main(argv)
        assert seen == {"name": registry.DEFAULT_SCENARIO, "runs": runs}
    assert registry.DEFAULT_SCENARIO == "rda-nav" and 10 <= registry.DEFAULT_RUNS <= 50


def test_run_bpa_sensitivity_writes_table_and_grid(tmp_path):
    """``sarnav run bpa-sensitivity`` runs the deterministic chapter 4 study through its kind's
    ``run_scenario`` hook: one CSV row per injected error of thesis §12.10, and the figure grid."""
    import csv

    out = tmp_path / "bpa"
    assert main(["run", "bpa-sensitivity", "--out", str(out), "--quiet"]) == 0
    rows = list(csv.DictReader(open(out / "sensitivity.csv")))
    assert [r["name"] for r in rows] == ["position_along", "position_cross", "position_elevation", "velocity_along",
                                         "velocity_cross", "velocity_elevation", "roll", "pitch", "yaw"]
    yaw = rows[-1]
    assert abs(float(yaw["meas_peak_loss"])) < 0.01  # yaw changes nothing (thesis T17)
    assert (out / "sensitivity.png").stat().st_size > 10_000


@pytest.mark.parametrize("override, field", [
    ("initial.theta_3sigma=[0.01,0.01,3.0]", "initial.theta_3sigma"),
    ("trajectory.duration=100000", "trajectory.duration"),
])
def test_telemetry_refuses_huge_attitude_error_and_results_that_do_not_fit(capsys, override, field):
    assert main(["run", "telemetry", "--set", override, "--out", "/nonexistent/never-written"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"sarnav: error: {field}:")
