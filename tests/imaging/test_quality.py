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


# ---------------------------------------------------------------------------------------------
# conventions pinned to closed forms (docs/quality.md)

def test_speckle_fourth_moment_is_two_and_cumulant_zero():
    # circular complex Gaussian: E|y|^4 = 2 (E|y|^2)^2, E y^2 = 0 (T4). Standard errors by the delta method:
    # m4/m2^2 with |y|^2 ~ Exp: Var(x^2 - 4x) = 24 - 48 + 32 - 4 = 4 for the ratio's linearisation -> SE = 2/sqrt(N)
    n = 1_000_000
    y = _complex_gaussian(n, 21, 0.7)
    se = 2.0 / np.sqrt(n)
    assert q.normalised_fourth_moment(y) == pytest.approx(2.0, abs=4 * se)
    assert abs(q.normalised_complex_kurtosis(y)) < 4 * se
    assert abs(q.complex_kurtosis(y, remove_mean=True)) < 4 * se * 0.7**2


def test_speckle_intensity_entropy_is_log_n_minus_one_minus_euler_gamma():
    # p_i = x_i / sum x, x ~ Exp(1): E = ln N - E[x ln x] = ln N - (1 - gamma_E) (+ O(1/N)); SD of
    # mean(x ln x) for Exp(1) is below 1.2 / sqrt(N), so 5e-3 is > 4 SE at N = 512^2.
    y = _complex_gaussian(512 * 512, 22, 5.0)
    expected = np.log(y.size) - (1.0 - q.EULER_GAMMA)
    assert q.intensity_entropy(y) == pytest.approx(expected, abs=5e-3)
    assert 1.0 - q.EULER_GAMMA == pytest.approx(0.42278433509846713, abs=1e-15)


def test_single_bright_pixel_and_uniform_image_limits():
    p = 900
    spike = np.zeros((30, 30), complex)
    spike[4, 17] = 2.0 - 1.0j
    # one pixel carries all intensity: entropy 0, fourth moment P, cumulant |a|^4 (1/P - 3/P^2)
    assert q.intensity_entropy(spike) == 0.0
    assert q.normalised_fourth_moment(spike) == pytest.approx(p, rel=1e-12)
    a4 = abs(2.0 - 1.0j) ** 4
    assert q.complex_kurtosis(spike) == pytest.approx(a4 * (1 / p - 3 / p**2), rel=1e-12)
    # uniform modulus, any phases: entropy ln P (its maximum), fourth moment 1
    rng = np.random.default_rng(np.random.SeedSequence(23))
    uniform = 3.0 * np.exp(2j * np.pi * rng.random((30, 30)))
    assert q.intensity_entropy(uniform) == pytest.approx(np.log(p), abs=1e-12)
    assert q.normalised_fourth_moment(uniform) == pytest.approx(1.0, abs=1e-12)
    # entropy of anything else lies between the limits
    assert 0.0 < q.intensity_entropy(_complex_gaussian(p, 24)) < np.log(p)


def test_coin_entropies_t5():
    assert q.entropy_bits([0.5, 0.5]) == 1.0
    h = -0.9 * np.log2(0.9) - 0.1 * np.log2(0.1)
    assert q.entropy_bits([0.9, 0.1]) == pytest.approx(h, rel=1e-14)
    assert round(q.entropy_bits([0.9, 0.1]), 3) == 0.469


def test_mean_removal_matches_zero_mean_when_the_mean_is_small():
    # the thesis' zero-mean approximation (L302): for zero-mean y, expanding eq. (3.5) of y + mu gives
    # |K(y + mu) - K(y)| <= 4|mu| E|y|^3 + 12 |mu|^2 m2 + 4 |mu|^4; mu = 1e-3 of the rms as in the thesis
    y = _complex_gaussian(10_000, 25)
    y[::97] *= 30.0  # super-Gaussian
    y -= y.mean()
    mu = 1e-3 * np.sqrt(np.mean(np.abs(y) ** 2)) * np.exp(0.3j)
    k_true = q.complex_kurtosis(y)
    bound = 4 * abs(mu) * np.mean(np.abs(y) ** 3) + 12 * abs(mu) ** 2 * np.mean(np.abs(y) ** 2) + 4 * abs(mu) ** 4
    assert abs(q.complex_kurtosis(y + mu) - k_true) <= bound
    assert bound < 2e-3 * k_true
    assert q.complex_kurtosis(y + mu, remove_mean=True) == pytest.approx(k_true, rel=1e-12)


def test_named_measures_and_their_sense():
    y = _complex_gaussian(2500, 26).reshape(50, 50)
    focused = y.copy()
    focused[25, 25] = 40.0
    for name, m in q.QUALITY_MEASURES.items():
        assert m.name == name
        assert q.quality_score(y, name, 100) == m(y, 100)
        # a bright point on speckle is "better" by every measure
        assert m.better(focused, 100) > m.better(y, 100), name
    with pytest.raises(ConfigError, match="measure"):
        q.quality_score(y, "sharpness")


@pytest.mark.parametrize("name", sorted(q.QUALITY_MEASURES))
def test_every_measure_rejects_constant_and_nan_images(name):
    with pytest.raises(InputDataError, match="zero variance"):
        q.quality_score(np.full((8, 8), 1.5 + 0.5j), name, 10)
    with pytest.raises(InputDataError, match="zero variance"):
        q.quality_score(np.zeros((8, 8)), name, 10)
    bad = _complex_gaussian(64, 27).reshape(8, 8)
    bad[3, 3] = np.nan
    with pytest.raises(InputDataError, match="NaN"):
        q.quality_score(bad, name, 10)


def test_bins_below_two_are_rejected():
    y = _complex_gaussian(100, 28)
    for n in (1, 0, -3, 2.5, True):
        with pytest.raises(ConfigError, match="n_bins"):
            q.entropy_magnitude(y, n)
    assert q.entropy_magnitude(y, 2) <= 1.0
