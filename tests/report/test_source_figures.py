"""``report.source_figures``: the per-source RMS figure, the UPF cloud variance, the images side by side (plotted
data read back from the artists, equal to values computed here from the input) and the ``focus.csv`` writer."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from helpers import assert_png, keep_saved_figures
import xarray as xr

from sarnav.report import source_figures as sf


@pytest.fixture
def drawn(monkeypatch):
    """The Figure objects the module saves, still written through the real save_png."""
    return keep_saved_figures(monkeypatch, sf)


_png = assert_png


def test_source_rmse_lines_are_the_rms_over_runs(tmp_path, drawn):
    """One line per source: sqrt(mean over runs of |error|^2) per epoch (floored at 1e-6), the legend its total."""
    rng = np.random.default_rng(0)
    R, T, names = 5, 30, ["ins", "fused"]
    err = rng.normal(size=(R, T, 2, 3)) * np.array([1.0, 0.1])[None, None, :, None]
    err[:, 0, 1] = 0.0  # a zero RMS is floored for the log axis
    ms = rng.uniform(1, 2, size=(R, 2))
    ds = xr.Dataset({"source_error": (("run", "time", "source", "axis"), err), "source_ms": (("run", "source"), ms)},
                    coords={"time": np.arange(T) * 0.5, "source": names})
    _png(sf.plot_source_rmse(ds, tmp_path / "rmse.png"))
    ax = drawn[0].axes[0]
    assert ax.get_yscale() == "log" and len(ax.lines) == 2
    for j, line in enumerate(ax.lines):
        want = np.maximum(np.sqrt((err[:, :, j] ** 2).sum(-1).mean(0)), 1e-6)
        np.testing.assert_allclose(line.get_ydata(), want, rtol=1e-12)
        np.testing.assert_array_equal(line.get_xdata(), np.arange(T) * 0.5)
        assert line.get_label() == f"{names[j]}: {np.sqrt(ms[:, j].mean()):.3g} m"


def test_cloud_variance_is_normalised_by_its_late_median(tmp_path, drawn):
    """Per axis: run-mean variance / its median over the second half of the record; the settling line at the worst
    run's settle time."""
    rng = np.random.default_rng(1)
    t = np.linspace(0.0, 100.0, 41)
    var = rng.uniform(1, 3, size=(3, 41, 3)) * np.exp(-t / 20)[None, :, None] + 0.5
    ds = xr.Dataset({"cloud_var": (("run", "time", "axis"), var), "settle_time": (("run",), [20.0, 35.0, 28.0])},
                    coords={"time": t})
    _png(sf.plot_cloud_variance(ds, tmp_path / "cv.png"))
    ax = drawn[0].axes[0]
    m = var.mean(0)
    late = np.median(m[t >= 50.0], axis=0)
    for a in range(3):
        np.testing.assert_allclose(ax.lines[a].get_ydata(), m[:, a] / late[a], rtol=1e-12)
    assert ax.lines[3].get_xdata()[0] == 35.0 and ax.lines[4].get_xdata()[0] == 75.0


def test_focus_images_in_db_of_the_truth_peak(tmp_path, drawn):
    """Each panel: 20 log10(|image| / peak of the truth image) with a 1e-12 floor; targets drawn at (east, north);
    unused panels hidden."""
    rng = np.random.default_rng(2)
    images = {"truth": rng.uniform(0.1, 4.0, (6, 5)), "ins": rng.uniform(0.0, 2.0, (6, 5)),
              "fused": np.zeros((6, 5))}
    targets = np.array([[1.0, 10.0], [2.0, 12.0]])
    _png(sf.plot_focus_images(images, (9.0, 13.0, 0.0, 3.0), targets, tmp_path / "img.png"))
    axes = [a for a in drawn[0].axes if a.get_images()]
    peak = images["truth"].max()
    for ax, name in zip(axes, images):
        want = 20 * np.log10(np.maximum(np.abs(images[name]), 1e-12 * peak) / peak)
        np.testing.assert_allclose(np.asarray(ax.images[0].get_array()), want, rtol=1e-12)
        np.testing.assert_array_equal(ax.lines[0].get_xdata(), targets[:, 1])
        np.testing.assert_array_equal(ax.lines[0].get_ydata(), targets[:, 0])
    assert len(axes) == 3 and sum(a.get_visible() for a in drawn[0].axes if a.get_label() != "<colorbar>") == 3


def test_focus_csv_columns_and_six_significant_digits(tmp_path):
    """Header FOCUS_COLUMNS; numbers with 6 significant digits (each reads back within 5e-6 relative: half a unit in the sixth digit); no
    temporary file left."""
    rows = [{"source": "truth", "irw_along_m": 1 / 3, "pslr_along_db": -13.26, "peak_offset_m": 0.0, "entropy": 7.0,
             "kurtosis": 123456789.0},
            {"source": "ins", "irw_along_m": 2.0, "pslr_along_db": np.float64(-9.5), "peak_offset_m": 1e-7,
             "entropy": 6.5, "kurtosis": 3.0}]
    p = Path(sf.write_focus_csv(rows, tmp_path / "focus.csv"))
    with open(p, newline="") as fh:
        got = list(csv.DictReader(fh))
    assert tuple(got[0]) == sf.FOCUS_COLUMNS
    for r, g in zip(rows, got):
        assert g["source"] == r["source"]
        for c in sf.FOCUS_COLUMNS[1:]:
            assert float(g[c]) == pytest.approx(float(r[c]), rel=5e-6, abs=0)
    assert got[0]["kurtosis"] == "1.23457e+08"
    assert [f.name for f in tmp_path.iterdir()] == ["focus.csv"]
