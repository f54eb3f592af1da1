"""Scenario files written by ``sarnav show`` under sarnav 0.1 (tests/data/show_0.1, saved before the restructuring)
still load and run, each renamed key reported in one line naming the new key (issue 8)."""

import json
from pathlib import Path

import pytest

from sarnav.cli.main import main
from sarnav.errors import ConfigError
from sarnav.scenarios.aliases import RENAMED, RETIRED, UNTIL
from sarnav.scenarios.config import load_scenario
from sarnav.scenarios.registry import get_scenario

OLD = Path(__file__).resolve().parents[1] / "data" / "show_0.1"
FILES = sorted(OLD.glob("*.toml"))


def test_every_scenario_of_0_1_has_a_saved_file():
    from sarnav.scenarios.registry import list_scenarios

    assert {f.stem for f in FILES} <= {name for name, _ in list_scenarios()}  # scenarios added since 0.1 have none


@pytest.mark.parametrize("path", FILES, ids=[f.stem for f in FILES])
def test_an_old_file_loads_as_the_new_scenario_with_one_notice_per_renamed_key(path):
    notices = []
    cfg = load_scenario(str(path), notices=notices)
    assert cfg == get_scenario(path.stem)  # every value carried over to its new key
    kind = cfg["scenario"]["kind"]
    renamed = [r for r in RENAMED if r.kind == kind]
    retired = [r for r in RETIRED if r.kind == kind and f"{r.key.split('.')[-1]} =" in path.read_text()]
    assert len(notices) == len(renamed) + len(retired)
    for r, line in zip(renamed, notices):
        assert line == f"{r.old} is now {r.new} (the old name is accepted until sarnav {UNTIL})"
    for r, line in zip(retired, notices[len(renamed):]):  # an old default dropped, with the reason
        assert line.startswith(f"{r.key}: the value of this file was the default") and r.why in line


@pytest.mark.parametrize("name,extra", [
    ("telemetry", ["--runs", "2", "--set", "trajectory.duration=1.0"]),
    ("rda-nav", ["--runs", "1", "--set", "trajectory.duration=2.0", "--set", "scene.snr_db=-5.0"]),
])
def test_old_files_run_through_the_command_line(tmp_path, capsys, name, extra):
    out = tmp_path / "out"
    assert main(["run", str(OLD / f"{name}.toml"), "--out", str(out), "--executor", "serial", "--no-figures",
                 "--quiet", *extra]) == 0
    err = capsys.readouterr().err
    assert json.loads((out / "summary.json").read_text())["complete"] is True
    if name == "rda-nav":  # the old key in the file and in --set: one notice each
        assert err.count("sarnav: notice: scene.snr_db is now radar.snr_db") == 2


def test_an_old_image_file_runs_with_sarnav_image(tmp_path, capsys):
    assert main(["image", str(OLD / "point-target.toml"), "--out", str(tmp_path), "--set", "image.margin_m=2.0"]) == 0
    err = capsys.readouterr().err
    assert "sarnav: notice: image.margin_m is now radar.range_margin_m" in err
    assert (tmp_path / "metrics.json").exists()


def test_old_altitude_in_set_becomes_start_ned_and_both_names_at_once_is_an_error(tmp_path):
    cfg = load_scenario("point-target", ["trajectory.altitude_m=1500"], notices=[])
    assert cfg["trajectory"]["start_ned"] == [0.0, 0.0, -1500.0]
    f = tmp_path / "both.toml"
    f.write_text('[scenario]\nname = "x"\nkind = "rda-nav"\n[scene]\nsnr_db = -5.0\n[radar]\nsnr_db = -6.0\n')
    with pytest.raises(ConfigError, match=r"^scene\.snr_db: is the old name of radar\.snr_db"):
        load_scenario(str(f), notices=[])


def test_without_a_sink_the_notices_are_future_warnings():
    with pytest.warns(FutureWarning, match="scene.snr_db is now radar.snr_db"):
        load_scenario(str(OLD / "rda-nav.toml"))


#: the other six 0.1 files, shortened with new keys on the command line: (command, extra arguments)
SHORT = {
    "bpa-sensitivity": ("run", ["--set", "trajectory.duration=3.0", "--set", "image.spacing=0.2",
                                "--set", "image.margin=2.0"]),
    "rda-nav-flexsar": ("run", ["--runs", "1", "--set", "trajectory.duration=1.0"]),
    "scatterers": ("image", ["--set", "trajectory.duration=0.25"]),
    "telemetry-geometry": ("run", ["--runs", "1", "--set", "base.trajectory.duration=1.0"]),
    "telemetry-imu-grade": ("run", ["--runs", "1", "--set", "base.trajectory.duration=1.0"]),
    "telemetry-noise": ("run", ["--runs", "1", "--set", "base.trajectory.duration=1.0"]),
}


@pytest.mark.parametrize("name", sorted(SHORT))
def test_the_other_old_files_run_with_one_notice_per_renamed_key(tmp_path, capsys, name):
    # 0.1's tests loaded these six files but never ran them
    command, extra = SHORT[name]
    kind = get_scenario(name)["scenario"]["kind"]
    out = tmp_path / "out"
    argv = [command, str(OLD / f"{name}.toml"), "--out", str(out), *extra]
    if command == "run":
        argv += ["--executor", "serial", "--no-figures", "--quiet"]
    assert main(argv) == 0
    notices = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("sarnav: notice: ")]
    renamed = [r for r in RENAMED if r.kind == kind]
    retired = [f"sarnav: notice: {r.key}: the value of this file was the default of sarnav 0.2 and is dropped: {r.why}"
               for r in RETIRED if r.kind == kind and f"{r.key.split('.')[-1]} =" in (OLD / f"{name}.toml").read_text()]
    assert notices == [f"sarnav: notice: {r.old} is now {r.new} (the old name is accepted until sarnav {UNTIL})"
                       for r in renamed] + retired
    if kind == "study":
        cases = json.loads((out / "study.json").read_text())["cases"]
        assert cases and all((out / c["label"] / "summary.json").exists() for c in cases)
    elif kind == "image":
        assert json.loads((out / "metrics.json").read_text())["n_targets"] >= 1
    elif kind == "bpa-sensitivity":
        assert len((out / "sensitivity.csv").read_text().splitlines()) == 1 + 9
    else:
        assert json.loads((out / "summary.json").read_text())["complete"] is True
