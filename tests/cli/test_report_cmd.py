"""``sarnav.cli.report_cmd``: its argument, what it prints (the path of DIR/report.html) and its one-line errors with
exit status 2; on a small toy campaign (tests/toy_kind.py)."""

from __future__ import annotations

import pytest
from helpers import assert_one_line_error

from sarnav.cli import report_cmd
from sarnav.cli.main import build_parser, main
from sarnav.montecarlo.campaign import run_campaign
from toy_kind import TOY, toy_cfg


_one_line = assert_one_line_error


def test_argument():
    a = build_parser().parse_args(["report", "d"])
    assert a.directory == "d" and a.handler is report_cmd.run


def test_prints_the_page_it_wrote(tmp_path, capsys, monkeypatch):
    """The printed line is DIR/report.html, which exists; write_report is called with DIR (its drawing is replaced
    by a stub page here: report.html's content is tested in tests/report/)."""
    d = tmp_path / "toy"
    run_campaign(toy_cfg(runs=2, steps=5), d, TOY, executor="serial", quiet=True)
    seen = []

    def stub(directory):
        seen.append(directory)
        p = d / "report.html"
        p.write_text("<html></html>")
        return p

    monkeypatch.setattr("sarnav.report.html.write_report", stub)
    assert main(["report", str(d)]) == 0
    assert capsys.readouterr().out == f"{d / 'report.html'}\n" and seen == [str(d)]


@pytest.mark.parametrize("case, words", [("missing", "no such directory"), ("file", "not a directory"),
                                         ("empty", "not a sarnav output directory")])
def test_unusable_folders(tmp_path, capsys, case, words):
    d = tmp_path / "d"
    if case == "file":
        d.write_text("x")
    elif case == "empty":
        d.mkdir()
    _one_line(capsys, main(["report", str(d)]), str(d), words)
    assert not (d / "report.html").exists()


def test_no_folder_is_an_argument_error(capsys):
    _one_line(capsys, main(["report"]), "DIR")
