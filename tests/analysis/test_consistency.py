"""Consistency statistics against hand-computed cases and seeded χ² samples."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from sarnav.analysis.consistency import (
    chi2_band,
    nees_statistics,
    nis_statistics,
    residual_statistics,
    sigma_containment,
)


def test_chi2_band_closed_form_dof2():
    # chi2 with 2 dof is exponential with mean 2: ppf(p) = -2 ln(1 - p)
    lo, hi = chi2_band(2, 1)
    assert lo == pytest.approx(-2 * math.log(0.975), rel=1e-12)
    assert hi == pytest.approx(-2 * math.log(0.025), rel=1e-12)
    # average of N chi2(2): band scales with 1/N on chi2(2N); N = 1 reproduces the above
    lo4, hi4 = chi2_band(8, 4)
    assert lo4 < 2 < hi4 and hi4 - lo4 < hi - lo
    with pytest.raises(ValueError, match="confidence"):
        chi2_band(2, 1, confidence=1.5)


def test_sigma_containment_hand_case():
    e = np.array([[[0.0, 3.0]], [[2.9, -3.1]], [[np.nan, 1.0]], [[-4.0, 0.5]]])  # (R=4, T=1, S=2)
    s = np.ones_like(e)
    # state 0: |0|, |2.9| inside, nan ignored, |-4| outside -> 2/3; state 1: 3.0 inside (<=), 3.1 out -> 3/4
    np.testing.assert_allclose(sigma_containment(e, s), [2 / 3, 3 / 4])


def test_sigma_containment_gaussian_matches_normal_cdf():
    rng = np.random.default_rng(np.random.SeedSequence(11))
    e = rng.standard_normal((400, 100, 3)) * np.array([1.0, 2.0, 0.5])
    frac = sigma_containment(e, np.broadcast_to([1.0, 2.0, 0.5], e.shape), k=2.0)
    p = 2 * norm.cdf(2.0) - 1  # 0.9545
    se = math.sqrt(p * (1 - p) / (400 * 100))
    np.testing.assert_array_less(np.abs(frac - p), 4 * se)


def test_nees_hand_case_and_band():
    nees = np.array([[1.0, 2.0], [3.0, 10.0]])
    st = nees_statistics(nees, n_state=2)
    np.testing.assert_allclose(st["mean"], [2.0, 6.0])
    lo, hi = chi2_band(4, 2)
    assert st["band"] == pytest.approx((lo, hi))
    assert st["fraction_in_band"] == pytest.approx(np.mean([(lo <= 2.0 <= hi), (lo <= 6.0 <= hi)]))
    assert st["time_average"] == pytest.approx(4.0)


def test_nees_of_consistent_gaussian_errors_is_in_band_95_percent():
    """Errors drawn from N(0, P) with a full P; NEES computed independently with P^-1."""
    rng = np.random.default_rng(np.random.SeedSequence(2024))
    S, R, T = 4, 50, 800
    A = rng.standard_normal((S, S))
    P = A @ A.T + S * np.eye(S)
    L = np.linalg.cholesky(P)
    e = rng.standard_normal((R, T, S)) @ L.T
    nees = np.einsum("rti,ij,rtj->rt", e, np.linalg.inv(P), e)
    st = nees_statistics(nees, S)
    # independent epochs: fraction in band ~ Binomial(T, 0.95)/T, sd 0.0077
    assert abs(st["fraction_in_band"] - 0.95) < 4 * math.sqrt(0.95 * 0.05 / T)
    assert abs(st["time_average"] - S) < 4 * math.sqrt(2 * S / (R * T))
    # an over-confident filter (P/4) is detected
    bad = nees_statistics(4 * nees, S)
    assert bad["fraction_in_band"] < 0.01


def test_nis_with_varying_dof_hand_case():
    nis = np.array([[1.0, 2.0, 9.0], [3.0, 0.0, 5.0]])
    dof = np.array([[1, 2, 0], [2, 0, 1]])
    st = nis_statistics(nis, dof)
    # update 0: both runs, dof 1+2=3, mean (1+3)/2; update 1: run 0 only; update 2: run 1 only
    np.testing.assert_allclose(st["mean"], [2.0, 2.0, 5.0])
    np.testing.assert_allclose(st["expected"], [1.5, 2.0, 1.0])
    lo0, hi0 = chi2_band(3, 2)
    assert st["lo"][0] == pytest.approx(lo0) and st["hi"][0] == pytest.approx(hi0)
    assert st["total_dof"] == 6
    assert st["per_dof"] == pytest.approx((1 + 3 + 2 + 5) / 6)


def test_nis_of_seeded_chi2_with_varying_dof():
    rng = np.random.default_rng(np.random.SeedSequence(5))
    R, U = 30, 600
    dof = rng.integers(0, 4, size=(R, U))  # 0..3 measurements present
    nis = np.where(dof > 0, rng.chisquare(np.maximum(dof, 1)), np.nan)
    st = nis_statistics(nis, dof)
    assert abs(st["fraction_in_band"] - 0.95) < 4 * math.sqrt(0.95 * 0.05 / U)
    lo, hi = st["per_dof_band"]
    assert lo < st["per_dof"] < hi


def test_residual_statistics_hand_case():
    r = np.array([[[1.0, np.nan], [3.0, 2.0]], [[-1.0, 4.0], [5.0, np.nan]]])  # (R=2, U=2, M=2)
    s = np.full_like(r, 2.0)
    st = residual_statistics(r, s)
    np.testing.assert_allclose(st["mean"], [2.0, 3.0])
    np.testing.assert_array_equal(st["count"], [4, 2])
    np.testing.assert_allclose(st["stderr"], [np.std([1, 3, -1, 5], ddof=1) / 2, np.std([2, 4], ddof=1) / math.sqrt(2)])
    np.testing.assert_allclose(st["normalized_mean"], [1.0, 1.5])
