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

    assert main(["show", "point-target", "--set", "trajectory.speed_mps=50"]) == 0
    cfg = tomllib.loads(capsys.readouterr().out)
    assert cfg["scenario"]["kind"] == "image" and cfg["trajectory"]["speed_mps"] == 50


def test_image_subcommand_is_wired(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["image", "--help"])
    assert exc.value.code == 0
    assert "--algorithm" in capsys.readouterr().out


def test_image_unknown_scenario_is_one_line_error(capsys):
    assert main(["image", "no-such-scenario"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sarnav: error:")
