"""The along-track offset expansion of back-projection against exact back-projection on the candidate tracks."""

import math
from dataclasses import replace

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.offset_bpa import offset_moments, order_for
from sarnav.imaging.range_compression import range_compress
from sarnav.radar.quality_scenes import QualityGeometry, binary_scene, simulate_pulses, usu_picture


@pytest.fixture(scope="module")
def block():
    geo = QualityGeometry(n_pulses=600, scene_extent=20.0)
    scene = binary_scene(usu_picture((24, 24)), geo.scene_center, geo.scene_extent)
    rc = range_compress(simulate_pulses(geo, scene))
    sl = slice(300, 600)
    rcb = replace(rc, data=rc.data[sl], pulse_times=rc.pulse_times[sl], positions=rc.positions[sl])
    grid = GroundGrid.centered(0.0, geo.ground_range, geo.grid_spacing(32), (32, 32))
    return geo, rcb, grid


def _err_db(a, b):
    return 10 * np.log10(np.sum(np.abs(a - b) ** 2) / np.sum(np.abs(b) ** 2))


def test_order_for_meets_the_truncation_bound():
    for x in (0.01, 0.3, 2.0, 7.0):
        q = order_for(x, 1e-6)
        assert x ** (q + 1) / math.factorial(q + 1) <= 1e-6
        assert q == 0 or x ** q / math.factorial(q) > 1e-6


@pytest.mark.parametrize("delta", [0.0, 2e-5, -2e-5, 1.5e-4])
def test_expansion_matches_exact_bpa_on_the_candidate_track(block, delta):
    geo, rcb, grid = block
    tau = np.arange(1.0, rcb.n_pulses + 1)  # samples since the block start (Alg. 3.3)
    e = geo.along_track
    mom = offset_moments(rcb, grid, rcb.positions, e, tau, order_for(0.2, 1e-8))
    img = mom.image(delta, tolerance=1e-2)
    ref = backproject(rcb, grid, positions=rcb.positions + delta * tau[:, None] * e, interpolation="linear").data
    # offsets of 6 mm and 4.5 cm at the block end; bound: truncation + range curvature k c^2 / 2R. At zero
    # offset the two differ only by the compiled kernel's float32 partial sums (about -130 dB, docs/backprojection.md)
    limit = -120.0 if delta == 0 else max(20 * np.log10(2 * mom.max_error(delta)) , -100.0)
    assert _err_db(img, ref) < limit


def test_many_offsets_in_one_call_equal_single_calls(block):
    geo, rcb, grid = block
    tau = np.arange(1.0, rcb.n_pulses + 1)
    mom = offset_moments(rcb, grid, rcb.positions, geo.along_track, tau, 6)
    d = np.linspace(-3e-5, 3e-5, 7)
    imgs = mom.images(d)
    assert imgs.shape == (7, 32, 32)
    for k in (0, 3, 6):
        np.testing.assert_allclose(imgs[k], mom.image(d[k]), rtol=1e-12, atol=1e-12 * np.abs(imgs).max())


def test_offsets_beyond_the_expansion_are_refused(block):
    geo, rcb, grid = block
    tau = np.arange(1.0, rcb.n_pulses + 1)
    mom = offset_moments(rcb, grid, rcb.positions, geo.along_track, tau, 2)
    with pytest.raises(ConfigError, match="offsets"):
        mom.images([1e-3])


def test_bad_input_is_named(block):
    geo, rcb, grid = block
    tau = np.arange(1.0, rcb.n_pulses + 1)
    with pytest.raises(InputDataError, match="lever"):
        offset_moments(rcb, grid, rcb.positions, geo.along_track, tau[:-1], 2)
    with pytest.raises(InputDataError, match="direction"):
        offset_moments(rcb, grid, rcb.positions, np.zeros(3), tau, 2)
    with pytest.raises(ConfigError, match="order"):
        offset_moments(rcb, grid, rcb.positions, geo.along_track, tau, -1)
    with pytest.raises(InputDataError, match="positions"):
        offset_moments(rcb, grid, rcb.positions[:-1], geo.along_track, tau, 2)
