"""Scenes: shapes, errors, Poisson counts and amplitude statistics, reproducibility."""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.radar.scene import point_targets, random_scatterers, speckle_scene


def _rng(seed=1):
    return np.random.default_rng(np.random.SeedSequence(seed))


def test_point_targets_shapes():
    s = point_targets([1.0, 2.0, 3.0])
    assert s.positions.shape == (1, 3) and s.amplitudes.dtype == np.complex128 and len(s) == 1
    s2 = point_targets(np.zeros((4, 3)), 2.0)
    np.testing.assert_array_equal(s2.amplitudes, 2.0)
    assert len(s + s2) == 5
    src = np.zeros((2, 3))
    s3 = point_targets(src)
    src[0, 0] = 5.0  # the scene holds a read-only copy; the caller's array stays writable
    assert s3.positions[0, 0] == 0.0 and not s3.positions.flags.writeable
    r = point_targets([[3.0, 4.0, 0.0]]).slant_ranges(np.zeros((2, 3)))
    np.testing.assert_allclose(r, 5.0)
    with pytest.raises(InputDataError, match="^scene.amplitudes"):
        point_targets(np.zeros((4, 3)), np.ones(3))
    with pytest.raises(InputDataError, match="^scene.amplitudes: contains NaN"):
        point_targets(np.zeros((1, 3)), np.nan)


def test_random_scatterers_statistics_and_seed():
    ext = ((0.0, 100.0), (1700.0, 1900.0))
    density = 0.05  # 1000 expected
    a = random_scatterers(_rng(3), ext, density, mean_power=2.0)
    b = random_scatterers(_rng(3), ext, density, mean_power=2.0)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.amplitudes, b.amplitudes)
    n = len(a)
    assert abs(n - 1000) < 4 * np.sqrt(1000)  # Poisson
    assert a.positions[:, 0].min() >= 0 and a.positions[:, 0].max() <= 100
    assert a.positions[:, 1].min() >= 1700 and a.positions[:, 1].max() <= 1900
    p = np.abs(a.amplitudes) ** 2
    assert abs(p.mean() - 2.0) < 4 * 2.0 / np.sqrt(n)  # exponential power: std = mean
    c = random_scatterers(_rng(4), ext, density, amplitude_law="constant", mean_power=2.0)
    np.testing.assert_allclose(np.abs(c.amplitudes) ** 2, 2.0)
    with pytest.raises(ConfigError, match="^density"):
        random_scatterers(_rng(), ext, -1.0)
    with pytest.raises(ConfigError, match="^extent"):
        random_scatterers(_rng(), ((0, -1), (0, 1)), 1.0)
    with pytest.raises(ConfigError, match="^amplitude_law"):
        random_scatterers(_rng(), ext, 1.0, amplitude_law="weibull")
    with pytest.raises(ConfigError, match="^rng"):
        random_scatterers(3, ext, 1.0)


def test_speckle_scene_mean_power_per_cell():
    north = np.arange(60) * 0.5
    east = 1800 + np.arange(80) * 0.5
    refl = np.ones((60, 80))
    refl[:, 40:] = 4.0
    refl[0, 0] = 0.0
    s = speckle_scene(refl, north, east, _rng(7), down=2.0)
    assert len(s) == 60 * 80 - 1
    assert np.all(s.positions[:, 2] == 2.0)
    p = np.abs(s.amplitudes) ** 2
    left = s.positions[:, 1] < east[40]
    for mask, mean in ((left, 1.0), (~left, 4.0)):
        assert abs(p[mask].mean() - mean) < 4 * mean / np.sqrt(mask.sum())
    with pytest.raises(InputDataError, match="^north_axis/east_axis"):
        speckle_scene(refl, north[:-1], east, _rng())
    with pytest.raises(InputDataError, match="^reflectivity"):
        speckle_scene(-refl, north, east, _rng())
