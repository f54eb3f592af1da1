"""Score-versus-velocity-error curves of Hathaway (2023) Figs. 4.1-4.8 and claims T3, T7-T17.

Slow tests (``pytest -m slow tests/analysis/test_quality_sweep.py``, about 10 minutes on 2 cores): the full
along-track sweep (sizes 10..200, N = 10, 100, 1000), the cross-track sweep, and 20 point/clutter scenes (T16).
"""

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.analysis import quality_sweep as qs
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import PointGrid
from sarnav.radar.quality_scenes import QualityGeometry, binary_scene, point_clutter_scene, usu_picture

GEO = QualityGeometry()  # 4000 pulses, 25 m square, PRF 1667 Hz, 60 m/s, slant 2024 m


@pytest.fixture(scope="module")
def usu():
    scene = binary_scene(usu_picture(), GEO.scene_center, GEO.scene_extent)
    return qs.compressed_pulses(GEO, scene)


@pytest.fixture(scope="module")
def along(usu):
    errors = qs.error_grid(GEO, "along", 7, 4.2)  # the slow tests' grid (step 0.6 focus depth), central 15 points
    return qs.quality_sweep(usu, GEO, errors, "along", (50,), (10, 100))


def _step_of_best(ds, measure, size, bins=None):
    curve = ds[measure].sel(size=size)
    if bins is not None:
        curve = curve.sel(bins=bins)
    e = ds["error"].values
    best = qs.extremum_error(e, curve.values, bool(ds.attrs[f"maximise_{measure}"]))
    return round(best / (e[1] - e[0]))


def test_focus_depth_is_the_pi_over_two_quadratic_phase():
    # independent check: two-way phase of the scene centre along the track scaled by (1 + eps) about the middle
    eps = qs.focus_depth(GEO)
    p = GEO.positions()
    scaled = qs.velocity_error_positions(p, eps, "along", GEO.along_track, GEO.cross_track, pivot=p.shape[0] // 2)
    lam = GEO.radar().wavelength
    dphi = 4 * np.pi / lam * (np.linalg.norm(scaled - GEO.scene_center, axis=1) - np.linalg.norm(p - GEO.scene_center, axis=1))
    t = GEO.pulse_times() - GEO.pulse_times().mean()
    quad = np.polyfit(t, dphi, 2)[0] * t.max() ** 2
    assert abs(quad) == pytest.approx(np.pi / 2, rel=0.02)


def test_velocity_error_positions():
    p = GEO.positions()
    along = qs.velocity_error_positions(p, 0.01, "along", GEO.along_track, GEO.cross_track)
    np.testing.assert_allclose(along[:, 0] - p[0, 0], 1.01 * (p[:, 0] - p[0, 0]), rtol=1e-12)
    cross = qs.velocity_error_positions(p, 0.002, "cross", GEO.along_track, GEO.cross_track)
    np.testing.assert_allclose(cross[:, 1], 0.002 * (p[:, 0] - p[0, 0]), atol=1e-12)
    with pytest.raises(ConfigError, match="direction"):
        qs.velocity_error_positions(p, 0.01, "up", GEO.along_track, GEO.cross_track)


def test_cross_track_error_rotates_the_image(usu):
    """T8 explained: y += eta (x - x0) on flat ground is a rotation about the vertical through p(n0) (plus a stretch
    eta^2 / 2): the image is the reference image on the rotated grid, not a defocused one."""
    eta = 0.002
    grid = qs.image_grid(GEO, 32)
    p = np.asarray(usu.positions)
    img = backproject(usu, grid, positions=qs.velocity_error_positions(p, eta, "cross", GEO.along_track,
                                                                      GEO.cross_track)).data
    th = math.atan(eta)
    rot = np.array([[math.cos(th), math.sin(th), 0], [-math.sin(th), math.cos(th), 0], [0, 0, 1]])
    pts = (grid.points() - p[0]) @ rot.T + p[0]   # pixels rotated back by -theta about the pivot
    ref = backproject(usu, PointGrid(pts), positions=p).data
    err = np.sum(np.abs(img - ref) ** 2) / np.sum(np.abs(ref) ** 2)
    assert 10 * np.log10(err) < -20.0


def test_t7_kurtosis_peaks_within_one_step_of_zero_at_50(along):
    assert abs(_step_of_best(along, "kurtosis", 50)) <= 1


def test_t13_entropy_magnitude_has_a_trough_at_zero_with_ten_bins(along):
    e = along["error"].values
    assert qs.local_minimum_near(e, along["entropy_magnitude"].sel(size=50, bins=10).values, 1)


def test_t17_mean_removed_kurtosis_follows_zero_mean_kurtosis(along):
    for n in (50,):
        assert qs.curve_correlation(along["kurtosis"].sel(size=n), along["kurtosis_mean_removed"].sel(size=n)) > 0.99


def test_t3_along_track_error_blurs_and_shifts_cross_track_shifts(usu):
    out = qs.t3_example(usu, GEO, 100)
    # 0.2 % along-track: 1.3 focus depths -> blurred (sharpness and correlation fall) and shifted along-track by
    # eps x mean distance from the first pulse (0.002 x 72 m = 0.14 m)
    assert out["along_sharpness"] < 0.8 and out["along_correlation"] < 0.9
    assert out["along_shift_m"][0] == pytest.approx(0.002 * 72.0, abs=0.125)
    # 0.002 m/m cross-track: a rotation, the image moves by eta x ground range = 3.5 m along-track, stays sharp
    assert out["cross_shift_m"][0] == pytest.approx(-0.002 * GEO.ground_range, abs=0.25)
    assert out["cross_sharpness"] > 0.9


def test_sweep_dataset_layout_and_bad_input(usu, along):
    assert set(along.dims) == {"size", "bins", "error"}
    assert along["entropy_sum"].dims == ("size", "bins", "error") and along["kurtosis"].dims == ("size", "error")
    assert along.attrs["maximise_kurtosis"] == 1 and along.attrs["maximise_entropy_magnitude"] == 0
    assert set(qs.FIGURES) == {"4.2", "4.3-4.6", "4.7", "4.8"}
    with pytest.raises(ConfigError, match="errors"):
        qs.quality_sweep(usu, GEO, [0.0, 0.0, 1.0])
    with pytest.raises(ConfigError, match="sizes"):
        qs.quality_sweep(usu, GEO, [-1.0, 0.0, 1.0], sizes=(1,))
    with pytest.raises(ConfigError, match="figure"):
        qs.figure_data("4.9", usu, GEO)
    with pytest.raises(ConfigError, match="measures"):
        qs.quality_sweep(usu, GEO, [-1.0, 0.0, 1.0], sizes=(4,), measures=("sharpness",))


# ---------------------------------------------------------------------------------------------
# slow: the full figures

@pytest.fixture(scope="module")
def full_along(usu):
    return qs.quality_sweep(usu, GEO, qs.error_grid(GEO, "along", 10), "along", (10, 50, 100, 200), (10, 100, 1000))


@pytest.mark.slow
def test_t7_t9_t10_kurtosis_curves(full_along):
    ds = full_along
    for n in (50, 100, 200):
        assert abs(_step_of_best(ds, "kurtosis", n)) <= 1                          # T7
    k = ds["kurtosis"].sel(size=200).values
    i = int(np.argmax(k))
    assert np.all(np.diff(k[i - 3:i + 1]) > 0) and np.all(np.diff(k[i:i + 4]) < 0)  # T9: monotone near the peak
    rough = {n: qs.count_local_extrema(ds["kurtosis"].sel(size=n).values) for n in (10, 50, 100, 200)}
    assert rough[10] >= max(rough[50], rough[100], rough[200])                   # T10


@pytest.mark.slow
def test_t11_t13_t15_entropy_curves(full_along):
    ds = full_along
    e = ds["error"].values
    for b in (10, 100, 1000):
        assert qs.local_minimum_near(e, ds["entropy_magnitude"].sel(size=100, bins=b).values, 1)   # T11, T13
    # T15: entropy sum is never smoother than entropy magnitude (local extrema count) -- with the BPA of main since the
    # imaging merge (interpolation "auto") this holds at N = 10 only (11 against 7 local extrema); at N = 100 and 1000
    # the sum has 5 against 7 and a deeper trough: not reproduced there (docs/quality.md §3)
    mag = qs.count_local_extrema(ds["entropy_magnitude"].sel(size=100, bins=10).values)
    s = qs.count_local_extrema(ds["entropy_sum"].sel(size=100, bins=10).values)
    assert s >= mag


@pytest.mark.slow
def test_t14_cross_track_entropy_has_no_trough_at_zero(usu):
    ds = qs.quality_sweep(usu, GEO, qs.error_grid(GEO, "cross", 10), "cross", (100,), (10, 100, 1000))
    e = ds["error"].values
    i0 = int(np.argmin(np.abs(e)))
    for b in (10, 100, 1000):
        h = ds["entropy_magnitude"].sel(size=100, bins=b).values
        assert h[i0] > np.min(h) and not qs.local_minimum_near(e, h, 0)


@pytest.mark.slow
def test_t16_reliability_over_20_scenes():
    """Distance of the extremum from zero error over 20 point/clutter scenes at 100 x 100 (docs/quality.md). The thesis'
    ordering (kurtosis more reliable than entropy) is not reproduced: entropy magnitude is exactly at zero at least as
    often as raw kurtosis, and normalising (3.5) by m2^2 removes most of raw kurtosis' offset."""
    errors = qs.error_grid(GEO, "along", 10)
    seeds = np.random.SeedSequence(16).spawn(20)
    scenes = [point_clutter_scene(np.random.default_rng(s), GEO.scene_center, GEO.scene_extent, clutter_density=0.5)
              for s in seeds]
    best = qs.reliability_study(GEO, scenes, errors, 100, 100, ("kurtosis", "normalised_kurtosis", "entropy_magnitude"))
    steps = np.abs(np.round(best / (errors[1] - errors[0])))
    assert np.all(steps <= 1)                                     # every measure within one step, every scene
    exact = np.mean(steps == 0, axis=0)
    assert exact[2] >= exact[0] and exact[1] >= exact[0]


@pytest.mark.slow
def test_t16_kurtosis_beats_entropy_on_textured_scenes_without_bright_points():
    """T16 where the thesis saw entropy fail (the BYU sea ice: distributed, low contrast, no dominant scatterer;
    docs/quality.md "T16 on distributed scenes"): 12 scenes of ``textured_clutter_scene`` (3 dB, 1 m, 32 per m^2,
    the ``[reliability] scene = "textured"`` of quality-sweep, seed 29), 100 x 100, N = 100. Zoomed out (+-6 focus
    depths, 0.6-depth steps): raw and normalised kurtosis peak within one step of zero in every scene, entropy
    magnitude is off by 2-8 steps in four (mean distance 0.58 against 1.75 steps). Zoomed in (+-1.2 depths, 0.12-depth
    steps): neither is reliable (mean distance ~3 steps, 0.35-0.41 depth, for both)."""
    from sarnav.analysis.quality_sweep import ReliabilitySpec, reliability_scenes

    measures = ("kurtosis", "normalised_kurtosis", "entropy_magnitude")
    rel = ReliabilitySpec(scenes=12, size=100, bins=100, seed=29, clutter_density=0.5, measures=measures,
                          scene="textured")
    wide, zoom = qs.error_grid(GEO, "along", 10, 6.0), qs.error_grid(GEO, "along", 10, 1.2)
    steps = {"wide": [], "zoom": []}
    for scene in reliability_scenes(rel, GEO):
        rc = qs.compressed_pulses(GEO, scene)
        for key, errors in (("wide", wide), ("zoom", zoom)):
            ds = qs.quality_sweep(rc, GEO, errors, "along", (100,), (100,), measures)
            steps[key].append([round(qs.extremum_error(errors, _curve(ds, m), bool(ds.attrs[f"maximise_{m}"]))
                                     / (errors[1] - errors[0])) for m in measures])
    w, z = np.abs(np.array(steps["wide"])), np.abs(np.array(steps["zoom"]))
    assert np.all(w[:, :2] <= 1)                                  # both kurtoses within one step, every scene
    assert np.sum(w[:, 2] >= 2) >= 3                              # entropy off by two steps or more in >= 3 scenes
    assert w[:, 2].mean() > 2.0 * w[:, 0].mean()
    assert z.mean(axis=0).min() > 2.0                             # zoomed in: no measure within two fine steps on average


def _curve(ds, measure):
    curve = ds[measure].sel(size=100)
    return (curve.sel(bins=100) if "bins" in curve.dims else curve).values
