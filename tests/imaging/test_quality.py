"""Image-quality scores against closed forms (Hathaway eqs. 3.5, 3.6; Groen normalised variance)."""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging import quality as q


def _complex_gaussian(n, seed, sigma2=1.0):
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    return np.sqrt(sigma2 / 2) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))


def test_kurtosis_of_complex_gaussian_is_zero_within_standard_error():
    # Delta method at sigma^2 = s: dK = d m4 - 4 s d m2 with |y|^2 ~ s*Exp(1):
    # Var(p^2 - 4 s p) = s^4 (24 - 48 + 32 - 4) = 4 s^4  ->  SE = 2 s^2 / sqrt(N).
    n, s = 1_000_000, 2.5
    y = _complex_gaussian(n, 11, s).reshape(1000, 1000)
    se = 2 * s**2 / np.sqrt(n)
    k = q.complex_kurtosis(y)
    assert abs(k) < 3 * se
    assert abs(q.normalised_complex_kurtosis(y)) < 3 * 2 / np.sqrt(n)


def test_kurtosis_closed_forms():
    p = 400
    spike = np.zeros(p, complex)
    spike[7] = 1.0
    # mean|y|^4 = 1/P, mean|y|^2 = 1/P, |mean y^2| = 1/P  ->  K = 1/P - 3/P^2
    assert q.complex_kurtosis(spike) == pytest.approx(1 / p - 3 / p**2, rel=1e-12)
    assert q.normalised_complex_kurtosis(spike) == pytest.approx(p - 3, rel=1e-12)
    # constant modulus, uniform phase (sub-Gaussian): m4 = m2 = 1, E[y^2] = 0 -> K = -1
    theta = 2 * np.pi * np.arange(1000) / 1000
    assert q.complex_kurtosis(np.exp(1j * theta)) == pytest.approx(-1.0, abs=1e-12)
    # amplitude^4 scaling of the raw (un-normalised) eq. (3.5)
    y = _complex_gaussian(1000, 3)
    assert q.complex_kurtosis(3 * y) == pytest.approx(81 * q.complex_kurtosis(y), rel=1e-10)
    # mean removal: adding a constant changes raw K but not the mean-removed K
    assert q.complex_kurtosis(y + 5, remove_mean=True) == pytest.approx(
        q.complex_kurtosis(y - y.mean()), rel=1e-9)


def test_entropy_coin_examples():
    fair = np.r_[np.zeros(500), np.ones(500)]
    assert q.histogram_entropy(fair, 2) == pytest.approx(1.0, abs=1e-12)
    assert q.histogram_entropy(fair, 10) == pytest.approx(1.0, abs=1e-12)
    biased = np.r_[np.zeros(100), np.ones(900)]
    # -0.9 log2 0.9 - 0.1 log2 0.1 = 0.46900 (Hathaway L316-322)
    assert q.histogram_entropy(biased, 10) == pytest.approx(0.469, abs=5e-4)
    assert q.entropy_bits([0.9, 0.1]) == pytest.approx(0.4689955935892812, abs=1e-12)
    # uniform spread over N equal bins -> log2 N; a constant -> 0
    assert q.histogram_entropy(np.arange(1000.0), 8) == pytest.approx(3.0, abs=1e-12)
    assert q.histogram_entropy(np.full(10, 2.0), 8) == 0.0


def test_entropy_magnitude_and_sum_use_the_stated_variables():
    y = np.array([1 + 0j, 0 + 1j, 3 + 4j, -1 - 1j])
    # magnitudes 1, 1, 5, sqrt2 ; 2 bins over [1, 5] -> {1, 1, sqrt2} and {5}
    assert q.entropy_magnitude(y, 2) == pytest.approx(q.entropy_bits([0.75, 0.25]))
    # Re + Im: 1, 1, 7, -2 ; 3 bins over [-2, 7] -> {-2}, {1, 1}, {7}
    assert q.entropy_sum(y, 3) == pytest.approx(q.entropy_bits([0.25, 0.5, 0.25]))


def test_contrast_of_speckle_matches_rayleigh_theory():
    y = _complex_gaussian(400_000, 5, 3.0)
    # |I|^2 ~ Exp: var/mean^2 = 1 ; Rayleigh: E|I|^2 / E|I|^2 = 4/pi
    assert q.normalised_variance(y) == pytest.approx(1.0, abs=0.02)
    assert q.intensity_contrast(y) == pytest.approx(4 / np.pi, abs=0.01)
    assert q.std_to_mean_contrast(y) == pytest.approx(np.sqrt(4 / np.pi - 1), abs=0.01)
    # Rayleigh amplitude: var/mean^2 = 4/pi - 1
    assert q.normalised_variance(y, quantity="amplitude") == pytest.approx(4 / np.pi - 1, abs=0.01)


def test_bad_input_is_named():
    with pytest.raises(ConfigError, match="n_bins"):
        q.histogram_entropy(np.arange(4.0), 0)
    with pytest.raises(InputDataError, match="image"):
        q.complex_kurtosis(np.array([1.0, np.nan]))
    with pytest.raises(InputDataError, match="probabilities"):
        q.entropy_bits([0.5, 0.6])
    with pytest.raises(ConfigError, match="quantity"):
        q.normalised_variance(np.ones(3), quantity="power")
