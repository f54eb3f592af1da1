"""Bad inputs of issue 9 that 0.1 answered with a hang or a traceback, each now one documented line (exit 2) or a
clean run: a FIFO as the scenario file, seeds at and past 2^63, a scheduler address that is not one, noise 3-sigma
values that overflow, argument errors, a corrupt ``campaign.json`` without ``--resume``, an ``--out`` that cannot be a
folder (for root too), and ``sarnav show`` of every file ``sarnav show NAME`` writes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading

import pytest
from toy_kind import TESTS, toy_cfg

from sarnav.cli.main import main
from sarnav.montecarlo.assemble import open_results
from sarnav.scenarios.registry import list_scenarios
from sarnav.tomlio import dump_toml, parse_toml


def _one_line(capsys, code: int, start: str) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("sarnav: notice:")]
    assert code == 2 and len(lines) == 1 and lines[0].startswith(start), err
    assert "Traceback" not in err
    return lines[0]


@pytest.fixture
def toy_file(tmp_path):
    p = tmp_path / "toy.toml"
    p.write_text(dump_toml(toy_cfg(runs=2, steps=10)))
    return p


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
@pytest.mark.parametrize("name", ["x.toml", "x"])
def test_a_fifo_as_the_scenario_file_is_refused_without_blocking(tmp_path, capsys, monkeypatch, name):
    # 0.1 opened it and blocked forever (nobody writes to the pipe); "./x" is a path, "x.toml" a file name
    monkeypatch.chdir(tmp_path)
    os.mkfifo(name)
    arg = name if name.endswith(".toml") else f"./{name}"
    result = {}
    worker = threading.Thread(target=lambda: result.update(code=main(["show", arg])), daemon=True)
    worker.start()
    worker.join(timeout=20)
    if worker.is_alive():  # unblock the reader so the test process can end, then fail
        with open(name, "w"):
            pass
        pytest.fail("sarnav show blocked on a FIFO")
    _one_line(capsys, result["code"], f"sarnav: error: {arg}: is not a regular file")


@pytest.mark.parametrize("seed", [2**63, 2**64, -1])
def test_seeds_outside_0_2_63_are_refused_before_anything_runs(tmp_path, capsys, toy_file, seed):
    # 2**64 simulated every run and crashed writing the netCDF attribute
    out = tmp_path / "o"
    code = main(["run", str(toy_file), "--seed", str(seed), "--out", str(out), "--quiet", "--executor", "serial"])
    _one_line(capsys, code, f"sarnav: error: campaign.seed: must be an integer in [0, 2^63 - 1], got {seed}")
    assert not out.exists()


def test_the_largest_seed_runs_and_is_stored_exactly(tmp_path, capsys, toy_file):
    out = tmp_path / "o"
    assert main(["run", str(toy_file), "--seed", str(2**63 - 1), "--out", str(out), "--quiet", "--no-figures",
                 "--executor", "serial"]) == 0
    assert int(open_results(out / "results.nc").attrs["seed"]) == 2**63 - 1
    assert json.loads((out / "summary.json").read_text())["seed"] == 2**63 - 1


@pytest.mark.parametrize("address", ["not a url", "tcp://host", "tcp://host:99999", "http://host:8786"])
def test_a_scheduler_that_is_not_an_address_is_one_line(tmp_path, capsys, toy_file, address):
    # "not a url" was a traceback from inside distributed
    code = main(["run", str(toy_file), "--scheduler", address, "--out", str(tmp_path / "o"), "--quiet"])
    _one_line(capsys, code, "sarnav: error: --scheduler: must be an address like tcp://host:8786")


@pytest.mark.parametrize("scenario, key", [("telemetry", "measurements.alt_3sigma"),
                                           ("rda-nav", "altimeter.sigma_3sigma")])
def test_a_noise_3sigma_of_1e300_is_one_line(tmp_path, capsys, scenario, key):
    # 0.1: OverflowError squaring it
    for command in ("show", "run"):
        argv = [command, scenario, "--set", f"{key}=1e300"]
        if command == "run":
            argv += ["--runs", "1", "--out", str(tmp_path / "o"), "--quiet"]
        _one_line(capsys, main(argv), f"sarnav: error: {key}: must be in [1e-06, 1e+09]")


@pytest.mark.parametrize("argv, line", [
    (["run", "telemetry", "--runs", "x"], "sarnav: error: --runs: invalid int value: 'x'"),
    (["run", "telemetry", "--bogus"], "sarnav: error: arguments: unrecognized arguments: --bogus"),
    (["run", "telemetry", "--executor", "gpu"], "sarnav: error: --executor: invalid choice: 'gpu'"),
    (["bogus"], "sarnav: error: COMMAND: invalid choice: 'bogus'"),
])
def test_argument_errors_are_the_one_documented_line_not_the_usage(argv, line):
    # through the installed command: argparse printed its usage line and its own "sarnav: error:" format
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-m", "sarnav.cli.main", *argv], capture_output=True, text=True, env=env,
                          timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith(line), proc.stderr
    assert "usage:" not in proc.stderr


def test_a_corrupt_manifest_without_resume_restarts_the_same_scenario_cleanly(tmp_path, capsys, toy_file):
    # intended: without --resume every run is simulated anyway, so a folder that says (sarnav.json) it holds this
    # scenario is simply rewritten; with --resume the manifest is needed and its damage is one line
    out = tmp_path / "o"
    argv = ["run", str(toy_file), "--out", str(out), "--quiet", "--no-figures", "--executor", "serial"]
    assert main(argv) == 0
    before = open_results(out / "results.nc")["error"].values.copy()
    (out / "campaign.json").write_text("{not json")
    _one_line(capsys, main(argv + ["--resume"]), "sarnav: error: ")
    assert main(argv) == 0
    assert json.loads((out / "campaign.json").read_text())["complete"] is True
    assert (open_results(out / "results.nc")["error"].values == before).all()


def test_a_corrupt_manifest_of_unknown_origin_is_refused_unless_overwrite(tmp_path, capsys, toy_file):
    # no sarnav.json either (a 0.1 folder, or both damaged): whose results they are is unknown, so not replaced
    out = tmp_path / "o"
    argv = ["run", str(toy_file), "--out", str(out), "--quiet", "--no-figures", "--executor", "serial"]
    assert main(argv) == 0
    (out / "campaign.json").write_text("{not json")
    (out / "sarnav.json").unlink()
    line = _one_line(capsys, main(argv), "sarnav: error: --out: ")
    assert "unknown origin" in line and "--overwrite" in line
    assert main(argv + ["--overwrite"]) == 0


@pytest.mark.parametrize("command", ["run", "image"])
def test_an_out_below_a_regular_file_is_one_line_for_root_too(tmp_path, capsys, toy_file, command):
    # the read-only-folder test skips as root; a path through a regular file fails for every user
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    if command == "run":
        argv = ["run", str(toy_file), "--out", str(blocker / "sub"), "--quiet", "--executor", "serial"]
    else:
        argv = ["image", "point-target", "--out", str(blocker / "sub"), "--set", "trajectory.duration=0.2"]
    _one_line(capsys, main(argv), "sarnav: error: --out: cannot create or write in output directory")
    assert blocker.read_text() == ""


@pytest.mark.parametrize("name", [n for n, _ in list_scenarios()])
def test_show_of_a_file_written_by_show_round_trips(tmp_path, capsys, name):
    # 0.1 rejected the image scenario file `sarnav show point-target` wrote
    assert main(["show", name]) == 0
    text = capsys.readouterr().out
    f = tmp_path / f"{name}.toml"
    f.write_text(text)
    assert main(["show", str(f)]) == 0
    again = capsys.readouterr()
    assert again.out == text and again.err == ""
    assert parse_toml(again.out) == parse_toml(text)
