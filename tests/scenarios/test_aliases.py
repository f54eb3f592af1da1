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


# ----------------------------------------------------------------------------- the kind-local spellings of 0.2
#: files ``sarnav show`` wrote before the quality kinds' ``[geometry]`` and the closed loop's ``[radar]`` spellings moved
#: to the shared vocabulary (issue 25)
OLD_02 = Path(__file__).resolve().parents[1] / "data" / "show_0.2"
FILES_02 = sorted(OLD_02.glob("*.toml"))


def test_every_kind_with_a_moved_key_has_a_saved_file():
    moved = {r.kind for r in RENAMED} - {"rda-nav", "image", "bpa-sensitivity"}  # (the kinds of the 0.1 renames)
    assert moved == {"quality-sweep", "gpsd-search", "quality-nav", "spacecraft-closed-loop"}
    assert moved == {get_scenario(f.stem)["scenario"]["kind"] for f in FILES_02}


@pytest.mark.parametrize("path", FILES_02, ids=[f.stem for f in FILES_02])
def test_a_file_of_the_old_spelling_loads_as_the_new_scenario_with_one_notice_per_moved_key(path):
    notices = []
    cfg = load_scenario(str(path), notices=notices)
    assert cfg == get_scenario(path.stem)
    old_text = path.read_text()
    assert "[geometry]" not in get_scenario(path.stem) and ("[geometry]" in old_text) == ("gpsd" in path.stem or
                                                                                         "sweep" in path.stem)
    renamed = [r for r in RENAMED if r.kind == cfg["scenario"]["kind"]]
    assert notices == [f"{r.old} is now {r.new} (the old name is accepted until sarnav {UNTIL})" for r in renamed]


def test_the_old_altitude_becomes_start_ned_over_the_origin():
    cfg = load_scenario(str(OLD_02 / "gpsd-search.toml"), ["geometry.altitude=1500", "scene.snr_db=3.0"], notices=[])
    assert cfg["trajectory"]["start_ned"] == [0.0, 0.0, -1500.0] and cfg["radar"]["snr_db"] == 3.0
    assert "geometry" not in cfg


def _files(out: Path) -> dict:
    return {f.name: f.read_bytes() for f in sorted(out.iterdir()) if f.is_file()}


#: an old file run with old keys on the command line against the registered scenario with the new keys: the same bytes
SAME_RUN = {
    "gpsd-search": (["--set", "geometry.n_pulses=400", "--set", "geometry.scene_extent=4.0"],
                    ["--set", "aperture.n_pulses=400", "--set", "scene.extent=4.0"],
                    ["--set", "search.initial_pulses=200", "--set", "search.block_pulses=[100]", "--set", "image.size=8",
                     "--set", "search.sigmas=1", "--set", "search.spacings=1"]),
    "quality-sweep": (["--set", "geometry.n_pulses=200", "--set", "scene.receiver_noise=true"],
                      ["--set", "aperture.n_pulses=200", "--set", "radar.receiver_noise=true"],
                      ["--set", "sweep.sizes=[6]", "--set", "sweep.steps=1", "--set", "sweep.figure_size=6",
                       "--set", "reliability.scenes=0", "--set", "sweep.bins=[10]"]),
}


@pytest.mark.parametrize("name", sorted(SAME_RUN))
def test_old_spellings_run_to_the_same_bytes(tmp_path, capsys, name):
    old_keys, new_keys, common = SAME_RUN[name]
    runs = ["--runs", "1"] if name == "gpsd-search" else []
    assert main(["run", str(OLD_02 / f"{name}.toml"), "--out", str(tmp_path / "old"), "--no-figures", "--quiet",
                 *runs, *old_keys, *common]) == 0
    notices = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("sarnav: notice: ")]
    assert len(notices) == len([r for r in RENAMED if r.kind == name]) + len(old_keys) // 2
    assert main(["run", name, "--out", str(tmp_path / "new"), "--no-figures", "--quiet", *runs, *new_keys,
                 *common]) == 0
    assert not [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("sarnav: notice: ")]
    old, new = _files(tmp_path / "old"), _files(tmp_path / "new")
    data = [n for n in old if n.endswith((".csv", ".nc"))]  # (search.json holds timings, sarnav.json the folder's claim)
    assert data and all(old[n] == new[n] for n in data), [n for n in data if old[n] != new[n]]
