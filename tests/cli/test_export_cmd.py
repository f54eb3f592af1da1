"""``sarnav.cli.export_cmd``: its arguments and defaults, and the one-line errors (exit status 2) it gives before
any simulation: missing or malformed --run, a run outside the campaign, a kind it cannot export, a bad
--reference; none of them creates --out."""

from __future__ import annotations

import pytest
from helpers import assert_one_line_error

from sarnav.cli import export_cmd
from sarnav.cli.main import build_parser, main
from sarnav.tomlio import dump_toml
from toy_kind import toy_cfg


_one_line = assert_one_line_error


def test_arguments_and_defaults():
    """--run and --out required; --reference cphd-pass by default; --set repeatable."""
    a = build_parser().parse_args(["export", "rda-nav", "--run", "3", "--out", "o", "--set", "a=1", "--set", "b=2"])
    assert (a.scenario, a.run_id, a.out, a.reference, a.overwrite, a.quiet) == ("rda-nav", 3, "o", "cphd-pass",
                                                                                 False, False)
    assert a.overrides == ["a=1", "b=2"] and a.seed is None and a.runs is None and a.handler is export_cmd.run


@pytest.mark.parametrize("argv, words", [
    (["export", "rda-nav", "--out", "OUT"], ["--run"]),
    (["export", "rda-nav", "--run", "one", "--out", "OUT"], ["--run", "invalid int value"]),
    (["export", "rda-nav", "--run", "0"], ["--out"]),
    (["export", "rda-nav", "--run", "0", "--out", "OUT", "--reference", "dem"], ["--reference", "invalid choice"]),
])
def test_argument_errors(tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    _one_line(capsys, main([str(out) if a == "OUT" else a for a in argv]), *words)
    assert not out.exists()


@pytest.mark.parametrize("run_id", [2, -1])
def test_run_outside_the_campaign(tmp_path, capsys, run_id):
    """--run must be 0 .. campaign.runs - 1 (here --runs 2)."""
    out = tmp_path / "out"
    _one_line(capsys, main(["export", "rda-nav", "--runs", "2", "--run", str(run_id), "--out", str(out)]),
              "--run: must be a run of the campaign, 0 to 1 (campaign.runs = 2)", f"got {run_id}")
    assert not out.exists()


def test_a_kind_without_recordings_is_refused(tmp_path, capsys):
    """A scenario of another kind (the toy kind): scenario.kind names the kinds export writes."""
    f = tmp_path / "toy.toml"
    f.write_text(dump_toml(toy_cfg(runs=2, steps=5)))
    out = tmp_path / "out"
    _one_line(capsys, main(["export", str(f), "--run", "0", "--out", str(out)]), "scenario.kind: export writes the kinds")
    assert not out.exists()


def test_unknown_scenario_and_bad_override(tmp_path, capsys):
    _one_line(capsys, main(["export", "no-such", "--run", "0", "--out", str(tmp_path / "o")]), "unknown scenario")
    _one_line(capsys, main(["export", "rda-nav", "--run", "0", "--out", str(tmp_path / "o"), "--set", "nope"]),
              "--set")
