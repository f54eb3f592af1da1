"""``report.spacecraft_figures``: the paper-style panels (every run, sample mean, predicted and sample 3-sigma read
back from the artists and recomputed here), the campaign figures written per block, the sharpness curve and the
registration figure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import assert_png, keep_saved_figures
import xarray as xr

from sarnav.report import spacecraft_figures as scf


@pytest.fixture
def drawn(monkeypatch):
    """The Figure objects the module saves, still written through the real save_png."""
    return keep_saved_figures(monkeypatch, scf)


_png = assert_png


def test_panels_plot_runs_mean_predicted_and_sample_three_sigma():
    """Per component: R grey run lines, then the sample mean, +-3 x mean sigma, +-3 x sample std (ddof 1); the y
    range 1.5 x the largest envelope from t_scale on."""
    rng = np.random.default_rng(0)
    R, T = 4, 20
    t = np.arange(T, dtype=float)
    err = rng.normal(size=(R, T, 2)) * np.array([1.0, 5.0])
    sig = rng.uniform(0.5, 2.0, size=(R, T, 2))
    sig[:, :3] = 100.0  # the initial sigma: excluded from the y range by t_scale
    fig = scf.paper_style_panels(t, err, sig, ["a", "b"], "T", "m", t_scale=3.0)
    for k, ax in enumerate(fig.axes):
        lines = ax.lines
        assert len(lines) == R + 5
        for r in range(R):
            np.testing.assert_array_equal(lines[r].get_ydata(), err[r, :, k])
        mean, pred, samp = err.mean(0)[:, k], 3 * sig.mean(0)[:, k], 3 * err.std(0, ddof=1)[:, k]
        np.testing.assert_allclose(lines[R].get_ydata(), mean, rtol=1e-12)
        np.testing.assert_allclose(lines[R + 1].get_ydata(), pred, rtol=1e-12)
        np.testing.assert_allclose(lines[R + 2].get_ydata(), -pred, rtol=1e-12)
        np.testing.assert_allclose(lines[R + 3].get_ydata(), samp, rtol=1e-12)
        np.testing.assert_allclose(lines[R + 4].get_ydata(), -samp, rtol=1e-12)
        top = 1.5 * max(pred[3:].max(), samp[3:].max())
        np.testing.assert_allclose(ax.get_ylim(), (-top, top), rtol=1e-12)
    assert fig._suptitle.get_text() == f"T: {R} of {R} runs"


def test_panels_thin_the_runs_and_survive_one_run():
    """max_runs thins the grey lines; with one run the sample 3-sigma is undefined (NaN) and nothing fails."""
    err, sig = np.zeros((30, 5, 1)), np.ones((30, 5, 1))
    fig = scf.paper_style_panels(np.arange(5.0), err, sig, ["x"], "T", "m", max_runs=10)
    assert len(fig.axes[0].lines) == 10 + 5
    one = scf.paper_style_panels(np.arange(5.0), err[:1], sig[:1], ["x"], "T", "m")
    assert np.all(np.isnan(one.axes[0].lines[-1].get_ydata()))


def _campaign(ric: bool):
    rng = np.random.default_rng(1)
    R, T = 3, 12
    states = ["rX", "rY", "rZ", "vX", "vY", "vZ", "muX", "muY", "muZ"]
    data = {"error": (("run", "time", "state"), rng.normal(size=(R, T, 9)) * 1e-3),
            "sigma": (("run", "time", "state"), rng.uniform(1e-3, 2e-3, size=(R, T, 9))),
            "update_time": (("update",), [2.0, 4.0])}
    coords = {"time": np.arange(T, dtype=float), "state": states}
    if ric:
        data["error_ric"] = (("run", "time", "ric"), rng.normal(size=(R, T, 6)))
        data["sigma_ric"] = (("run", "time", "ric"), rng.uniform(1, 2, size=(R, T, 6)))
        coords["ric"] = ["pR", "pI", "pC", "vR", "vI", "vC"]
    return xr.Dataset(data, coords=coords)


def test_campaign_figures_per_block(tmp_path, drawn):
    """Three ECEF figures (misalignment shown in degrees) and two RIC figures; the curves are the dataset's values of
    the block's states."""
    ds = _campaign(ric=True)
    paths = scf.write_spacecraft_figures(ds, tmp_path)
    stems = ["sc_position_ecef", "sc_velocity_ecef", "sc_misalignment", "sc_position_ric", "sc_velocity_ric"]
    assert [Path(p).name for p in paths] == [f"{s}.png" for s in stems]
    for p in paths:
        _png(p)
    mis = drawn[2].axes[2].lines[0].get_ydata()  # muZ of run 0, in degrees
    np.testing.assert_allclose(mis, np.degrees(ds["error"].values[0, :, 8]), rtol=1e-12)
    np.testing.assert_array_equal(drawn[4].axes[1].lines[2].get_ydata(), ds["error_ric"].values[2, :, 4])


def test_campaign_without_ric_gets_the_ecef_figures_only(tmp_path, monkeypatch):
    """No error_ric in the results: only the three ECEF figures (drawn, not saved here: saving is tested above)."""
    monkeypatch.setattr(scf, "save_png", lambda fig, path: str(path))
    paths = scf.write_spacecraft_figures(_campaign(ric=False), tmp_path)
    assert [Path(p).name for p in paths] == ["sc_position_ecef.png", "sc_velocity_ecef.png", "sc_misalignment.png"]


def test_sharpness_curve_is_relative_to_the_true_speed(tmp_path, drawn):
    """x = processor speed - true speed; the visited points as given; the truth line at 0."""
    speeds, sharp = np.linspace(7490.0, 7510.0, 9), np.linspace(1.0, 2.0, 9)
    visited = [(7495.0, 1.2), (7501.0, 1.9)]
    _png(scf.plot_sharpness_curve(speeds, sharp, visited, 7500.0, tmp_path / "s.png"))
    curve, pts, truth = drawn[0].axes[0].lines
    np.testing.assert_allclose(curve.get_xdata(), speeds - 7500.0)
    np.testing.assert_array_equal(curve.get_ydata(), sharp)
    np.testing.assert_allclose(pts.get_xdata(), [-5.0, 1.0])
    assert list(truth.get_xdata()) == [0.0, 0.0]


def test_registration_marks_inliers_and_outliers(tmp_path, drawn):
    """Matches drawn as (column, row): outliers grey, inliers green, the centre stars; the title counts inliers."""
    rng = np.random.default_rng(3)
    img, ref = rng.uniform(size=(20, 30)), rng.uniform(size=(25, 25))
    src, dst = rng.uniform(0, 20, (5, 2)), rng.uniform(0, 25, (5, 2))
    inl = np.array([True, False, True, True, False])
    _png(scf.plot_registration(img, ref, src, dst, inl, (10.0, 15.0), (12.0, 11.0), tmp_path / "r.png"))
    a, b = drawn[0].axes[:2]
    np.testing.assert_array_equal(a.lines[0].get_xdata(), src[~inl, 1])
    np.testing.assert_array_equal(a.lines[1].get_ydata(), src[inl, 0])
    np.testing.assert_array_equal(b.lines[1].get_xdata(), dst[inl, 1])
    assert list(a.lines[2].get_xdata()) == [15.0] and list(b.lines[2].get_ydata()) == [12.0]
    assert drawn[0]._suptitle.get_text() == "registration: 3 inliers of 5 matches"
