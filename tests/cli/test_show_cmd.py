"""``sarnav.cli.show_cmd``: the scenario printed as TOML (overrides applied, round trip through the reader) and its
one-line errors with exit status 2, through ``main`` and the console script ``entry``."""

from __future__ import annotations

import sys

import pytest
from helpers import assert_one_line_error

from sarnav.cli import show_cmd
from sarnav.cli.main import build_parser, entry, main
from sarnav.scenarios.config import load_scenario
from sarnav.tomlio import dump_toml, parse_toml
from toy_kind import toy_cfg


_one_line = assert_one_line_error


@pytest.fixture
def toy_file(tmp_path):
    p = tmp_path / "toy.toml"
    p.write_text(dump_toml(toy_cfg(runs=3, steps=10)))
    return p


def test_arguments():
    a = build_parser().parse_args(["show", "x", "--set", "a=1", "--set", "b=2"])
    assert a.scenario == "x" and a.overrides == ["a=1", "b=2"] and a.handler is show_cmd.run


def test_prints_the_file_with_overrides(toy_file, capsys):
    """The printed TOML is the scenario with both overrides applied; nothing on stderr."""
    assert main(["show", str(toy_file), "--set", "toy.q=0.25", "--set", "campaign.seed=11"]) == 0
    out = capsys.readouterr()
    cfg = parse_toml(out.out)
    want = toy_cfg(runs=3, steps=10)
    want["toy"]["q"], want["campaign"]["seed"] = 0.25, 11
    assert cfg == want and out.err == ""


def test_registered_scenario_round_trips(tmp_path, capsys):
    """Printing a registered scenario and reading the text back gives the same configuration."""
    assert main(["show", "telemetry"]) == 0
    f = tmp_path / "t.toml"
    f.write_text(capsys.readouterr().out)
    assert load_scenario(str(f)) == load_scenario("telemetry")


@pytest.mark.parametrize("argv, words", [
    (["show"], ["SCENARIO"]),
    (["show", "no-such-scenario"], ["unknown scenario 'no-such-scenario'"]),
    (["show", "FILE", "--set", "toy.q"], ["--set: expected key=value"]),
    (["show", "MISSING"], ["cannot read scenario file"]),
])
def test_errors_are_one_line(toy_file, tmp_path, capsys, argv, words):
    argv = [str(toy_file) if a == "FILE" else str(tmp_path / "missing.toml") if a == "MISSING" else a for a in argv]
    _one_line(capsys, main(argv), *words)


def test_console_script_exits_two_on_error(capsys, monkeypatch):
    """entry(): exit status 2 and one error line for an unknown scenario."""
    monkeypatch.setattr(sys, "argv", ["sarnav", "show", "no-such-scenario"])
    with pytest.raises(SystemExit) as ex:
        entry()
    assert ex.value.code == 2
    _one_line(capsys, 2, "unknown scenario")
