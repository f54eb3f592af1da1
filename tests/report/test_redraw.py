"""``sarnav figures DIR`` (sarnav.report.redraw): the figures of a finished campaign or study drawn again from what
is stored, old PNG files removed, the kind's own figures through its hook, an unresolvable kind a notice.

The standard panels are replaced by a stub here (``cheap_panels``): what is tested is which files are written and
removed; real drawing is covered by tests/cli/test_report_cli.py and test_figures.py."""

from __future__ import annotations

import shutil

import pytest

from sarnav.errors import ConfigError
from sarnav.report.redraw import redraw_figures

STANDARD = ["attitude.png", "position.png", "residuals.png", "velocity.png"]


@pytest.fixture
def cheap_panels(monkeypatch):
    from matplotlib.figure import Figure

    from sarnav.report import figures as F

    monkeypatch.setattr(F, "error_figure", lambda ds, idx, title, max_runs=50: Figure(figsize=(1, 1)))
    monkeypatch.setattr(F, "residual_figure", lambda ds, max_runs=20: Figure(figsize=(1, 1)))


@pytest.fixture
def campaign_copy(small_campaigns, tmp_path, cheap_panels):
    d = tmp_path / "c"
    shutil.copytree(small_campaigns["tactical"], d)
    return d


def test_redraw_replaces_the_figures_folder(campaign_copy):
    figdir = campaign_copy / "figures"
    (figdir / "stale_from_another_scenario.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    (figdir / "position.png").write_bytes(b"not a figure")  # replaced
    done = redraw_figures(campaign_copy)
    assert sorted(p.name for p in figdir.glob("*.png")) == STANDARD
    assert sorted(p.name for p in done.paths) == STANDARD and done.notices == []
    assert (figdir / "position.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_kind_hook_draws_its_figures_and_an_unknown_kind_is_a_notice(campaign_copy):
    class Kind:
        def figures(self, results, outdir):
            path = outdir / "kind_extra.png"
            path.write_bytes(b"\x89PNG\r\n\x1a\n")
            return [str(path)]

    seen = []
    done = redraw_figures(campaign_copy, resolve_kind=lambda name: seen.append(name) or Kind())
    assert seen == ["telemetry"] and "kind_extra.png" in [p.name for p in done.paths]

    def unknown(name):
        raise ConfigError("scenario.kind", f"unknown kind {name!r}")

    done = redraw_figures(campaign_copy, resolve_kind=unknown)
    assert sorted(p.name for p in (campaign_copy / "figures").glob("*.png")) == STANDARD
    assert len(done.notices) == 1 and "only the standard figures" in done.notices[0]


def test_not_a_campaign_is_refused(tmp_path):
    (tmp_path / "sensitivity.csv").write_text("name\n")
    with pytest.raises(ConfigError, match="bpa-sensitivity output: its figure is drawn by `sarnav run`"):
        redraw_figures(tmp_path)


def test_study_redraw_draws_every_case_and_the_comparison(small_study, tmp_path, cheap_panels):
    d = tmp_path / "s"
    shutil.copytree(small_study, d)
    (d / "study_3sigma.png").unlink()
    (d / "study_stale.png").write_bytes(b"x")
    done = redraw_figures(d)
    assert sorted(p.name for p in d.glob("study_*.png")) == ["study_3sigma.png"]
    cases = sorted(p.parent.parent.name for p in done.paths if p.parent.name == "figures")
    assert cases == sorted(["consumer"] * 4 + ["tactical"] * 4)
