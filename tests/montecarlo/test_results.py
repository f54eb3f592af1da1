"""Results: run store round trip, Dataset assembly (schema of docs/results.md), netCDF round trip,
summary.json numbers against independent computations, figures."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.stats import chi2

from sarnav.analysis.consistency import summarize
from sarnav.errors import InputDataError
from sarnav.montecarlo import store
from sarnav.montecarlo.assemble import assemble_results, open_results, write_results
from sarnav.montecarlo.record import RunRecord
from sarnav.report.figures import state_blocks, thin_runs, write_campaign_figures

STATES = ["pN", "pE", "pD", "vN", "vE", "vD", "thN", "thE", "thD"]
UNITS = ["m"] * 3 + ["m/s"] * 3 + ["rad"] * 3


def make_record(run, rng, T=30, U=10, S=9, M=2):
    t = np.linspace(0.0, 2.9, T)
    sig = np.tile(np.linspace(2.0, 1.0, T)[:, None], (1, S))
    err = rng.standard_normal((T, S)) * sig
    res = rng.standard_normal((U, M))
    res[::3, 1] = np.nan
    rs = np.ones((U, M))
    rs[::3, 1] = np.nan
    dof = np.where(np.isnan(res[:, 1]), 1, 2)
    nis = np.nansum(res**2, axis=1)
    return RunRecord(
        run=run, time=t, error=err, sigma=sig, nees=((err / sig) ** 2).sum(axis=1), update_time=t[::3][:U],
        residual=res, residual_sigma=rs, nis=nis, nis_dof=dof,
        extras={"registration_error": (("update", "meas"), rng.standard_normal((U, M))), "scale": ((), np.float64(run))},
    )


def records(n=6, seed=0):
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    return [make_record(i, rng) for i in range(n)]


def build(recs):
    return assemble_results(recs, STATES, ["range", "cross"], UNITS, ["m", "m"], {"scenario": "x = 1\n", "seed": 4, "complete": 1})


def test_store_round_trip_with_extras_and_no_temp_files(tmp_path):
    rec = records(1)[0]
    path = store.save_record(tmp_path, rec)
    assert path.name == "run_000000.npz" and store.stored_runs(tmp_path) == {0}
    back = store.load_record(path)
    for name in ("time", "error", "sigma", "nees", "update_time", "residual", "residual_sigma", "nis", "nis_dof"):
        assert np.array_equal(getattr(back, name), getattr(rec, name), equal_nan=True), name
    assert back.extras["registration_error"][0] == ("update", "meas")
    assert np.array_equal(back.extras["registration_error"][1], rec.extras["registration_error"][1])
    assert [p.name for p in (tmp_path / "runs").iterdir()] == ["run_000000.npz"]


def test_assembled_dataset_schema_and_netcdf_round_trip(tmp_path):
    recs = records()
    ds = build(recs[::-1])  # order of arrival does not matter
    assert dict(ds.sizes) == {"run": 6, "time": 30, "state": 9, "update": 10, "meas": 2}
    assert list(ds["run"].values) == list(range(6))
    assert ds["error"].dims == ("run", "time", "state") and ds["residual"].dims == ("run", "update", "meas")
    assert ds["registration_error"].dims == ("run", "update", "meas") and ds["scale"].dims == ("run",)
    write_results(ds, tmp_path / "results.nc")
    back = open_results(tmp_path / "results.nc")
    assert list(back["state"].values) == STATES
    assert list(back["state_units"].values) == UNITS and "units" not in back["state"].attrs  # CF: labels have none
    assert list(back["meas_units"].values) == ["m", "m"] and back["error"].attrs["units_coordinate"] == "state_units"
    assert back.attrs["scenario"] == "x = 1\n" and back.attrs["seed"] == 4 and back.attrs["complete"] == 1
    assert back.attrs["sarnav_version"]
    for v in ("error", "sigma", "nees", "residual", "residual_sigma", "nis", "nis_dof", "registration_error", "scale"):
        assert np.array_equal(back[v].values, ds[v].values, equal_nan=True), v
    assert back["nis_dof"].dtype == np.int64
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_assembly_rejects_inconsistent_epochs():
    recs = records(2)
    recs[1].time = recs[1].time + 1e-3
    with pytest.raises(InputDataError, match=r"^time: run 1"):
        build(recs)
    recs = records(2)
    recs[1].update_time = recs[1].update_time[::-1]
    with pytest.raises(InputDataError, match=r"^update_time:"):
        build(recs)
    with pytest.raises(InputDataError, match=r"^records:"):
        build([])


def test_summary_numbers_match_independent_computation():
    recs = records(8, seed=3)
    ds = build(recs)
    s = summarize(ds)
    err = np.stack([r.error for r in recs])
    sig = np.stack([r.sigma for r in recs])
    for i, name in enumerate(STATES):
        st = s["states"][name]
        assert st["final_sigma"] == pytest.approx(np.mean([r.sigma[-1, i] for r in recs]), rel=1e-14)
        assert st["final_3sigma"] == pytest.approx(3 * st["final_sigma"], rel=1e-14)
        inside = np.mean(np.abs(err[:, :, i]) <= 3 * sig[:, :, i])
        assert st["fraction_inside_3sigma"] == pytest.approx(inside, rel=1e-14)
        assert st["units"] == UNITS[i]
    assert s["nees"]["band"] == pytest.approx(list(chi2.ppf([0.025, 0.975], 8 * 9) / 8), rel=1e-12)
    res = np.stack([r.residual for r in recs])
    for j, m in enumerate(["range", "cross"]):
        col = res[:, :, j][np.isfinite(res[:, :, j])]
        assert s["residuals"][m]["mean"] == pytest.approx(col.mean(), rel=1e-12)
        assert s["residuals"][m]["stderr"] == pytest.approx(col.std(ddof=1) / np.sqrt(col.size), rel=1e-12)
        assert s["residuals"][m]["count"] == col.size
    D = int(sum(r.nis_dof.sum() for r in recs))
    assert s["nis"]["total_dof"] == D
    assert s["nis"]["per_dof"] == pytest.approx(sum(r.nis.sum() for r in recs) / D, rel=1e-12)
    # registration statistics of the image-derived axes (NaN entries = axis not image-derived)
    reg = np.stack([r.extras["registration_error"][1] for r in recs])
    reg[:, :, 0] = np.nan
    ds["registration_error"].values[:] = reg
    s = summarize(ds)
    assert list(s["registration"]) == ["cross"]
    e = reg[:, :, 1].ravel()
    st = s["registration"]["cross"]
    assert st["count"] == e.size and st["units"] == "m"
    assert st["mean"] == pytest.approx(e.mean(), rel=1e-12)
    assert st["std"] == pytest.approx(e.std(ddof=1), rel=1e-12)
    assert st["rms"] == pytest.approx(np.sqrt(np.mean(e**2)), rel=1e-12)
    assert st["max_abs"] == np.max(np.abs(e))
    json.dumps(s)  # serialisable


def test_figures_blocks_thinning_and_files(tmp_path):
    assert [b[0] for b in state_blocks(STATES)] == ["position", "velocity", "attitude"]
    assert state_blocks(["a", "b", "c", "d"])[1] == ("states_2", "Error d", [3])
    assert list(thin_runs(5, 50)) == [0, 1, 2, 3, 4]
    th = thin_runs(1000, 50)
    assert len(th) == 50 and th[0] == 0 and th[-1] == 999
    ds = build(records(4))
    paths = write_campaign_figures(ds, tmp_path)
    names = sorted(p.split("/")[-1] for p in paths)
    assert names == ["attitude.png", "position.png", "residuals.png", "velocity.png"]
    for p in paths:
        with open(p, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
