"""``simulation.quality_scene``: the scene and receiver of the image-quality experiments: the scatterer count of each
scene type, the USU picture and the point/clutter scene on the geometry's square, and the seeding (scene draw and
receiver noise from ``SeedSequence([seed, seed_offset])``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarnav.radar.quality_scenes import QualityGeometry, usu_picture
from sarnav.simulation.quality_scene import SCENE_TYPES, QualitySceneSpec, make_scene

GEO = QualityGeometry(n_pulses=400, scene_extent=20.0)


def _spec(**kw):
    base = dict(type="point-clutter", seed=5, points=12, point_to_clutter_db=20.0, clutter_density=2.0, usu_cells=24,
                receiver_noise=False, snr_db=10.0)
    return QualitySceneSpec(**{**base, **kw})


def test_scene_types():
    assert SCENE_TYPES == ("usu", "point-clutter")


def test_expected_scatterers_of_a_point_clutter_scene():
    """points + density x extent^2 (expected clutter count), whatever the seed."""
    assert _spec(points=7, clutter_density=0.25).scatterers(GEO) == 7 + 0.25 * 400.0
    assert _spec(points=0, clutter_density=0.0).scatterers(GEO) == 0.0


def test_usu_scatterers_scale_with_the_square_of_the_enlargement():
    """USU picture: the lit cells; enlarging the 24-cell lattice by an integer k multiplies them by k^2."""
    n24 = _spec(type="usu", usu_cells=24).scatterers(GEO)
    assert n24 == np.count_nonzero(usu_picture((24, 24))) > 0
    assert _spec(type="usu", usu_cells=72).scatterers(GEO) == 9 * n24
    assert _spec(type="usu", usu_cells=48, points=999, clutter_density=50.0).scatterers(GEO) == 4 * n24


def test_usu_scene_is_the_picture_on_the_geometry_square():
    """One unit scatterer per lit cell centre, inside the square of side extent about the scene centre, on the
    ground; no receiver without receiver noise; the seed does not matter."""
    spec = _spec(type="usu", usu_cells=48)
    sc, rng, snr = make_scene(spec, GEO)
    assert rng is None and snr is None
    assert len(sc) == spec.scatterers(GEO)
    np.testing.assert_array_equal(sc.amplitudes, 1.0)
    c, h, cell = GEO.scene_center, GEO.scene_extent / 2, GEO.scene_extent / 48
    p = sc.positions
    assert np.all(np.abs(p[:, 0] - c[0]) <= h - cell / 2 + 1e-9) and np.all(np.abs(p[:, 1] - c[1]) <= h - cell / 2 + 1e-9)
    np.testing.assert_array_equal(p[:, 2], 0.0)
    k = np.round((p[:, 1] - (c[1] - h)) / cell - 0.5)  # cell centres: on the lattice
    np.testing.assert_allclose((p[:, 1] - (c[1] - h)) / cell - 0.5, k, atol=1e-9)
    other, _, _ = make_scene(_spec(type="usu", usu_cells=48, seed=99), GEO, seed_offset=3)
    np.testing.assert_array_equal(other.positions, p)


def test_point_clutter_scene_points_and_clutter():
    """The bright points (first) have |a| = 10^(PCR/20) inside the central 80 % of the square; the clutter count is
    Poisson(density x extent^2) (5-sigma tolerance) spread over the whole square."""
    spec = _spec(points=12, point_to_clutter_db=26.0, clutter_density=2.0)
    sc, _, _ = make_scene(spec, GEO)
    pts, clutter = sc.positions[:12], sc.positions[12:]
    np.testing.assert_allclose(np.abs(sc.amplitudes[:12]), 10 ** (26.0 / 20))
    c, h = GEO.scene_center, GEO.scene_extent / 2
    assert np.all(np.abs(pts[:, :2] - c[:2]) <= 0.8 * h + 1e-9)
    lam = 2.0 * GEO.scene_extent**2
    assert abs(len(clutter) - lam) < 5 * math.sqrt(lam)
    assert np.all(np.abs(clutter[:, :2] - c[:2]) <= h + 1e-9)
    assert np.abs(clutter[:, 1] - c[1]).max() > 0.9 * h  # reaches beyond the points' square


def test_seeding_of_the_scene_and_the_noise():
    """Same spec and offset: the same scene and noise stream; another seed_offset or seed: another draw; with
    receiver noise the snr is passed through and the noise stream is the second child of SeedSequence([seed, offset])
    (independent of the scene's)."""
    spec = _spec(receiver_noise=True, snr_db=-3.0)
    a, ra, snr = make_scene(spec, GEO, seed_offset=2)
    b, rb, _ = make_scene(spec, GEO, seed_offset=2)
    assert snr == -3.0 and isinstance(ra, np.random.Generator)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(ra.standard_normal(5), rb.standard_normal(5))
    c, rc, _ = make_scene(spec, GEO, seed_offset=3)
    assert len(c) != len(a) or not np.array_equal(c.positions, a.positions)
    _, rn, _ = make_scene(spec, GEO, seed_offset=2)
    want = np.random.default_rng(np.random.SeedSequence([5, 2]).spawn(2)[1]).standard_normal(4)
    np.testing.assert_array_equal(rn.standard_normal(4), want)
    d, _, _ = make_scene(_spec(seed=6, receiver_noise=True), GEO, seed_offset=2)
    assert len(d) != len(a) or not np.array_equal(d.positions, a.positions)


@pytest.mark.parametrize("kind", SCENE_TYPES)
def test_no_receiver_noise_means_no_generator(kind):
    """receiver_noise false: (scene, None, None) for either scene type."""
    _, rng, snr = make_scene(_spec(type=kind, receiver_noise=False), GEO)
    assert rng is None and snr is None
