"""``simulation.image_scene``: the image experiment used as a library (no scenario file), checked against geometry
and theory; ``imaging.collect_image`` on the same pulses; ``io.cphd.read_filter``'s bad input."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.imaging.collect_image import collect_figures, form_collect_image
from sarnav.imaging.grid import SlantGrid
from sarnav.radar.params import RadarParams
from sarnav.signal.metrics import peak_location
from sarnav.simulation.image_scene import ImageSceneParams, build_pulses, pulse_track, run, scene_centre
from sarnav.units import C

H, R0, Y0, V, PRF, B = 1000.0, 2003.3, 1.7, 60.0, 250.0, 500e6


def _radar(near=1895.0, n=1340) -> RadarParams:  # the scenario's window: slant ranges +- (cT/4 + 10 m)
    return RadarParams(carrier_frequency=9.75e9, bandwidth=B, pulse_length=1e-6, sample_rate=1e9, prf=PRF,
                       near_range=near, n_range_samples=n, antenna_length=0.5)


def _params(**kw) -> ImageSceneParams:
    base = dict(radar=_radar(), start_ned=(10.0, -5.0, -H), speed=V, duration=1.0, scene="point",
                target_along_track=Y0, target_slant_range=R0)
    return ImageSceneParams(**{**base, **kw})


@pytest.fixture(scope="module")
def point():
    p = _params()
    return p, run(p)


def test_pulse_track_is_straight_level_north_and_centred_on_zero():
    t, pos = pulse_track(_params())
    assert t.size == round(1.0 * PRF) and t[t.size // 2] == 0.0
    assert np.allclose(np.diff(t), 1 / PRF)
    assert np.allclose(pos, np.column_stack([10.0 + V * t, np.full_like(t, -5.0), np.full_like(t, -H)]))


def test_point_target_focuses_at_its_position_with_the_theoretical_range_resolution(point):
    p, res = point
    img = res.image
    iy, ix = peak_location(img.data)
    y = np.interp(iy, np.arange(img.y.size), img.y)
    x = np.interp(ix, np.arange(img.x.size), img.x)
    assert abs(y - Y0) < 0.1 * img.dy and abs(x - R0) < 0.1 * img.dx, (y, x)
    pt = res.metrics["point_target"]
    assert pt["slant_range"]["irw_m"]["theory"] == pytest.approx(0.886 * C / (2 * B), rel=2e-3)
    assert pt["slant_range"]["irw_m"]["measured"] == pytest.approx(0.886 * C / (2 * B), rel=0.03)
    lam = C / 9.75e9
    assert pt["along_track"]["irw_m"]["measured"] == pytest.approx(0.886 * lam * R0 / (2 * V * 1.0), rel=0.05)
    assert res.metrics["n_targets"] == 1 and res.autofocus is None


def test_the_scene_lies_on_the_flat_ground_at_the_slant_range_on_the_look_side():
    for side, sign in (("right", 1.0), ("left", -1.0)):
        p = _params(radar=dataclasses.replace(_radar(), look_side=side))
        centre, half = scene_centre(p)
        assert np.allclose(centre, [10.0 + Y0, -5.0 + sign * math.sqrt(R0**2 - H**2), 0.0]) and half == (10.0, 10.0)
    p = _params(scene="random", along_track_extent=20.0, slant_range_min=1990.0, slant_range_max=2010.0)
    centre, (hn, he) = scene_centre(p)
    g = [math.sqrt(r**2 - H**2) for r in (1990.0, 2010.0)]
    assert centre[1] == pytest.approx(-5.0 + 0.5 * sum(g)) and he == pytest.approx(0.5 * (g[1] - g[0]) + 5.0)
    assert hn == 15.0


def test_random_fields_and_noise_follow_the_seed():
    p = _params(scene="random", along_track_extent=20.0, slant_range_min=1990.0, slant_range_max=2010.0,
                density=0.05, snr_db=10.0, duration=0.2)
    (a, sa), (b, sb), (c, _) = build_pulses(p), build_pulses(p), build_pulses(dataclasses.replace(p, seed=1))
    assert np.array_equal(a.data, b.data) and sa.n_targets == sb.n_targets
    assert not np.array_equal(a.data, c.data)
    quiet, _ = build_pulses(dataclasses.replace(p, snr_db=None))
    assert not np.array_equal(a.data, quiet.data)


def test_collect_image_of_the_same_pulses_is_the_straight_track_bpa_image(point):
    """form_collect_image back-projects the pulses at their own (true) positions: on the straight track's slant grid
    it matches focus_straight_block's BPA image with the true speed (the same positions)."""
    p, _ = point
    bpa = run(dataclasses.replace(p, algorithm="bpa", window="hamming", bpa_interpolation="auto"))  # the CPHD default
    rc = bpa.pulses
    grid = SlantGrid(origin=np.asarray(p.start_ned), direction=[1.0, 0.0, 0.0], look_point=[0.0, 1e3, 0.0],
                     along_track=V * rc.pulse_times, slant_range=rc.slant_range)
    img = form_collect_image(rc, grid, "bpa", "hamming")
    assert img.metadata["window"] == bpa.image.metadata["window"]
    err = np.linalg.norm(img.data - bpa.image.data) / np.linalg.norm(bpa.image.data)
    assert err < 1e-6, err
    fig = collect_figures(rc)
    assert fig.prf == pytest.approx(PRF, rel=1e-12) and fig.speed == pytest.approx(V, rel=1e-12)
    assert fig.bandwidth == pytest.approx(B, rel=0.05)  # from the spectrum: to within its bin and edge roll-off
    with pytest.raises(ConfigError) as err:
        form_collect_image(rc, grid, "rda")
    assert err.value.field == "algorithm"


def test_read_filter_names_its_field(tmp_path):
    from sarnav.io.cphd import read_filter

    np.save(tmp_path / "ok.npy", np.arange(5.0))
    assert np.array_equal(read_filter(tmp_path / "ok.npy"), np.arange(5.0))
    np.save(tmp_path / "two.npy", np.ones((2, 3)))
    (tmp_path / "junk.npy").write_bytes(b"not npy")
    for bad in ("two.npy", "junk.npy", "missing.npy"):
        with pytest.raises(ConfigError) as err:
            read_filter(tmp_path / bad, "--filter")
        assert err.value.field == "--filter"
