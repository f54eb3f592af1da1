"""Statistics of source-comparison campaigns (``sarnav.analysis.sources``) on small hand-made datasets: the RMS and
its delta-method standard error written out here, the ratio of sources, the per-filter NEES against the chi-square
band, and the focus table's means."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy.stats import chi2

from sarnav.analysis.sources import (
    filter_nees_summary,
    focus_table,
    rmse_ratio,
    source_rmse,
)


def _ms_dataset(ms, names):
    return xr.Dataset({"source_ms": (("run", "source"), np.asarray(ms, dtype=float))}, coords={"source": names})


def test_source_rmse_is_the_root_of_the_mean_over_runs_with_a_delta_method_stderr():
    """rmse = sqrt(mean_r ms); stderr = std(ms, ddof=1) / sqrt(R) / (2 rmse), per source."""
    ms = np.array([[1.0, 4.0], [4.0, 9.0], [16.0, 25.0]])
    out = source_rmse(_ms_dataset(ms, ["ins", "sar"]))
    assert out["rmse_runs"] == 3
    assert out["rmse"] == pytest.approx({"ins": np.sqrt(7.0), "sar": np.sqrt(38.0 / 3)}, rel=1e-12)
    for j, name in enumerate(["ins", "sar"]):
        m = ms[:, j].mean()
        sd = np.sqrt(np.sum((ms[:, j] - m) ** 2) / 2)
        assert out["rmse_stderr"][name] == pytest.approx(sd / np.sqrt(3) / (2 * np.sqrt(m)), rel=1e-12)


def test_source_rmse_stderr_matches_the_spread_of_rmse_over_resampled_campaigns():
    """The delta-method stderr predicts the scatter of sqrt(mean) over many independent campaigns (within 25 %)."""
    rng = np.random.default_rng(np.random.SeedSequence(3))
    runs = 40
    draw = lambda: rng.chisquare(3, size=(runs, 1)) * 4.0
    se = source_rmse(_ms_dataset(draw(), ["a"]))["rmse_stderr"]["a"]
    spread = np.std([np.sqrt(draw().mean()) for _ in range(4000)], ddof=1)
    assert se == pytest.approx(spread, rel=0.25)  # se estimated from one campaign of 40 runs scatters by ~15 %


def test_source_rmse_of_one_run_has_no_stderr_and_zero_error_has_zero_stderr():
    """One run: no spread to estimate (no ``rmse_stderr``); a zero error source: stderr 0, not NaN or inf."""
    one = source_rmse(_ms_dataset([[2.25, 0.0]], ["a", "b"]))
    assert one["rmse"] == {"a": 1.5, "b": 0.0} and "rmse_stderr" not in one and one["rmse_runs"] == 1
    two = source_rmse(_ms_dataset([[0.0, 1.0], [0.0, 3.0]], ["zero", "b"]))
    assert two["rmse_stderr"]["zero"] == 0.0


def test_rmse_ratio_of_names_and_of_lists_of_names():
    """A name or the mean RMS of a list over another; a zero denominator gives NaN (not a division error)."""
    rmse = {"a": 2.0, "b": 4.0, "c": 6.0, "z": 0.0}
    assert rmse_ratio(rmse, "a", "b") == 0.5
    assert rmse_ratio(rmse, ["a", "c"], "b") == 1.0
    assert rmse_ratio(rmse, "c", ["a", "b"]) == 2.0
    assert np.isnan(rmse_ratio(rmse, "a", "z"))


def test_filter_nees_summary_per_filter_against_the_chi_square_band():
    """Each filter's time-averaged run-mean NEES, its band chi2(3R)/R and the fraction of epochs inside it."""
    rng = np.random.default_rng(np.random.SeedSequence(5))
    runs, steps = 8, 50
    nees = np.stack([rng.chisquare(3, (runs, steps)), 4.0 * rng.chisquare(3, (runs, steps))], axis=2)
    ds = xr.Dataset({"filter_nees": (("run", "time", "filter"), nees)}, coords={"filter": ["good", "overconfident"]})
    out = filter_nees_summary(ds)
    assert list(out) == ["good", "overconfident"]
    lo, hi = chi2.ppf(0.025, 3 * runs) / runs, chi2.ppf(0.975, 3 * runs) / runs
    for j, name in enumerate(out):
        mean = nees[..., j].mean(axis=0)
        st = out[name]
        assert "mean" not in st and st["dof"] == 3 and st["runs"] == runs
        assert st["band"] == pytest.approx((lo, hi), rel=1e-12)
        assert st["time_average"] == pytest.approx(mean.mean(), rel=1e-12)
        assert st["fraction_in_band"] == pytest.approx(np.mean((mean >= lo) & (mean <= hi)), abs=0)
    assert out["good"]["fraction_in_band"] > 0.8 > out["overconfident"]["fraction_in_band"]


def test_focus_table_is_the_mean_over_runs_and_reflectors_per_source_and_metric():
    """One row per source in order; each metric the mean over runs and reflectors (rows of focus.csv)."""
    rng = np.random.default_rng(np.random.SeedSequence(9))
    f = rng.normal(size=(3, 2, 4, 2))  # (run, source, reflector, metric)
    ds = xr.Dataset({"focus": (("run", "source", "reflector", "metric"), f)},
                    coords={"source": ["ins", "fused"], "metric": ["pslr", "irw"]})
    rows = focus_table(ds)
    assert [r["source"] for r in rows] == ["ins", "fused"]
    for j, row in enumerate(rows):
        assert set(row) == {"source", "pslr", "irw"}
        for i, m in enumerate(["pslr", "irw"]):
            assert row[m] == pytest.approx(sum(f[r, j, k, i] for r in range(3) for k in range(4)) / 12, rel=1e-12)
