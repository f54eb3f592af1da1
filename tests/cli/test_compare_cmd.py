"""``sarnav.cli.compare_cmd``: its arguments (two or more folders, --out and its default), what it prints (the two
files the comparison returns) and its one-line errors with exit status 2."""

from __future__ import annotations

from pathlib import Path

from helpers import assert_one_line_error

from sarnav.cli import compare_cmd
from sarnav.cli.main import build_parser, main


_one_line = assert_one_line_error


def test_arguments_and_default_out():
    """DIR is one or more folders; --out defaults to sarnav-out/compare."""
    args = build_parser().parse_args(["compare", "a", "b", "c"])
    assert args.directories == ["a", "b", "c"] and Path(args.out) == Path("sarnav-out") / "compare"
    assert args.handler is compare_cmd.run
    assert build_parser().parse_args(["compare", "a", "b", "--out", "x"]).out == "x"


def test_run_prints_the_html_then_the_csv(monkeypatch, capsys):
    """run passes the folders and --out to report.compare.compare_campaigns and prints its two paths, html first."""
    seen = {}

    def fake(dirs, out):
        seen.update(dirs=dirs, out=out)
        return Path(out) / "compare.html", Path(out) / "compare.csv"

    monkeypatch.setattr("sarnav.report.compare.compare_campaigns", fake)
    assert main(["compare", "d1", "d2", "--out", "o"]) == 0
    assert seen == {"dirs": ["d1", "d2"], "out": "o"}
    assert capsys.readouterr().out.split() == [str(Path("o") / "compare.html"), str(Path("o") / "compare.csv")]


def test_no_directory_is_an_argument_error(capsys):
    _one_line(capsys, main(["compare"]), "DIR")


def test_missing_folders_are_named(tmp_path, capsys):
    """A folder that does not exist: one line naming it; nothing written to --out."""
    d = tmp_path / "nope"
    _one_line(capsys, main(["compare", str(d), str(tmp_path / "nope2"), "--out", str(tmp_path / "o")]),
              str(d), "no such directory")
    assert not (tmp_path / "o").exists()


def test_one_folder_is_not_enough(tmp_path, capsys):
    """compare needs at least two campaigns (checked before the folders are read)."""
    (tmp_path / "c").mkdir()
    _one_line(capsys, main(["compare", str(tmp_path / "c"), "--out", str(tmp_path / "o")]),
              "give at least two campaign directories to compare, got 1")
