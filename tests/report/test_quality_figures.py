"""``report.quality_figures``: the CSV and strict-JSON writers (exact floats, NaN as empty / null, no partial file
left), the sweep Dataset (values and attributes of every direction), and the figures: written, non-empty PNGs whose
plotted data (read back from the matplotlib artists) equal the input."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from helpers import assert_png, keep_saved_figures
import xarray as xr
from matplotlib.colors import to_rgba

from sarnav.report import quality_figures as qf


@pytest.fixture
def drawn(monkeypatch):
    """The Figure objects the module saves, still written through the real save_png."""
    return keep_saved_figures(monkeypatch, qf)


_png = assert_png


def _rows(rng):
    rows = []
    for real in (0, 1, 2):
        for sig in (1e-5, 2e-5):
            for sp in range(4):
                for m in ("source", "grid"):
                    rows.append({"method": m, "block_pulses": 200, "candidates": 3, "sigma": sig, "spacing": sp,
                                 "realisation": real, "rho": float(rng.uniform(0.5, 1.5)),
                                 "reach": float(rng.uniform(0.01, 0.5))})
    return rows


def test_rows_csv_writes_exactly_the_columns_and_exact_floats(tmp_path):
    """Header = columns; floats round-trip exactly (repr), NaN is an empty cell, booleans true/false; no .partial."""
    rows = [{"a": 0.1 + 0.2, "b": "x,y", "c": True, "d": np.int64(7), "e": 1.0 / 3.0},
            {"a": float("nan"), "b": "", "c": np.bool_(False), "d": 0, "e": -2.5e-300}]
    p = qf.write_rows_csv(rows, tmp_path / "r.csv", ("a", "b", "c", "d"))
    with open(p, newline="") as fh:
        got = list(csv.reader(fh))
    assert got[0] == ["a", "b", "c", "d"]
    assert float(got[1][0]) == 0.1 + 0.2 and got[1][1:] == ["x,y", "true", "7"]
    assert got[2] == ["", "", "false", "0"]
    assert [f.name for f in tmp_path.iterdir()] == ["r.csv"]


def test_strict_json_has_numbers_lists_and_null_for_nan(tmp_path):
    """numpy scalars and arrays become JSON numbers and lists; NaN becomes null (strict JSON, parseable)."""
    p = qf.write_strict_json({"x": np.float64(1.5), "v": np.arange(3), "n": float("nan")}, tmp_path / "s.json")
    doc = json.loads(p.read_text(), parse_constant=lambda c: pytest.fail(f"non-strict {c}"))
    assert doc["x"] == 1.5 and doc["v"] == [0, 1, 2] and doc["n"] is None
    assert [f.name for f in tmp_path.iterdir()] == ["s.json"]


def _sweep(direction, errors, values, maximise=True):
    ds = xr.Dataset({"kurtosis": (("size", "error"), values)}, coords={"error": errors, "size": [16, 32]},
                    attrs={"direction": direction, "maximise_kurtosis": maximise, "pivot": "first", "other": "x"})
    return ds


def test_sweep_dataset_stacks_the_directions_on_centred_steps():
    """direction x size x step with step = index - n // 2, the values and errors unchanged per direction, the
    maximise_ attribute kept (as an int) and described in long_name."""
    rng = np.random.default_rng(1)
    va, vc = rng.normal(size=(2, 5)), rng.normal(size=(2, 5))
    ea, ec = np.linspace(-0.02, 0.02, 5), np.linspace(-0.004, 0.004, 5)
    out = qf.sweep_dataset({"along": _sweep("along", ea, va), "cross": _sweep("cross", ec, vc)}, {"runs": 3})
    assert list(out["direction"].values) == ["along", "cross"]
    np.testing.assert_array_equal(out["step"].values, [-2, -1, 0, 1, 2])
    np.testing.assert_array_equal(out["kurtosis"].sel(direction="along").values, va)
    np.testing.assert_array_equal(out["kurtosis"].sel(direction="cross").values, vc)
    np.testing.assert_array_equal(out["error"].sel(direction="cross").values, ec)
    assert out.attrs["maximise_kurtosis"] == 1 and out.attrs["pivot"] == "first" and out.attrs["runs"] == 3
    assert "larger is better focus" in out["kurtosis"].attrs["long_name"]


def test_score_curves_plot_the_sweep(tmp_path, drawn):
    """Each panel's curve: x = 100 x error (along-track, in %), y = the measure at that size."""
    e = np.linspace(-0.01, 0.01, 7)
    v = np.arange(14.0).reshape(2, 7) ** 2
    p = qf.plot_score_curves(_sweep("along", e, v), ["kurtosis"], [(16, None), (32, None)], tmp_path / "s.png", "t")
    _png(p)
    ax16, ax32 = drawn[0].axes
    np.testing.assert_allclose(ax16.lines[0].get_xdata(), 100 * e)
    np.testing.assert_array_equal(ax16.lines[0].get_ydata(), v[0])
    np.testing.assert_array_equal(ax32.lines[0].get_ydata(), v[1])


def test_t3_images_are_db_of_the_reference_peak(tmp_path, drawn):
    """Each panel: 20 log10(|image| / reference peak), floored at -80 dB (1e-4)."""
    rng = np.random.default_rng(2)
    imgs = {k: rng.normal(size=(8, 8)) + 1j * rng.normal(size=(8, 8)) for k in ("reference", "along", "cross")}
    t3 = {**imgs, **{f"{k}_{q}": 0.5 for k in ("along", "cross") for q in ("correlation", "sharpness")},
          "along_shift_m": [0.1], "cross_shift_m": [-0.2]}
    _png(qf.plot_t3(t3, 0.5, tmp_path / "t3.png"))
    peak = np.abs(imgs["reference"]).max()
    for ax, k in zip(drawn[0].axes[:3], ("reference", "along", "cross")):
        want = 20 * np.log10(np.maximum(np.abs(imgs[k]) / peak, 1e-4))
        np.testing.assert_allclose(np.asarray(ax.images[0].get_array()), want, rtol=1e-12)


def test_reliability_bars_count_the_scenes(tmp_path, drawn):
    """Bar heights: per measure, how many scenes had their extremum k steps from zero (counted here)."""
    steps = np.array([[0, 1], [0, -3], [1, 0], [-0.4, 2]])
    _png(qf.plot_reliability(steps, ["a", "b"], tmp_path / "r.png"))
    ax = drawn[0].axes[0]
    heights = [p.get_height() for p in ax.patches]
    want = [[sum(abs(round(s)) == k for s in steps[:, j]) for k in range(4)] for j in range(2)]
    assert heights == want[0] + want[1]


def _medians(ax):
    red = to_rgba("red")
    return [float(np.mean(l.get_ydata())) for l in ax.lines if to_rgba(l.get_color()) == red]


def test_whiskers_show_the_median_per_sigma(tmp_path, drawn):
    """One panel per method; the red median lines are the medians of rho per sigma of the first realisation."""
    rows = _rows(np.random.default_rng(3))
    _png(qf.plot_whiskers(rows, 200, 3, ["source", "grid", "brent"], tmp_path / "w.png"))
    axes = [a for a in drawn[0].axes if a.get_visible()]
    assert len(axes) == 2  # brent has no rows
    for ax, m in zip(axes, ("source", "grid")):
        want = [np.median([r["rho"] for r in rows if r["method"] == m and r["sigma"] == s and r["realisation"] == 0])
                for s in (1e-5, 2e-5)]
        np.testing.assert_allclose(_medians(ax), want, rtol=1e-12)


def test_realisations_need_two_and_pick_the_best(tmp_path, drawn):
    """None with one realisation; otherwise the first panel is the realisation with the lowest median rho."""
    rows = _rows(np.random.default_rng(4))
    assert qf.plot_realisations([r for r in rows if r["realisation"] == 0], 200, 3, tmp_path / "x.png") is None
    _png(qf.plot_realisations(rows, 200, 3, tmp_path / "real.png"))
    med = {k: np.median([r["rho"] for r in rows if r["method"] == "source" and r["realisation"] == k])
           for k in (0, 1, 2)}
    assert drawn[0].axes[0].get_title() == f"best: realisation {min(med, key=med.get)}"


def test_noise_runs_plot_the_drifts(tmp_path, drawn):
    """Panel (b): one line per realisation (at most three) equal to its drift; None with fewer than two."""
    drifts = {k: np.cumsum(np.random.default_rng(k).normal(size=50)) for k in range(4)}
    assert qf.plot_noise_runs(_rows(np.random.default_rng(5)), 200, 3, 1e-5, {0: drifts[0]}, tmp_path / "n") is None
    _png(qf.plot_noise_runs(_rows(np.random.default_rng(5)), 200, 3, 1e-5, drifts, tmp_path / "n.png"))
    lines = drawn[0].axes[1].lines
    assert len(lines) == 3
    for k, line in enumerate(lines):
        np.testing.assert_array_equal(line.get_ydata(), drifts[k])


def test_failure_plots_rho_against_the_reach_bound(tmp_path, drawn):
    """Panel (b): every finite (reach, rho) point per method, and the envelope (1 + B)^2."""
    rows = _rows(np.random.default_rng(6))
    rows[0]["rho"] = math.nan  # a failed run is left out
    _png(qf.plot_failure(rows, tmp_path / "f.png"))
    ax_b = drawn[0].axes[1]
    pts = {l.get_label(): l for l in ax_b.lines}
    src = [r for r in rows if r["method"] == "source" and math.isfinite(r["rho"])]
    np.testing.assert_array_equal(pts["source"].get_xdata(), [r["reach"] for r in src])
    np.testing.assert_array_equal(pts["source"].get_ydata(), [r["rho"] for r in src])
    env = pts["(1 +- B)^2"]
    np.testing.assert_allclose(env.get_ydata(), (1 + np.asarray(env.get_xdata())) ** 2)


def test_methods_plot_is_written(tmp_path, drawn):
    """One box per (method, S_i, L), log scale."""
    _png(qf.plot_methods(_rows(np.random.default_rng(7)), tmp_path / "m.png"))
    ax = drawn[0].axes[0]
    assert ax.get_yscale() == "log" and [t.get_text() for t in ax.get_xticklabels()] == ["grid 200/3", "source 200/3"]
