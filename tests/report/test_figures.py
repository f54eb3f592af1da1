"""Figures (issue 9 item 8): residual panels scaled to the bulk of the data (a large first update no longer flattens
the rest), units on every axis, colour bars where colour encodes a value."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from sarnav.report import figures as F
from sarnav.report.figures import RESIDUAL_MARGIN, residual_figure, residual_limit


def _residual_ds(first=1000.0, bulk=0.5, s3=3.0, runs=5, updates=50):
    """Two measurements; in every run the first update's residual is ``first`` and its 3σ 100 × ``s3``, the
    others alternate ±``bulk`` inside a constant 3σ of ``s3``."""
    res = np.empty((runs, updates, 2))
    res[:] = bulk * np.where(np.arange(updates) % 2, 1.0, -1.0)[None, :, None]
    res[:, 0, :] = first
    rsig = np.full((runs, updates, 2), s3 / 3.0)
    rsig[:, 0, :] = 100 * s3 / 3.0
    return xr.Dataset(
        {"residual": (("run", "update", "meas"), res), "residual_sigma": (("run", "update", "meas"), rsig)},
        coords={"update_time": ("update", np.arange(1.0, updates + 1)), "meas": ("meas", ["range", "rate"]),
                "meas_units": ("meas", ["m", "m/s"])})


def test_residual_limit_is_the_bulk_not_the_first_update():
    ds = _residual_ds()
    res = ds["residual"].values[:, :, 0]
    s3 = 3 * ds["residual_sigma"].values[:, :, 0].mean(axis=0)
    # per-update envelope max(|r|, 3σ) is 3 at 49 of 50 updates: its 80th percentile is 3
    assert residual_limit(res, s3) == pytest.approx(RESIDUAL_MARGIN * 3.0)
    assert residual_limit(np.full((2, 3), np.nan), np.full(3, np.nan)) is None


def test_residual_panels_use_the_robust_limits_and_mark_what_they_clip():
    fig = residual_figure(_residual_ds())
    axes = fig.axes
    for ax in axes:
        lo, hi = ax.get_ylim()
        assert hi == pytest.approx(RESIDUAL_MARGIN * 3.0) and lo == pytest.approx(-hi)  # autoscale: ±1000+
        assert ax.get_title(loc="left").startswith("5 of 250 residuals beyond")
    assert [ax.get_ylabel() for ax in axes] == ["range [m]", "rate [m/s]"]
    assert axes[-1].get_xlabel() == "time [s]"


def _capture(monkeypatch, module):
    figs = []
    monkeypatch.setattr(module, "save_png", lambda fig, path, dpi=110: figs.append(fig) or str(path))
    return figs


def _assert_units(fig) -> None:
    """Every axes with a y label has a unit in brackets; the bottom axes of each column has an x label with one."""
    for ax in fig.axes:
        if ax.get_ylabel():
            assert "[" in ax.get_ylabel() and ax.get_ylabel().endswith("]"), ax.get_ylabel()
        else:  # only image panels share a colour bar's label; none of ours lacks a y label
            pytest.fail(f"axes without a y label in {fig.get_suptitle()!r}")
    assert any("[" in ax.get_xlabel() for ax in fig.axes)


def test_campaign_figures_have_units_on_every_axis(small_campaigns, monkeypatch, tmp_path):
    from sarnav.montecarlo.assemble import open_results

    figs = _capture(monkeypatch, F)
    ds = open_results(small_campaigns["tactical"] / "results.nc")
    F.write_campaign_figures(ds, tmp_path)
    assert len(figs) == 4
    for fig in figs:
        _assert_units(fig)


def test_overlay_figures_have_units(small_campaigns):
    from sarnav.montecarlo.assemble import open_results
    from sarnav.report.overlays import consistency_figure, state_overlay_figure

    ds = open_results(small_campaigns["tactical"] / "results.nc")
    _assert_units(consistency_figure([("a", ds)]))
    _assert_units(state_overlay_figure([("a", ds), ("b", ds)], ["pN", "vE"], ["m", "m/s"], "t"))


def test_study_figure_y_axes_carry_units(monkeypatch, tmp_path):
    from sarnav.report import study_figure as S

    figs = _capture(monkeypatch, S)
    t = np.linspace(0, 1, 5)
    sig3 = np.ones((5, 3))
    S.plot_study_comparison([("a", t, sig3, "-")], ["pN", "vE", "b_alt"], ["pN", "vE", "b_alt"], "t", tmp_path / "x")
    assert [ax.get_ylabel() for ax in figs[0].axes] == ["pN 3σ [m]", "vE 3σ [m/s]", "b_alt 3σ"]  # no guess for b_alt
    S.plot_study_comparison([("a", t, sig3, "-")], ["pN", "vE", "b_alt"], ["b_alt"], "t", tmp_path / "x",
                            state_units=["m", "m/s", "m"])
    assert [ax.get_ylabel() for ax in figs[1].axes] == ["b_alt 3σ [m]"]


def test_correlation_surface_has_a_colour_bar(monkeypatch, tmp_path):
    from sarnav.report import rda_nav_figures as R
    from sarnav.signal.data import SarImage

    figs = _capture(monkeypatch, R)
    img = SarImage(np.ones((4, 5), complex), np.arange(4.0), 2000 + np.arange(5.0))
    lags = np.arange(-2.0, 3.0)
    cap = {"reference": img, "before": img, "after": img, "correlation": (np.ones((5, 5)), lags, lags), "run": 0,
           "aperture": 3, "speed_hat": 60.1, "autofocus_speed": 60.0, "used": "mapdrift"}
    R.plot_aperture_images(cap, tmp_path / "x.png")
    labels = [ax.get_ylabel() for ax in figs[0].axes]
    assert "|correlation| / peak [-]" in labels and "dB re peak" in labels
