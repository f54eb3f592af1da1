"""``sarnav.cli.navigate_cmd``: argument handling and its one-line errors (exit status 2) only; what navigate writes
is tested in tests/recording/."""

from __future__ import annotations

import pytest
from helpers import assert_one_line_error

from sarnav.cli import navigate_cmd
from sarnav.cli.main import build_parser, main


_one_line = assert_one_line_error


def test_arguments_and_defaults():
    """DIR and --out; --config, repeatable --set, --overwrite, --quiet, --no-report off by default."""
    a = build_parser().parse_args(["navigate", "rec", "--out", "o"])
    assert (a.recording, a.out, a.config, a.overrides, a.overwrite, a.quiet, a.no_report) == \
        ("rec", "o", None, [], False, False, False)
    a = build_parser().parse_args(["navigate", "rec", "--out", "o", "--config", "n.toml", "--set", "x=1",
                                   "--set", "y=2", "--no-report", "--quiet", "--overwrite"])
    assert a.config == "n.toml" and a.overrides == ["x=1", "y=2"] and a.no_report and a.quiet and a.overwrite
    assert a.handler is navigate_cmd.run


@pytest.mark.parametrize("argv, words", [
    (["navigate", "REC"], ["--out"]),
    (["navigate", "--out", "OUT"], ["DIR"]),
    (["navigate", "REC", "--out", "OUT", "--bogus"], ["unrecognized arguments: --bogus"]),
])
def test_argument_errors(tmp_path, capsys, argv, words):
    argv = [str(tmp_path / "rec") if a == "REC" else str(tmp_path / "out") if a == "OUT" else a for a in argv]
    _one_line(capsys, main(argv), *words)
    assert not (tmp_path / "out").exists()


def test_a_missing_recording_is_named(tmp_path, capsys):
    """A recording folder that does not exist: one line saying so; --out not created."""
    _one_line(capsys, main(["navigate", str(tmp_path / "none"), "--out", str(tmp_path / "out")]), "is not a folder")
    assert not (tmp_path / "out").exists()


def test_a_folder_without_a_manifest_is_refused(tmp_path, capsys):
    """An empty folder is not a recording (no flight.toml): one line, exit 2, --out not created."""
    (tmp_path / "rec").mkdir()
    _one_line(capsys, main(["navigate", str(tmp_path / "rec"), "--out", str(tmp_path / "out")]), "flight.toml")
    assert not (tmp_path / "out").exists()
