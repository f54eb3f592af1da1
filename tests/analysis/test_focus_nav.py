"""Focus-fix statistics of a quality-nav campaign (``sarnav.analysis.focus_nav``) on hand-made datasets: the error
statistics written out here, the normalised error against the chi-square band, the exclusions (NaN, sigma <= 0),
and the EKF's predicted sigma at the first and last update."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy.stats import chi2

from sarnav.analysis.focus_nav import focus_statistics


def _ds(err, sig, **extra):
    dims = ("run", "update")
    data = {"focus_error": (dims, np.asarray(err, dtype=float)), "focus_sigma": (dims, np.asarray(sig, dtype=float))}
    data.update({k: (dims, np.asarray(v, dtype=float)) for k, v in extra.items()})
    return xr.Dataset(data)


def test_fix_statistics_of_a_hand_case_skip_nan_and_non_positive_sigma():
    """Only pairs with finite error and sigma > 0 count; mean, std (ddof 1), RMS, max |e| and (e / sigma)^2 by hand."""
    err = [[1.0, -2.0, 5.0], [np.nan, 2.0, 100.0]]
    sig = [[1.0, 2.0, np.nan], [1.0, 4.0, 0.0]]
    out = focus_statistics(_ds(err, sig))["fix"]
    e = np.array([1.0, -2.0, 2.0])  # the three usable fixes (sigmas 1, 2, 4)
    assert out["count"] == 3
    assert out["mean"] == pytest.approx(1.0 / 3, rel=1e-12)
    assert out["std"] == pytest.approx(np.sqrt(np.sum((e - 1 / 3) ** 2) / 2), rel=1e-12)
    assert out["rms"] == pytest.approx(np.sqrt(3.0), rel=1e-12)
    assert out["max_abs"] == 2.0
    assert out["sigma_rms"] == pytest.approx(np.sqrt(21.0 / 3), rel=1e-12)
    assert out["normalised_mean"] == pytest.approx((1.0 + 1.0 + 0.25) / 3, rel=1e-12)
    assert out["normalised_band"] == pytest.approx([chi2.ppf(0.025, 3) / 3, chi2.ppf(0.975, 3) / 3], rel=1e-12)


def test_the_band_follows_the_confidence_and_the_count():
    """A wider confidence widens the band; it always brackets 1 (a correct variance model)."""
    rng = np.random.default_rng(np.random.SeedSequence(2))
    ds = _ds(rng.normal(size=(4, 10)), np.ones((4, 10)))
    narrow = focus_statistics(ds, confidence=0.5)["fix"]["normalised_band"]
    wide = focus_statistics(ds, confidence=0.99)["fix"]["normalised_band"]
    assert wide[0] < narrow[0] < 1.0 < narrow[1] < wide[1]
    assert wide == pytest.approx([chi2.ppf(0.005, 40) / 40, chi2.ppf(0.995, 40) / 40], rel=1e-12)


def test_errors_drawn_with_the_stated_sigma_fall_in_the_band_and_a_halved_sigma_does_not():
    """Gaussian fixes with the sigma the filter states: normalised mean inside the band; sigma stated half: ~4, out."""
    rng = np.random.default_rng(np.random.SeedSequence(7))
    sig = rng.uniform(0.1, 2.0, size=(20, 30))
    err = sig * rng.normal(size=sig.shape)
    good = focus_statistics(_ds(err, sig))["fix"]
    lo, hi = good["normalised_band"]
    assert lo < good["normalised_mean"] < hi
    bad = focus_statistics(_ds(err, sig / 2))["fix"]
    assert bad["normalised_mean"] > bad["normalised_band"][1]


def test_no_usable_fix_gives_a_count_of_zero_and_no_normalised_statistics():
    """All errors NaN or all sigmas invalid: ``fix`` is just {"count": 0}."""
    assert focus_statistics(_ds([[np.nan, np.nan]], [[1.0, 1.0]])) == {"fix": {"count": 0}}
    assert focus_statistics(_ds([[1.0, 2.0]], [[0.0, -1.0]])) == {"fix": {"count": 0}}


def test_a_single_fix_has_zero_std():
    """std of one value is reported as 0 (not NaN from ddof 1)."""
    out = focus_statistics(_ds([[3.0]], [[1.5]]))["fix"]
    assert out["count"] == 1 and out["std"] == 0.0 and out["normalised_mean"] == pytest.approx(4.0)


def test_mapdrift_errors_are_summarised_on_their_own_finite_values():
    """``mapdrift``: statistics of its own finite errors, independent of the fix sigmas."""
    md = [[0.5, np.nan], [-1.5, 1.0]]
    out = focus_statistics(_ds([[1.0, 1.0], [1.0, 1.0]], [[1.0, 1.0], [1.0, 1.0]], mapdrift_error=md))
    e = np.array([0.5, -1.5, 1.0])
    assert out["mapdrift"]["count"] == 3
    assert out["mapdrift"]["rms"] == pytest.approx(np.sqrt(np.mean(e**2)), rel=1e-12)
    assert out["mapdrift"]["max_abs"] == 1.5
    assert "mapdrift" not in focus_statistics(_ds([[1.0]], [[1.0]]))


def test_predicted_sigma_is_the_rms_over_runs_at_the_first_and_last_update():
    """RMS over runs (NaN runs skipped) of the EKF's predicted 1-sigma at update 0 and at the last update."""
    p = [[1.0, 2.0, 3.0], [3.0, np.nan, np.nan], [np.nan, 4.0, 4.0]]
    out = focus_statistics(_ds(np.ones((3, 3)), np.ones((3, 3)), predicted_sigma=p))["predicted_sigma"]
    assert out["first_update"] == pytest.approx(np.sqrt((1.0 + 9.0) / 2), rel=1e-12)
    assert out["last_update"] == pytest.approx(np.sqrt((9.0 + 16.0) / 2), rel=1e-12)
    none = focus_statistics(_ds(np.ones((1, 2)), np.ones((1, 2)), predicted_sigma=[[np.nan, np.nan]]))
    assert "predicted_sigma" not in none
