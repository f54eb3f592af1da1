"""``sarnav.cli.scenarios_cmd``: the list of registered scenarios, one aligned line each, through ``main`` and the
console script ``entry``."""

from __future__ import annotations

import sys

import pytest

from sarnav.cli import scenarios_cmd
from sarnav.cli.main import build_parser, entry, main
from sarnav.scenarios.registry import list_scenarios


def test_lines_are_names_padded_to_the_longest_then_the_description(capsys):
    """Each line: name left-aligned to the longest name, two spaces, its description, in registry order."""
    assert main(["scenarios"]) == 0
    rows = list_scenarios()
    width = max(len(n) for n, _ in rows)
    assert capsys.readouterr().out.splitlines() == [n + " " * (width - len(n)) + "  " + d for n, d in rows]


def test_console_script_exits_zero(capsys, monkeypatch):
    """entry() exits with status 0 and the same listing."""
    monkeypatch.setattr(sys, "argv", ["sarnav", "scenarios"])
    with pytest.raises(SystemExit) as ex:
        entry()
    assert ex.value.code == 0
    assert len(capsys.readouterr().out.splitlines()) == len(list_scenarios())


def test_takes_no_argument(capsys):
    """An extra argument: one line, exit 2."""
    assert build_parser().parse_args(["scenarios"]).handler is scenarios_cmd.run
    assert main(["scenarios", "extra"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sarnav: error: ") and "unrecognized arguments: extra" in err and err.count("\n") == 1
