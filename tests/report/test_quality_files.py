"""``sarnav.report.quality_files``: the files of the image-quality kinds (docs/quality.md), ``quality-sweep``
(``sweep.nc``, ``claims.json``) and ``gpsd-search`` (``rho.csv``, ``rho_diagnostics.csv``, ``search.json``).

The sweeps and search rows are built here by hand (small xarray Datasets and dicts of the documented columns) and
the files read back with netCDF4, csv and json. Drawing the figures is ``report.quality_figures``' (and the
scenario tests'); here only that ``figures`` asks for them, into ``figures/``.
"""

from __future__ import annotations

import csv
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from sarnav.measurements.focus_search import DIAGNOSTIC_COLUMNS, ROW_COLUMNS
from sarnav.report import quality_files
from sarnav.report.quality_files import write_search_files, write_sweep_files

SIZES, BINS = [6, 8], [10, 20]
ERRORS = {"along": np.array([-0.02, -0.01, 0.0, 0.01, 0.02]), "cross": np.array([-0.2, -0.1, 0.0, 0.1, 0.2])}


def strict_load(path):
    def bad(name):
        raise ValueError(f"non-strict JSON constant {name}")
    return json.loads(path.read_text(encoding="utf-8"), parse_constant=bad)


def sweep(direction: str, seed: int) -> xr.Dataset:
    """A sweep as ``analysis.quality_sweep.quality_sweep`` returns it: kurtosis (size, error), entropy_magnitude
    (size, bins, error), the sense of each measure and the direction, pivot and error unit as attributes."""
    rng = np.random.default_rng(seed)
    err = ERRORS[direction]
    ds = xr.Dataset(coords={"size": SIZES, "bins": BINS, "error": err})
    ds["kurtosis"] = (("size", "error"), rng.standard_normal((len(SIZES), err.size)))
    ds["entropy_magnitude"] = (("size", "bins", "error"), rng.uniform(1, 5, (len(SIZES), len(BINS), err.size)))
    ds.attrs.update(maximise_kurtosis=1, maximise_entropy_magnitude=0, direction=direction, pivot="first",
                    error_unit="relative" if direction == "along" else "m/m")
    return ds


@pytest.fixture
def sweep_result():
    claims = {"T7": {"passed": True, "error_at_peak": np.float64(0.0)}, "T9": {"value": math.nan, "count": 0},
              "step": {"along": 0.01, "cross": 0.1}, "sizes": np.array([6, 8])}
    return {"sweeps": {"along": sweep("along", 1), "cross": sweep("cross", 2)}, "claims": claims, "t3": None,
            "reliability": None}


def read_nc(path):
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        out = {name: np.asarray(v[:]) for name, v in nc.variables.items()}
        dims = {name: v.dimensions for name, v in nc.variables.items()}
        var_attrs = {name: {k: v.getncattr(k) for k in v.ncattrs()} for name, v in nc.variables.items()}
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs()}
    return out, dims, var_attrs, attrs


# ---- quality-sweep -------------------------------------------------------------------------------------------------


def test_sweep_files_hold_every_direction_and_measure(tmp_path, sweep_result):
    """sweep.nc: dims direction, size, bins, step (0 = no error); each measure's scores as given; error(direction,
    step) the injected error; the scenario name and the senses of the measures as attributes."""
    path = write_sweep_files(sweep_result, None, "qs-<name>", tmp_path, figures=False)
    assert path == tmp_path / "sweep.nc"
    v, dims, var_attrs, attrs = read_nc(path)
    directions = [str(d) for d in v["direction"]]
    assert sorted(directions) == ["along", "cross"]
    np.testing.assert_array_equal(v["step"], [-2, -1, 0, 1, 2])
    np.testing.assert_array_equal(v["size"], SIZES)
    np.testing.assert_array_equal(v["bins"], BINS)
    for i, d in enumerate(directions):
        ds = sweep_result["sweeps"][d]
        k = dims["kurtosis"]
        kurt = np.moveaxis(v["kurtosis"], [k.index("direction"), k.index("size"), k.index("step")], [0, 1, 2])
        np.testing.assert_array_equal(kurt[i], ds["kurtosis"].values)
        e = dims["entropy_magnitude"]
        ent = np.moveaxis(v["entropy_magnitude"], [e.index(x) for x in ("direction", "size", "bins", "step")],
                          [0, 1, 2, 3])
        np.testing.assert_array_equal(ent[i], ds["entropy_magnitude"].values)
        r = dims["error"]
        err = np.moveaxis(v["error"], [r.index("direction"), r.index("step")], [0, 1])
        np.testing.assert_array_equal(err[i], ERRORS[d])
    assert attrs["scenario"] == "qs-<name>"
    assert attrs["references"] == "Hathaway 2023 §4.1.1"
    assert int(attrs["maximise_kurtosis"]) == 1 and int(attrs["maximise_entropy_magnitude"]) == 0
    assert "larger is better focus" in var_attrs["kurtosis"]["long_name"]
    assert "smaller is better focus" in var_attrs["entropy_magnitude"]["long_name"]


def test_sweep_files_write_strict_claims_and_leave_no_partial_file(tmp_path, sweep_result):
    write_sweep_files(sweep_result, None, "qs", tmp_path, figures=False)
    claims = strict_load(tmp_path / "claims.json")
    assert claims["T7"] == {"passed": True, "error_at_peak": 0.0}
    assert claims["T9"]["value"] is None and "value" in claims["T9"]["undefined"]  # NaN: null, with its reason
    assert claims["step"] == {"along": 0.01, "cross": 0.1} and claims["sizes"] == [6, 8]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["claims.json", "sweep.nc"]


def test_sweep_files_replace_an_earlier_sweep(tmp_path, sweep_result):
    (tmp_path / "sweep.nc").write_bytes(b"an older, broken file")
    (tmp_path / "sweep.nc.partial").write_bytes(b"an interrupted write")
    write_sweep_files(sweep_result, None, "qs", tmp_path, figures=False)
    v, _, _, _ = read_nc(tmp_path / "sweep.nc")
    assert "kurtosis" in v
    assert not (tmp_path / "sweep.nc.partial").exists()


def test_sweep_figures_are_drawn_into_figures_when_asked(tmp_path, sweep_result, monkeypatch):
    calls = []
    monkeypatch.setattr(quality_files, "sweep_figures", lambda res, prm, figdir: calls.append((res, prm, figdir)))
    prm = object()
    write_sweep_files(sweep_result, prm, "qs", tmp_path, figures=False)
    assert calls == []
    write_sweep_files(sweep_result, prm, "qs", tmp_path, figures=True)
    assert calls == [(sweep_result, prm, tmp_path / "figures")]


# ---- gpsd-search ---------------------------------------------------------------------------------------------------


def rows():
    """Search rows of every documented column: method, block size, candidates, sigma, spacing, realisation, rho;
    the diagnostics scorer, coverage, agreement, reach, error; a failed run's rho NaN."""
    out = []
    rng = np.random.default_rng(4)
    for k, method in enumerate(["source", "source-carry", "source-oracle", "source-random"]):
        out.append({"method": method, "block_pulses": np.int64(64 * (k + 1)), "candidates": 9, "sigma": 0.1 * k,
                    "spacing": np.float64(1.0 / 3.0), "realisation": k, "rho": float(rng.uniform()),
                    "scorer": "kurtosis", "coverage": np.float32(0.75), "agreement": bool(k % 2),
                    "reach": 1e-17 * k, "error": -2.5e-3})
    out[2]["rho"] = math.nan
    return out


def read_csv(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.reader(fh))


def test_search_files_hold_exactly_the_documented_columns(tmp_path):
    """rho.csv: the row columns; rho_diagnostics.csv: the row and diagnostic columns; floats exact (repr), integers
    as integers, booleans true/false, an undefined rho an empty cell."""
    res = SimpleNamespace(rows=rows(), summary={"best": "source", "rho_mean": np.float64(0.5), "bad": math.inf})
    path = write_search_files(res, None, tmp_path, figures=False)
    assert path == tmp_path / "rho.csv"
    table = read_csv(tmp_path / "rho.csv")
    assert table[0] == list(ROW_COLUMNS)
    diag = read_csv(tmp_path / "rho_diagnostics.csv")
    assert diag[0] == list(ROW_COLUMNS) + list(DIAGNOSTIC_COLUMNS)
    for got, full, want in zip(table[1:], diag[1:], res.rows):
        assert got == full[:len(ROW_COLUMNS)]
        cell = dict(zip(diag[0], full))
        assert cell["method"] == want["method"]
        assert cell["block_pulses"] == str(int(want["block_pulses"])) and cell["realisation"] == str(want["realisation"])
        assert float(cell["sigma"]) == want["sigma"] and float(cell["spacing"]) == want["spacing"]
        assert float(cell["coverage"]) == float(want["coverage"]) and float(cell["reach"]) == want["reach"]
        assert cell["agreement"] == ("true" if want["agreement"] else "false")
        if math.isnan(want["rho"]):
            assert cell["rho"] == ""
        else:
            assert float(cell["rho"]) == want["rho"]
    assert len(table) == len(res.rows) + 1
    summary = strict_load(tmp_path / "search.json")
    assert {k: summary[k] for k in ("best", "rho_mean", "bad")} == {"best": "source", "rho_mean": 0.5, "bad": None}
    assert set(summary) == {"best", "rho_mean", "bad", "undefined"} and set(summary["undefined"]) == {"bad"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rho.csv", "rho_diagnostics.csv", "search.json"]


def test_search_files_of_no_rows_are_headers_only(tmp_path):
    write_search_files(SimpleNamespace(rows=[], summary={}), None, tmp_path, figures=False)
    assert read_csv(tmp_path / "rho.csv") == [list(ROW_COLUMNS)]
    assert read_csv(tmp_path / "rho_diagnostics.csv") == [list(ROW_COLUMNS) + list(DIAGNOSTIC_COLUMNS)]
    assert strict_load(tmp_path / "search.json") == {}


def test_search_figures_are_drawn_into_figures_when_asked(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(quality_files, "search_figures", lambda r, prm, figdir: calls.append((r, prm, figdir)))
    res, prm = SimpleNamespace(rows=rows(), summary={}), object()
    write_search_files(res, prm, tmp_path, figures=False)
    assert calls == []
    write_search_files(res, prm, tmp_path, figures=True)
    assert calls == [(res.rows, prm, tmp_path / "figures")]
