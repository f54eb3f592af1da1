"""``sarnav.report.sensitivity``: ``write_csv`` (one row per case, read back here with the ``csv`` module: the numbers
to 6 significant digits, an undefined value an empty cell) and ``plot_grid`` (a PNG of the image grid, read back with
matplotlib: its size from the figure size and layout, the X / O markers drawn). Stand-in case objects: no study is
run."""

from __future__ import annotations

import csv
import math
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.image import imread

from sarnav.analysis.bpa_sensitivity import CSV_FIELDS
from sarnav.report.sensitivity import plot_grid, write_csv


def _case(i: int, **over) -> SimpleNamespace:
    """A result with every CSV field: numbers of several magnitudes and signs."""
    values = {"name": f"case_{i}", "value": 0.5 * (i + 1), "unit": "m/s",
              "pred_offset_range": -1.234567891 * 10**i, "pred_offset_along": 3.14159265358979e-4 * (i + 1),
              "meas_offset_range": -1.2e5 - i, "meas_offset_along": float(i), "pred_peak_loss": 7.0 / 3.0,
              "meas_peak_loss": np.float32(0.125), "irw_along_ref": np.float64(0.8861), "irw_along": 123456789.0}
    values.update(over)
    return SimpleNamespace(**values)


def _read(path):
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def test_csv_header_is_the_fields_and_one_row_per_case(tmp_path):
    """The header row is CSV_FIELDS; one row per case in order, of as many cells."""
    cases = [_case(i) for i in range(4)]
    out = write_csv(cases, tmp_path / "sensitivity.csv")
    assert out == tmp_path / "sensitivity.csv"
    rows = _read(out)
    assert rows[0] == list(CSV_FIELDS)
    assert len(rows) == 5 and all(len(r) == len(CSV_FIELDS) for r in rows)
    assert [r[0] for r in rows[1:]] == [f"case_{i}" for i in range(4)]


def test_csv_numbers_read_back_to_six_significant_digits(tmp_path):
    """Every numeric cell reads back within half a unit of the 6th significant digit of the value, and holds at
    most 6 significant digits."""
    cases = [_case(i) for i in range(3)]
    rows = _read(write_csv(cases, tmp_path / "s.csv"))
    for case, row in zip(cases, rows[1:]):
        for f, cell in zip(CSV_FIELDS, row):
            v = getattr(case, f)
            if isinstance(v, str):
                assert cell == v
                continue
            got = float(cell)
            assert abs(got - float(v)) <= 0.5e-5 * abs(float(v)) * (1 + 1e-12)
            mantissa = cell.lower().split("e")[0].lstrip("-").replace(".", "").lstrip("0")
            assert len(mantissa) <= 6


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf"), np.nan])
def test_csv_undefined_values_are_empty_cells(tmp_path, bad):
    """A NaN or infinite value (an IRW the image cannot measure) is an empty cell; the other cells are kept."""
    rows = _read(write_csv([_case(0, irw_along=bad)], tmp_path / "s.csv"))
    row = dict(zip(rows[0], rows[1]))
    assert row["irw_along"] == ""
    assert float(row["irw_along_ref"]) == pytest.approx(0.8861, rel=5e-6)


def test_csv_with_chosen_fields_and_no_cases(tmp_path):
    """``fields`` picks the columns (in its order); no cases: the header alone."""
    rows = _read(write_csv([_case(2)], tmp_path / "a.csv", fields=("value", "name")))
    assert rows == [["value", "name"], ["1.5", "case_2"]]
    assert _read(write_csv([], tmp_path / "b.csv")) == [list(CSV_FIELDS)]


def _grid_case(i: int, n: int = 41, spacing: float = 0.5) -> SimpleNamespace:
    """A case whose image is a point response at its predicted position on an n x n ground grid."""
    x = (np.arange(n) - n // 2) * spacing
    y = x + 100.0
    pred = (100.0 + 2.0 * i, 1.0 * i)  # (north, east)
    yy, xx = np.meshgrid(y, x, indexing="ij")
    data = np.exp(-((yy - pred[0]) ** 2 + (xx - pred[1]) ** 2) / 2.0) * (1 + 0j)
    return SimpleNamespace(image=SimpleNamespace(data=data, x=x, y=y), reference_xy=(100.0, 0.0), predicted_xy=pred,
                           name="vel_error_along", value=0.1 * i, unit="m/s")


def _colour_fraction(img, rgb, tol=0.15) -> float:
    """Fraction of pixels within ``tol`` of the colour ``rgb`` (0-1)."""
    return float(np.mean(np.all(np.abs(img[..., :3] - np.asarray(rgb)) < tol, axis=-1)))


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """PNGs of two cases (drawn twice) and of the same grid with the second response moved, read back."""
    d = tmp_path_factory.mktemp("grid")
    a = [_grid_case(0), _grid_case(1)]
    b = [_grid_case(0), _grid_case(3)]
    return (imread(plot_grid(a, a[0].image, d / "a.png")), imread(plot_grid(a, a[0].image, d / "a2.png")),
            imread(plot_grid(b, b[0].image, d / "b.png")))


@pytest.mark.parametrize("n, rows", [(1, 1), (4, 2)])
def test_plot_grid_writes_a_png_of_three_columns(tmp_path, n, rows):
    """A PNG of 3 columns x ceil(n / 3) rows of 4 x 3.2 in panels at 110 dpi (parent folders created)."""
    cases = [_grid_case(i) for i in range(n)]
    out = plot_grid(cases, cases[0].image, tmp_path / "figs" / "sensitivity.png")
    assert out == tmp_path / "figs" / "sensitivity.png"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = imread(out)
    assert img.shape[:2] == (round(3.2 * rows * 110), round(4.0 * 3 * 110))
    assert rows == math.ceil(n / 3)


def test_plot_grid_draws_reference_and_predicted_markers(drawn):
    """The red X (reference) and the cyan O (predicted) markers are drawn: pure red and cyan pixels appear, which
    the gray images alone never give."""
    img = drawn[0]
    assert _colour_fraction(img, (1.0, 0.0, 0.0)) > 1e-5
    assert _colour_fraction(img, (0.0, 0.75, 0.75)) > 1e-5


def test_plot_grid_images_depend_on_the_data(drawn):
    """Two grids whose images differ (response moved) give different pictures; the same input the same picture."""
    pa, pa2, pb = drawn
    np.testing.assert_array_equal(pa, pa2)
    assert not np.array_equal(pa, pb)
