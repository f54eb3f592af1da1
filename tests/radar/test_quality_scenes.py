"""The scenes of the image-quality experiments (``radar.quality_scenes``): the textured clutter of claim T16."""

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.radar.quality_scenes import MAX_SCATTERERS, textured_clutter_scene


def _scene(seed=1, **kw):
    return textured_clutter_scene(np.random.default_rng(seed), (0.0, 1760.0), 25.0, **kw)


def test_speckle_without_texture_has_exponential_power_of_unit_mean():
    """contrast 0 dB: circular-Gaussian amplitudes of unit power, |a|^2 exponential (E|a|^4 = 2)."""
    s = _scene(contrast_db=0.0)
    n = s.amplitudes.size
    assert abs(n - 32.0 * 625.0) < 5.0 * math.sqrt(32.0 * 625.0)  # Poisson count
    p = np.abs(s.amplitudes) ** 2
    assert p.mean() == pytest.approx(1.0, abs=4.0 / math.sqrt(n))
    assert np.mean(p**2) == pytest.approx(2.0, abs=12.0 / math.sqrt(n))
    assert abs(np.mean(s.amplitudes**2)) < 4.0 / math.sqrt(n)  # circular: no preferred phase


def test_texture_power_is_log_normal_with_the_asked_contrast():
    """Mean power E[10^(c g / 10)] = exp((c ln 10 / 10)^2 / 2) over the scene; the power averaged over 1-m cells varies
    with a log-std close to the contrast (the texture's, blurred by speckle of ~32 scatterers a cell)."""
    c = 4.0
    means, stds = [], []
    for seed in range(4):
        s = _scene(seed, contrast_db=c, correlation_m=1.0)
        p = np.abs(s.amplitudes) ** 2
        means.append(p.mean())
        cells = np.floor((s.positions[:, :2] - s.positions[:, :2].min(axis=0)) / 1.0).astype(int)
        key = cells[:, 0] * 100 + cells[:, 1]
        sums, counts = np.bincount(key, p), np.bincount(key)
        ok = counts > 0
        stds.append(np.std(10 * np.log10(sums[ok] / counts[ok])))
    sigma = c * math.log(10) / 10
    assert np.mean(means) == pytest.approx(math.exp(sigma**2 / 2), rel=0.1)
    assert 0.6 * c < np.mean(stds) < 1.2 * c  # speckle adds ~0.8 dB; 1-m cells smooth a 1-m texture a little


def test_positions_inside_the_square_and_the_same_seed_gives_the_same_scene():
    a, b = _scene(7), _scene(7)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.amplitudes, b.amplitudes)
    assert np.all(np.abs(a.positions[:, 0]) <= 12.5) and np.all(np.abs(a.positions[:, 1] - 1760.0) <= 12.5)
    assert np.all(a.positions[:, 2] == 0.0)
    assert not np.array_equal(_scene(8).amplitudes[:10], a.amplitudes[:10])


@pytest.mark.parametrize("kw, match", [
    ({"contrast_db": -1.0}, r"contrast_db: must be a finite number >= 0 dB, got -1.0"),
    ({"contrast_db": True}, r"contrast_db: must be a finite number >= 0 dB, got True"),
    ({"contrast_db": math.nan}, r"contrast_db: must be a finite number >= 0 dB"),
    ({"correlation_m": 0.0}, r"correlation_m"),
    ({"correlation_m": 0.001}, r"correlation_m: must be >= extent / 1024"),
    ({"density": -2.0}, r"density"),
    ({"density": 1e4}, rf"density: asks for 6.25e\+06 scatterers .* at most {MAX_SCATTERERS}"),
])
def test_bad_arguments_are_named_with_their_range(kw, match):
    with pytest.raises(ConfigError, match=match) as err:
        _scene(**kw)
    assert "\n" not in str(err.value)
