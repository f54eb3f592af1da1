"""``sarnav.cli.figures_cmd``: its argument, what it prints (one path per figure redrawn into DIR/figures, recorded
as sarnav's files) and its one-line errors with exit status 2; on a small toy campaign (tests/toy_kind.py)."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import assert_one_line_error

from sarnav.cli import figures_cmd
from sarnav.cli.main import build_parser, main
from sarnav.montecarlo.campaign import run_campaign
from toy_kind import TOY, toy_cfg


_one_line = assert_one_line_error


def test_argument():
    a = build_parser().parse_args(["figures", "d"])
    assert a.directory == "d" and a.handler is figures_cmd.run


def test_prints_every_figure_it_drew(tmp_path, capsys):
    """A toy campaign without figures: the printed paths are exactly the PNG files now in DIR/figures, stderr empty."""
    d = tmp_path / "toy"
    run_campaign(toy_cfg(runs=3, steps=10), d, TOY, executor="serial", quiet=True)
    assert main(["figures", str(d)]) == 0
    out = capsys.readouterr()
    printed = sorted(Path(p) for p in out.out.split())
    assert printed == sorted((d / "figures").glob("*.png")) and printed
    assert all(p.stat().st_size > 0 for p in printed) and out.err == ""


@pytest.mark.parametrize("case, words", [("missing", "no such directory"), ("file", "not a directory"),
                                         ("empty", "not a sarnav output directory")])
def test_unusable_folders(tmp_path, capsys, case, words):
    d = tmp_path / "d"
    if case == "file":
        d.write_text("x")
    elif case == "empty":
        d.mkdir()
    _one_line(capsys, main(["figures", str(d)]), str(d), words)


def test_no_folder_is_an_argument_error(capsys):
    _one_line(capsys, main(["figures"]), "DIR")
