"""``radar.ground_scene``: the Gaussian-hill terrain (closed form, gradient, random draw) and the distributed clutter
checked against theory: Poisson count, uniform placement, mean power per unit area whatever the density, fully
developed speckle (circular Gaussian amplitudes, exponential intensity), the local-incidence law on terrain, and the
temporal coherence between the two passes. Tolerances are 5 standard errors of the estimator under the stated law."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.radar.ground_scene import HillTerrain, distributed_clutter
from sarnav.trajectory.straight import StraightLevel

V, ALT = 50.0, 1000.0
TOC, GR = (2.0, 12.0), (1500.0, 1700.0)
AREA = V * (TOC[1] - TOC[0]) * (GR[1] - GR[0])  # 500 m x 200 m


def _rng(seed):
    return np.random.default_rng(np.random.SeedSequence(seed))


@pytest.fixture(scope="module")
def track():
    return StraightLevel([0.0, 0.0, -ALT], V, 0.0, 20.0)


def _hill(a=30.0, w=80.0, n=10.0, e=1600.0):
    return HillTerrain(np.array([[n, e]]), np.array([w]), np.array([a]))


# ------------------------------------------------------------------------------------------------ terrain
def test_one_hill_height_is_the_gaussian_closed_form():
    """h = a exp(-d^2 / 2 w^2): a at the centre, a e^-1/2 at one width, sums of hills add."""
    h = _hill(a=30.0, w=80.0, n=10.0, e=20.0)
    np.testing.assert_allclose(h.height(10.0, 20.0), 30.0)
    np.testing.assert_allclose(h.height([90.0, 10.0], [20.0, -60.0]), 30.0 * math.exp(-0.5))
    two = HillTerrain(np.array([[0.0, 0.0], [100.0, 0.0]]), np.array([50.0, 20.0]), np.array([10.0, -4.0]))
    np.testing.assert_allclose(two.height(40.0, 5.0),
                               10.0 * math.exp(-(40**2 + 5**2) / 5000.0) - 4.0 * math.exp(-(60**2 + 5**2) / 800.0))
    assert h.height(np.zeros((2, 3)), 0.0).shape == (2, 3)


def test_gradient_matches_finite_differences():
    """(dh/dN, dh/dE) equals central differences of the height on a random terrain."""
    terrain = HillTerrain.random(_rng(5), ((0.0, 400.0), (1000.0, 1400.0)), 40.0)
    rng = _rng(6)
    n, e, d = rng.uniform(0, 400, 50), rng.uniform(1000, 1400, 50), 1e-3
    gn, ge = terrain.gradient(n, e)
    np.testing.assert_allclose(gn, (terrain.height(n + d, e) - terrain.height(n - d, e)) / (2 * d), atol=1e-6)
    np.testing.assert_allclose(ge, (terrain.height(n, e + d) - terrain.height(n, e - d)) / (2 * d), atol=1e-6)


def test_random_terrain_follows_its_laws():
    """Hill count ~ Poisson(hills_per_km2 x area of the extent widened by 2 max widths), centres inside that area,
    widths in ``scale``, heights N(0, relief^2); relief 0 is flat ground."""
    ext, scale, rate, relief = ((0.0, 2000.0), (-1000.0, 3000.0)), (40.0, 200.0), 60.0, 25.0
    lam = rate * (2000.0 + 800.0) * (4000.0 + 800.0) / 1e6
    t = HillTerrain.random(_rng(11), ext, relief, scale, rate)
    k = len(t.widths)
    assert abs(k - lam) < 5 * math.sqrt(lam)
    assert np.all((t.centres[:, 0] >= -400) & (t.centres[:, 0] <= 2400))
    assert np.all((t.centres[:, 1] >= -1400) & (t.centres[:, 1] <= 3400))
    assert np.all((t.widths >= 40.0) & (t.widths <= 200.0))
    assert abs(np.std(t.heights) / relief - 1.0) < 5 / math.sqrt(2 * k)  # std error of a sample std
    flat = HillTerrain.random(_rng(11), ext, 0.0)
    np.testing.assert_array_equal(flat.height([0.0, 500.0], [0.0, 100.0]), 0.0)


@pytest.mark.parametrize("relief, scale, field", [(-1.0, (40.0, 200.0), "scene.terrain_relief_m"),
                                                  (float("nan"), (40.0, 200.0), "scene.terrain_relief_m"),
                                                  (1001.0, (40.0, 200.0), "scene.terrain_relief_m"),
                                                  (10.0, (0.0, 200.0), "scene.terrain_scale_m"),
                                                  (10.0, (300.0, 200.0), "scene.terrain_scale_m"),
                                                  (10.0, (40.0, 2e4), "scene.terrain_scale_m")])
def test_bad_terrain_settings_are_one_line_errors(relief, scale, field):
    """A relief outside [0, 1000] m or widths not 0 < min <= max <= 1e4 m: ConfigError naming the key and range."""
    with pytest.raises(ConfigError) as err:
        HillTerrain.random(_rng(0), ((0.0, 100.0), (0.0, 100.0)), relief, scale)
    assert err.value.field == field and "must be" in err.value.message and "\n" not in str(err.value)


# ------------------------------------------------------------------------------------------------ clutter
def test_clutter_count_and_placement_on_flat_ground(track):
    """Count ~ Poisson(density x track length in the window x ground-range width); points on D = 0, to the right
    (east of a northward track) inside the ground ranges, uniform in TOC (north) and ground range (east)."""
    density = 0.2
    a, b = distributed_clutter(_rng(1), track, TOC, GR, density, 1.0)
    lam = density * AREA
    n = len(a)
    assert abs(n - lam) < 5 * math.sqrt(lam)
    np.testing.assert_array_equal(a.positions, b.positions)
    p = a.positions
    np.testing.assert_array_equal(p[:, 2], 0.0)
    assert p[:, 0].min() >= V * TOC[0] and p[:, 0].max() <= V * TOC[1]
    assert p[:, 1].min() >= GR[0] and p[:, 1].max() <= GR[1]
    for x, (lo, hi) in ((p[:, 0], (V * TOC[0], V * TOC[1])), (p[:, 1], GR)):  # uniform: mean and variance
        assert abs(x.mean() - (lo + hi) / 2) < 5 * (hi - lo) / math.sqrt(12 * n)
        assert abs(x.var() / ((hi - lo) ** 2 / 12) - 1) < 5 * math.sqrt(0.8 / n)  # Var of s^2/sigma^2: 4/5 n
    left, _ = distributed_clutter(_rng(1), track, TOC, GR, density, 1.0, look_side="left")
    np.testing.assert_allclose(left.positions[:, 1], -p[:, 1])


@pytest.mark.parametrize("density", [0.05, 0.4])
def test_mean_power_per_area_is_sigma0_whatever_the_density(track, density):
    """sum |a|^2 / area = power_per_m2 (compound Poisson: relative std sqrt(2 / (density x area)))."""
    p0 = 3.0
    a, _ = distributed_clutter(_rng(2), track, TOC, GR, density, p0)
    total = np.sum(np.abs(a.amplitudes) ** 2) / AREA
    assert abs(total / p0 - 1.0) < 5 * math.sqrt(2.0 / (density * AREA))


def test_amplitudes_are_circular_gaussian_speckle(track):
    """Flat ground: |a|^2 d / P ~ Exp(1) (mean 1, second moment 2), real and imaginary parts of equal variance and
    uncorrelated, E[a^2] = 0 (circular)."""
    density, p0 = 0.3, 2.0
    a, _ = distributed_clutter(_rng(3), track, TOC, GR, density, p0)
    x = np.abs(a.amplitudes) ** 2 * density / p0
    n = x.size
    assert abs(x.mean() - 1.0) < 5 / math.sqrt(n)
    assert abs(np.mean(x**2) - 2.0) < 5 * math.sqrt(20.0 / n)  # Var(x^2) = 24 - 4 for Exp(1)
    z = a.amplitudes * math.sqrt(density / p0)
    assert abs(np.mean(z**2)) < 5 / math.sqrt(n)
    assert abs(np.var(z.real) - 0.5) < 5 * math.sqrt(0.5 / n)
    assert abs(np.var(z.imag) - 0.5) < 5 * math.sqrt(0.5 / n)


@pytest.mark.parametrize("gamma", [0.0, 0.3, 0.8, 1.0])
def test_second_pass_has_the_stated_temporal_coherence(track, gamma):
    """The complex correlation of the two passes' amplitudes is gamma (real: std (1 - gamma^2) / sqrt(2N); the
    imaginary part 0), the second pass has the same mean power, and gamma = 1 repeats the amplitudes exactly."""
    density = 0.3
    a, b = distributed_clutter(_rng(4), track, TOC, GR, density, 1.0, coherence=gamma)
    za, zb = a.amplitudes, b.amplitudes
    n = za.size
    rho = np.vdot(za, zb) / math.sqrt(np.vdot(za, za).real * np.vdot(zb, zb).real)
    tol = 5 * max(1.0 - gamma**2, 1e-3) / math.sqrt(2 * n) + 1e-12
    assert abs(rho.real - gamma) < tol and abs(rho.imag) < tol, rho
    pa, pb = np.mean(np.abs(za) ** 2), np.mean(np.abs(zb) ** 2)
    assert abs(pb / pa - 1.0) < 5 * math.sqrt(2.0 * (1 - gamma**2) / n) + 1e-12
    if gamma == 1.0:
        np.testing.assert_array_equal(za, zb)


def test_terrain_moves_the_scatterers_and_sets_the_local_incidence(track):
    """On hills: each scatterer lies on the terrain (D = -h) and |a|^2 d / (P f) ~ Exp(1) with f = max(n . l, 0.05)
    / l_up computed here from the terrain's finite-difference normal and the radar at the scatterer's TOC (a level
    northward track: the radar abeam at the same north)."""
    terrain = HillTerrain.random(_rng(8), ((0.0, 700.0), (1400.0, 1800.0)), 40.0, (40.0, 120.0))
    density, p0 = 0.2, 1.5
    a, _ = distributed_clutter(_rng(9), track, TOC, GR, density, p0, terrain=terrain)
    p = a.positions
    np.testing.assert_allclose(p[:, 2], -terrain.height(p[:, 0], p[:, 1]), atol=1e-9)
    d = 1e-3
    gn = (terrain.height(p[:, 0] + d, p[:, 1]) - terrain.height(p[:, 0] - d, p[:, 1])) / (2 * d)
    ge = (terrain.height(p[:, 0], p[:, 1] + d) - terrain.height(p[:, 0], p[:, 1] - d)) / (2 * d)
    normal = np.stack([-gn, -ge, -np.ones_like(gn)], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    radar = np.stack([p[:, 0], np.zeros(len(p)), np.full(len(p), -ALT)], axis=1)
    los = (radar - p) / np.linalg.norm(radar - p, axis=1, keepdims=True)
    f = np.maximum(np.sum(normal * los, axis=1), 0.05) / (-los[:, 2])
    assert np.std(f) > 0.1  # the terrain really changes the brightness, so the check below can fail
    x = np.abs(a.amplitudes) ** 2 * density / (p0 * f)
    assert abs(x.mean() - 1.0) < 5 / math.sqrt(x.size)


def test_documented_draw_order_and_reproducibility(track):
    """The draws are, in order: count, TOCs, ground ranges, a (real, imaginary), a_new (real, imaginary); the same
    seed gives the same scene."""
    density, p0, gamma = 0.02, 2.0, 0.6
    a, b = distributed_clutter(_rng(21), track, TOC, GR, density, p0, coherence=gamma)
    rng = _rng(21)
    n = rng.poisson(density * AREA)
    toc, gr = rng.uniform(*TOC, n), rng.uniform(*GR, n)
    z = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2)
    z2 = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2)
    s = math.sqrt(p0 / density)
    np.testing.assert_allclose(a.positions, np.stack([V * toc, gr, np.zeros(n)], axis=1), atol=1e-9)
    np.testing.assert_allclose(a.amplitudes, s * z, rtol=1e-12)
    np.testing.assert_allclose(b.amplitudes, s * (gamma * z + math.sqrt(1 - gamma**2) * z2), rtol=1e-12)
    a2, _ = distributed_clutter(_rng(21), track, TOC, GR, density, p0, coherence=gamma)
    np.testing.assert_array_equal(a.amplitudes, a2.amplitudes)


def test_an_empty_patch_gives_empty_scenes(track):
    """A density so low that no scatterer is drawn gives two empty scenes, not an error."""
    a, b = distributed_clutter(_rng(0), track, TOC, GR, 1e-12, 1.0)
    assert len(a) == len(b) == 0 and a.positions.shape == (0, 3)


@pytest.mark.parametrize("kw, field", [({"density": 0.0}, "scene.clutter_density_m2"),
                                       ({"density": 1001.0}, "scene.clutter_density_m2"),
                                       ({"density": float("nan")}, "scene.clutter_density_m2"),
                                       ({"power_per_m2": -1.0}, "scene.clutter_power_m2"),
                                       ({"power_per_m2": float("inf")}, "scene.clutter_power_m2"),
                                       ({"coherence": 1.01}, "scene.reference_coherence"),
                                       ({"coherence": -0.1}, "scene.reference_coherence"),
                                       ({"coherence": float("nan")}, "scene.reference_coherence"),
                                       ({"look_side": "up"}, "radar.look_side")])
def test_bad_clutter_settings_are_one_line_errors(track, kw, field):
    """Each out-of-range setting is a ConfigError naming its key and valid range."""
    args = {"density": 0.1, "power_per_m2": 1.0, **kw}
    with pytest.raises(ConfigError) as err:
        distributed_clutter(_rng(0), track, TOC, GR, **args)
    assert err.value.field == field and "must be" in err.value.message and "\n" not in str(err.value)
