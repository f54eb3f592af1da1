"""The ``sarnav`` command: subcommands, outputs, and one-line errors with exit status 2."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sarnav.cli.main import COMMANDS, main
from sarnav.tomlio import dump_toml, parse_toml
from sarnav.scenarios.registry import list_scenarios
from toy_kind import TESTS, toy_cfg


@pytest.fixture
def toy_file(tmp_path):
    p = tmp_path / "toy.toml"
    p.write_text(dump_toml(toy_cfg(runs=6, steps=20)))
    return p


def one_error_line(capsys, code, pattern):
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sarnav: error: "), err
    assert pattern in lines[0], lines[0]
    assert "Traceback" not in err


def test_commands_are_modules_with_parser_and_run():
    from sarnav.cli import run_cmd
    from sarnav.montecarlo.executors import EXECUTORS

    for mod in COMMANDS:
        assert callable(mod.add_parser) and callable(mod.run) and mod.NAME
    assert run_cmd.EXECUTORS == EXECUTORS


def test_scenarios_lists_every_registered_name(capsys):
    assert main(["scenarios"]) == 0
    from sarnav.cli.image_cmd import IMAGE_SCENARIOS
    from sarnav.scenarios.registry import SCENARIOS

    out = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in out] == [n for n, _ in list_scenarios()]
    assert list(IMAGE_SCENARIOS) == [e.name for e in SCENARIOS if e.kind == "image"]  # the image command's help


def test_show_prints_toml_that_round_trips(capsys, toy_file):
    assert main(["show", str(toy_file), "--set", "toy.q=0.25"]) == 0
    cfg = parse_toml(capsys.readouterr().out)
    assert cfg["toy"]["q"] == 0.25 and cfg["campaign"]["runs"] == 6


def test_run_writes_results_summary_figures(capsys, toy_file, tmp_path):
    out = tmp_path / "out"
    code = main(["run", str(toy_file), "--out", str(out), "--executor", "serial", "--runs", "5", "--seed", "3", "--quiet"])
    assert code == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["runs"] == 5 and s["seed"] == 3 and s["complete"] is True
    assert (out / "results.nc").is_file()
    figs = sorted(p.name for p in (out / "figures").glob("*.png"))
    assert figs == ["residuals.png", "states_1.png"]


@pytest.mark.parametrize(
    "extra, pattern",
    [
        (["--runs", "-3"], "campaign.runs: must be an integer in [1, 100000], got -3"),
        (["--set", "toy.nope=1"], "toy.nope: unknown key"),
        (["--set", "toy.q=-1"], "toy.q: must be > 0"),
        (["--set", "toy.q=nan"], "toy.q: must be a finite number"),
        (["--set", "toy.q"], "--set: expected key=value"),
        (["--workers", "0"], "--workers: must be an integer >= 1"),
        (["--chunk-size", "0"], "--chunk-size: must be an integer >= 1"),
        (["--out", "/dev/null/x"], "--out: cannot create or write in output directory"),
        (["--scheduler", "tcp://127.0.0.1:9", "--executor", "serial"], "--scheduler: needs --executor dask"),
    ],
)
def test_bad_input_one_line_exit_2(capsys, toy_file, tmp_path, extra, pattern):
    code = main(["run", str(toy_file), "--out", str(tmp_path / "o"), "--quiet"] + extra)
    one_error_line(capsys, code, pattern)


def test_unknown_scenario_and_malformed_toml(capsys, tmp_path):
    one_error_line(capsys, main(["run", "no-such-scenario"]), "scenario: unknown scenario 'no-such-scenario'")
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenario]\nname = \n")
    one_error_line(capsys, main(["show", str(bad)]), f"{bad}: malformed TOML")
    one_error_line(capsys, main(["run", str(tmp_path / "missing.toml")]), "cannot read scenario file")


def test_real_subprocess_bad_input_and_help(tmp_path, toy_file):
    """The installed ``sarnav`` command: each kind of bad input -> exactly one stderr line, status 2."""
    exe = Path(sys.executable).with_name("sarnav")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "sarnav.cli.main"]
    env = dict(os.environ, PYTHONPATH=str(TESTS) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenario]\nname = \n")
    out = ["--out", str(tmp_path / "o")]
    cases = [
        (["run", str(toy_file), "--runs", "-3"] + out, "sarnav: error: campaign.runs: must be an integer in [1, 100000], got -3"),
        (["run", "no-such-scenario"] + out, "sarnav: error: scenario: unknown scenario 'no-such-scenario'"),
        (["run", str(toy_file), "--set", "toy.nope=1"] + out, "sarnav: error: toy.nope: unknown key"),
        (["run", str(toy_file), "--set", "toy.q=0"] + out, "sarnav: error: toy.q: must be > 0"),
        (["run", str(toy_file), "--set", "toy.r1=nan"] + out, "sarnav: error: toy.r1: must be a finite number"),
        (["run", str(bad)] + out, f"sarnav: error: {bad}: malformed TOML"),
    ]
    procs = [subprocess.Popen(cmd + args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for args, _ in cases]
    for proc, (args, want) in zip(procs, cases):
        stdout, stderr = proc.communicate(timeout=120)
        assert proc.returncode == 2, (args, stderr)
        lines = stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(want), (args, stderr)
        assert stdout == ""
    r = subprocess.run(cmd + ["scenarios"], capture_output=True, text=True, env=env, timeout=60)
    assert r.returncode == 0 and "telemetry" in r.stdout


# --------------------------------------------------------------------------- with the telemetry kind
def test_telemetry_bad_values_through_main(capsys, tmp_path):
    for extra, pattern in [
        (["--set", "imu.tau_accel=0"], "imu.tau_accel: must be finite and > 0"),
        (["--set", "measurements.tau_range=-5"], "measurements.tau_range:"),
        (["--set", "imu.tau_gyro=nan"], "imu.tau_gyro: must be a finite number"),
        (["--set", "imu.no_such_key=1"], "imu.no_such_key: unknown key"),
        (["--runs", "0"], "campaign.runs: must be an integer in [1, 100000], got 0"),
    ]:
        one_error_line(capsys, main(["run", "--out", str(tmp_path / "o"), "--quiet"] + extra), pattern)


def test_telemetry_show_and_small_run_with_figures(capsys, tmp_path):
    assert main(["show", "telemetry", "--set", "imu.grade=consumer"]) == 0
    cfg = parse_toml(capsys.readouterr().out)
    assert cfg["scenario"]["kind"] == "telemetry" and cfg["imu"]["grade"] == "consumer"
    out = tmp_path / "tel"
    code = main(["run", "telemetry", "--runs", "2", "--set", "trajectory.duration=4", "--executor", "serial", "--out", str(out)])
    assert code == 0
    printed = capsys.readouterr().out
    assert "telemetry: 2 runs" in printed and "mean NEES" in printed
    figs = sorted(p.name for p in (out / "figures").glob("*.png"))
    assert figs == ["attitude.png", "position.png", "residuals.png", "velocity.png"]
    s = json.loads((out / "summary.json").read_text())
    assert set(s["residuals"]) == {"alt", "range", "rate"} and s["nees"]["dof"] == 18


def test_help_descriptions_are_plain_text():
    """``sarnav SUB --help`` shows argparse text: no reStructuredText markup from docstrings."""
    from sarnav.cli.main import build_parser

    parser = build_parser()
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sub in subs.choices.items():
        assert sub.description and "``" not in sub.description, name
