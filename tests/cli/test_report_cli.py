"""``sarnav report``, ``sarnav compare``, ``sarnav figures`` through ``sarnav.cli.main.main``: what they print, and
one line ``sarnav: error: <directory>: ...`` with exit status 2 for every directory they cannot use."""

from __future__ import annotations

import shutil

import pytest

from sarnav.cli.main import COMMANDS, main


def test_commands_are_registered():
    assert {"report", "compare", "figures"} <= {m.NAME for m in COMMANDS}


def test_report_and_figures_print_what_they_wrote(small_campaigns, tmp_path, capsys):
    d = tmp_path / "c"
    shutil.copytree(small_campaigns["tactical"], d)
    assert main(["report", str(d)]) == 0
    assert capsys.readouterr().out.strip() == str(d / "report.html")
    assert main(["figures", str(d)]) == 0
    out = capsys.readouterr()
    assert sorted(line.rsplit("/", 1)[1] for line in out.out.split()) == [
        "attitude.png", "position.png", "residuals.png", "velocity.png"]
    assert out.err == ""


def test_compare_prints_its_two_files(compared_campaigns):
    out, printed = compared_campaigns
    assert printed == [str(out / "compare.html"), str(out / "compare.csv")]


def _bad_dir(case, small_campaigns, tmp_path):
    d = tmp_path / "bad"
    if case == "missing":
        return d, "no such directory"
    if case == "file":
        d.write_text("x")
        return d, "not a directory"
    if case == "empty":
        d.mkdir()
        return d, "not a sarnav output directory"
    shutil.copytree(small_campaigns["consumer"], d)
    if case == "unfinished":
        (d / "results.nc").unlink()
        (d / "INCOMPLETE").write_text("")
        return d, "an unfinished campaign (4 of 4 runs stored"
    if case == "summary":
        (d / "summary.json").write_text('{"runs": 4,')
        return d, "summary.json does not match the SHA-256 recorded in campaign.json"  # issue 31: checksummed
    (d / "results.nc").write_bytes(b"garbage" * 100)
    return d, "results.nc does not match the SHA-256 recorded in campaign.json"


@pytest.mark.parametrize("command", ["report", "figures", "compare"])
@pytest.mark.parametrize("case", ["missing", "file", "empty", "unfinished", "summary", "results"])
def test_unusable_directories_are_one_line_errors(command, case, small_campaigns, tmp_path, capsys):
    d, message = _bad_dir(case, small_campaigns, tmp_path)
    argv = [command, str(d)]
    if command == "compare":
        argv = [command, str(small_campaigns["tactical"]), str(d), "--out", str(tmp_path / "cmp")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"sarnav: error: {d}: {message}") and err.count("\n") == 1, err
    assert not (tmp_path / "cmp").exists()


def test_compare_needs_two_campaigns_and_report_needs_a_writable_folder(small_campaigns, tmp_path, capsys):
    assert main(["compare", str(small_campaigns["tactical"]), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == "sarnav: error: DIR: give at least two campaign directories to compare, got 1\n"
    d = tmp_path / "ro"
    shutil.copytree(small_campaigns["tactical"], d)
    (d / "report.html").unlink(missing_ok=True)  # other tests may have written one into the fixture
    (d / "report.html").mkdir()  # a folder in the way: works as root too, unlike a read-only mode
    assert main(["report", str(d)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"sarnav: error: {d}: cannot write {d / 'report.html'}") and err.count("\n") == 1
    assert [p.name for p in d.iterdir() if p.name.startswith(".") and p.name != ".sarnav.lock"] == []  # no temporary left
