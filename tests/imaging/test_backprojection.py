"""Back-projection: point-target response vs theory, compiled vs float64 numpy reference, inputs.

Geometry (all tests): X band (9.75 GHz), B = 150 MHz (c/2B ~ 1 m), complex sampling fs = 1.25 B,
straight level track flying north at 50 m/s, 1000 m altitude, PRF 400 Hz, target 1800 m east on the
ground. No antenna pattern (``simulate_echoes(pattern=False)``, and the analytic model has none), so
the azimuth response is that of a uniformly weighted aperture of P pulses, length L = P V / PRF.
"""

from __future__ import annotations

from dataclasses import replace

import numba
import numpy as np
import pytest
from helpers import straight_pulse_track

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import (INTERPOLATIONS, PHASE_F32_MAX_ERROR, PHASE_POLY_MAX_ERROR, backproject,
                                           backproject_numpy, backproject_points, plane_of)
from sarnav.signal.data import PulseData
from sarnav.imaging.grid import GroundGrid, PlaneGrid, PointGrid, SlantGrid
from sarnav.signal.metrics import index_to_coordinate, peak_location, point_target_metrics
from sarnav.imaging.range_compression import range_compress
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.scene import point_targets
from sarnav.units import C

FC, BW, FS = 9.75e9, 150e6, 1.25 * 150e6
LAM = C / FC
SPEED, PRF, ALT, EAST = 50.0, 400.0, 1000.0, 1800.0
R0 = float(np.hypot(ALT, EAST))
RANGE_IRW = 0.886 * C / (2 * BW)                    # thesis (2.2) with the sinc -3 dB factor
PSLR_RECT, ISLR_RECT_10 = -13.26, -10.11            # anchors-sar §3.1 (ISLR: 10 sidelobes, isce3)


def track(n_pulses: int):
    return straight_pulse_track(n_pulses, PRF, SPEED, ALT)


def radar(near: float, n: int = 320) -> RadarParams:
    return RadarParams(carrier_frequency=FC, bandwidth=BW, pulse_length=0.5e-6, sample_rate=FS, prf=PRF,
                       near_range=near, n_range_samples=n, antenna_length=1.0)


def simulated(target, n_pulses: int) -> PulseData:
    """Echoes of one unit target from the colleague's simulator, range compressed (no window)."""
    times, pos = track(n_pulses)
    raw = simulate_echoes(radar(R0 - 120.0), pos, times, point_targets(np.asarray(target)), pattern=False)
    return range_compress(raw, window="none")


def analytic(target, n_pulses: int, n: int = 320) -> PulseData:
    """Ideal range-compressed samples sinc(2B(r - R)/c) exp(-j 4 pi R / lambda) (docs/conventions.md)."""
    times, pos = track(n_pulses)
    r_t = np.linalg.norm(np.asarray(target) - pos, axis=1)
    ranges = R0 - 120.0 + np.arange(n) * C / (2 * FS)
    data = np.sinc(2 * BW / C * (ranges[None, :] - r_t[:, None])) * np.exp(-4j * np.pi * r_t[:, None] / LAM)
    return PulseData(data, ranges, times, pos, None, compressed=True, wavelength=LAM)


def error_db(a, b) -> float:
    return float(10 * np.log10(np.sum(np.abs(a - b) ** 2) / np.sum(np.abs(b) ** 2) + 1e-300))   # identical: -3000


@pytest.mark.parametrize("source", ["simulated", "analytic"])
def test_point_target_irf_matches_uniform_aperture_theory(source):
    n_pulses = 256
    target = np.array([0.1, EAST + 0.03, 0.0])       # off the pixel lattice on both axes
    rc = simulated(target, n_pulses) if source == "simulated" else analytic(target, n_pulses)
    aperture = n_pulses * SPEED / PRF                # L = P * spacing (uniform P-point aperture)
    az_irw = 0.886 * LAM * R0 / (2 * aperture)       # ~0.88 m
    grid = SlantGrid(origin=[0, 0, -ALT], direction=[1, 0, 0], look_point=target,
                     along_track=np.arange(-64, 64) * 0.2 + 0.05, slant_range=R0 + np.arange(-64, 64) * 0.2 + 0.07)
    img = backproject(rc, grid, interpolation="upsample", upsample=8)
    m = point_target_metrics(img, half_width=56)
    assert m["x"]["irw_m"] == pytest.approx(RANGE_IRW, rel=0.03)
    assert m["y"]["irw_m"] == pytest.approx(az_irw, rel=0.05)
    for axis in ("x", "y"):
        assert abs(m[axis]["pslr_db"] - PSLR_RECT) < 0.3, (axis, m[axis])
        assert abs(m[axis]["islr_db"] - ISLR_RECT_10) < 0.5, (axis, m[axis])
    # slant grid: along-track of closest approach = target north, column = range of closest approach
    y, x = m["peak_position"]
    assert abs(y - target[0]) < az_irw / 20
    assert abs(x - np.linalg.norm(target - [target[0], 0, -ALT])) < RANGE_IRW / 20
    # coherent gain: a unit target sums to P at its own position (matched filter normalised to 1)
    assert m["peak_amplitude"] == pytest.approx(n_pulses, rel=0.02)


def test_ground_grid_peak_at_target():
    target = np.array([-0.37, EAST + 0.21, 0.0])
    rc = simulated(target, 256)
    grid = GroundGrid.centered(0.0, EAST, 0.2, (96, 96))
    # low-order range interpolation at fs = 1.25 B biases the peak (docs/backprojection.md): upsample
    img = backproject(rc, grid, interpolation="upsample", upsample=8)
    iy, ix = peak_location(img)
    ground_cell = RANGE_IRW * R0 / EAST              # slant resolution projected on the ground
    assert abs(index_to_coordinate(img.y, iy) - target[0]) < 0.886 * LAM * R0 / (2 * 32.0) / 20
    assert abs(index_to_coordinate(img.x, ix) - target[1]) < ground_cell / 20
    assert img.y_name == "north" and img.x_name == "east" and img.metadata["algorithm"] == "bpa"


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_compiled_equals_float64_numpy_reference_random_scene(interpolation):
    rng = np.random.default_rng(np.random.SeedSequence(20261122))
    n_p, n_r = 64, 200
    times, pos = track(n_p)
    pos += rng.normal(0.0, 2.0, pos.shape)            # irregular (non-straight) trajectory
    ranges = R0 - 60.0 + np.arange(n_r) * C / (2 * FS)
    data = rng.standard_normal((n_p, n_r)) + 1j * rng.standard_normal((n_p, n_r))
    rc = PulseData(data, ranges, times, pos, None, compressed=True, wavelength=LAM)
    pts = np.empty((40, 50, 3))
    pts[..., 0] = rng.uniform(-60, 60, (40, 50))
    pts[..., 1] = EAST + rng.uniform(-80, 80, (40, 50))   # some pixels fall outside the range window
    pts[..., 2] = rng.uniform(-30, 30, (40, 50))
    a = backproject(rc, pts, interpolation=interpolation).data
    b = backproject_numpy(rc, pts, interpolation=interpolation).data
    assert a.shape == (40, 50)
    # task goal -50 dB; float32 sample storage alone gives ~-140 dB, so a drop below -100 dB is a bug
    assert error_db(a, b) < -100.0
    # block size and thread count are only a work split: bit-identical results
    np.testing.assert_array_equal(a, backproject(rc, pts, interpolation=interpolation, block=37).data)
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        single = backproject(rc, pts, interpolation=interpolation).data
    finally:
        numba.set_num_threads(threads)
    np.testing.assert_array_equal(a, single)


def test_phase_exact_at_spaceborne_range():
    """Float64 geometry: at 800 km (2R/lambda ~ 5e7 cycles) the phase still matches numpy's exp."""
    rng = np.random.default_rng(np.random.SeedSequence(7))
    n_p = 32
    pos = np.zeros((n_p, 3))
    pos[:, 0] = np.arange(n_p) * 7.0
    pos[:, 2] = -800e3
    ranges = 800e3 - 50.0 + np.arange(256) * 0.5
    data = rng.standard_normal((n_p, 256)) + 1j * rng.standard_normal((n_p, 256))
    rc = PulseData(data, ranges, np.arange(n_p) / PRF, pos, None, compressed=True, wavelength=LAM)
    pts = np.stack([rng.uniform(0, 200, 500), rng.uniform(-100, 100, 500), np.zeros(500)], axis=1)
    a = backproject_points(rc, pts)
    b = backproject_numpy(rc, pts[None]).data[0]
    assert error_db(a, b) < -100.0
    grid = GroundGrid.centered(100.0, 0.0, 0.5, (24, 20))            # the plane kernel at 800 km
    assert error_db(backproject(rc, grid).data, backproject_numpy(rc, grid).data) < -100.0
    assert PHASE_POLY_MAX_ERROR < 1e-9
    # the kernels' float32 phase factor: its own float32 rounding (~6e-8 per part) and that of f, nothing more
    assert 5e-8 < PHASE_F32_MAX_ERROR < 3e-7


def _irregular_track_pulses(n_p=48, n_r=200, seed=5):
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    times, pos = track(n_p)
    pos += rng.normal(0.0, 2.0, pos.shape)
    ranges = R0 - 60.0 + np.arange(n_r) * C / (2 * FS)
    data = rng.standard_normal((n_p, n_r)) + 1j * rng.standard_normal((n_p, n_r))
    return PulseData(data, ranges, times, pos, None, compressed=True, wavelength=LAM)


@pytest.mark.parametrize("interpolation", ["nearest", "linear", "cubic", "lagrange"])
def test_plane_kernel_equals_the_points_kernel_and_the_numpy_reference(interpolation):
    """Ground, slant and tilted planes go through the row-recurrence kernel; as points they go through the general
    kernel: both agree with each other and with float64 numpy, and neither depends on the block size or threads
    beyond the float32 accumulation's last bits (a freshly compiled Lagrange row kernel at block 7 differed from
    block 512 by 1.4e-6 relative in some pixels, the same kernel loaded from numba's cache not at all; seen on
    .ci/run's fresh clone, 2026-12-04)."""
    rc = _irregular_track_pulses()
    tilt = np.array([0.0, 0.8, 0.6])
    grids = [GroundGrid.centered(0.0, EAST, 0.3, (30, 41), down=-2.0),
             SlantGrid([0, 0, -ALT], [1, 0, 0], [0, EAST, 0], np.arange(-15, 15) * 0.4, R0 - 20 + np.arange(37) * 0.35),
             PlaneGrid([0.0, EAST, 0.0], [1.0, 0.0, 0.0], tilt, np.arange(-12, 13) * 0.5, np.arange(-20, 19) * 0.3)]
    for grid in grids:
        assert plane_of(grid) is not None
        a = backproject(rc, grid, interpolation=interpolation).data
        b = backproject(rc, PointGrid(grid.points()), interpolation=interpolation).data
        ref = backproject_numpy(rc, grid, interpolation=interpolation).data
        assert error_db(a, ref) < -100.0 and error_db(b, ref) < -100.0
        assert error_db(a, b) < -120.0
        last_bits = 4e-6 * np.abs(a).max()  # float32 accumulation (docstring)
        np.testing.assert_allclose(a, backproject(rc, grid, interpolation=interpolation, block=7).data, rtol=0,
                                   atol=last_bits)
        threads = numba.get_num_threads()
        try:
            numba.set_num_threads(1)
            np.testing.assert_allclose(a, backproject(rc, grid, interpolation=interpolation).data, rtol=0,
                                       atol=last_bits)
        finally:
            numba.set_num_threads(threads)


def test_grid_axis_off_its_progression_uses_the_points_kernel():
    """An axis that passes the grid's uniformity check (1e-9 relative) but deviates from its arithmetic progression
    by more than 1e-9 m is not treated as a plane (the recurrence would put its pixels in the wrong place)."""
    rc = _irregular_track_pulses()
    east = EAST + np.arange(40) * 0.3
    east[20:] += 2e-10 * np.arange(20)             # within the grid's check, off the progression by up to 4e-9 m
    grid = GroundGrid(np.arange(-10, 10) * 0.3, east)
    assert plane_of(grid) is None
    assert error_db(backproject(rc, grid).data, backproject_numpy(rc, grid).data) < -100.0


def test_interpolation_error_vs_exact_band_limited_image_decreases_with_order():
    """Independent reference: every pulse evaluated analytically at each pixel's range (no sampling)."""
    target = np.array([0.0, EAST, 0.0])
    n_p = 64
    rc = analytic(target, n_p)
    grid = GroundGrid.centered(0.0, EAST, 0.23, (32, 32))
    pts = grid.points().reshape(-1, 3)
    r_t = np.linalg.norm(target - rc.positions, axis=1)
    exact = np.zeros(pts.shape[0], complex)
    for k in range(n_p):
        r = np.linalg.norm(pts - rc.positions[k], axis=1)
        exact += np.sinc(2 * BW / C * (r - r_t[k])) * np.exp(4j * np.pi * (r - r_t[k]) / LAM)
    err = {i: error_db(backproject(rc, grid, interpolation=i).data.ravel(), exact) for i in INTERPOLATIONS}
    assert err["nearest"] > err["linear"] > err["cubic"] > err["upsample"]
    assert err["upsample"] < -30.0


def test_positions_argument_overrides_rc_positions():
    target = np.array([0.0, EAST, 0.0])
    rc = analytic(target, 32)
    grid = GroundGrid.centered(0.0, EAST, 0.5, (8, 8))
    shifted = rc.positions + [1.0, 2.0, 3.0]
    a = backproject(rc, grid, positions=shifted).data
    b = backproject(rc.with_positions(shifted), grid).data
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, backproject(rc, grid).data)


def test_bad_inputs_name_the_argument():
    rc = analytic(np.array([0.0, EAST, 0.0]), 16)
    grid = GroundGrid.centered(0.0, EAST, 0.5, (4, 4))
    bad = rc.positions.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputDataError, match="^positions"):
        backproject(rc, grid, positions=bad)
    with pytest.raises(InputDataError, match="^positions.*shape"):
        backproject(rc, grid, positions=rc.positions[:-1])
    with pytest.raises(InputDataError, match="^rc.positions"):
        backproject(replace(rc, positions=bad), grid)
    with pytest.raises(InputDataError, match="^rc:.*range-compressed"):
        backproject(replace(rc, compressed=False), grid)
    with pytest.raises(InputDataError, match="^rc.data"):
        backproject(replace(rc, data=rc.data[0]), grid)
    with pytest.raises(InputDataError, match="^rc.slant_range"):
        backproject(replace(rc, slant_range=rc.slant_range[::-1]), grid)
    with pytest.raises(InputDataError, match="^grid"):
        backproject(rc, np.full((2, 2, 3), np.nan))
    with pytest.raises(InputDataError, match="^grid"):
        backproject(rc, np.zeros((2, 2, 2)))
    with pytest.raises(ConfigError, match="^interpolation"):
        backproject(rc, grid, interpolation="sinc")
    with pytest.raises(ConfigError, match="^upsample"):
        backproject(rc, grid, interpolation="upsample", upsample=1)
    with pytest.raises(ConfigError, match="^pulse_block"):
        backproject(rc, grid, pulse_block=0)
    with pytest.raises(ConfigError, match="^wavelength"):
        backproject(rc, grid, wavelength=-1.0)
    with pytest.raises(InputDataError, match="^grid.north"):
        GroundGrid(np.array([0.0, 1.0, 3.0]), np.arange(3.0))
    with pytest.raises(InputDataError, match="^grid.look_point"):
        SlantGrid([0, 0, 0], [1, 0, 0], [5, 0, 0], np.arange(3.0), np.arange(1.0, 4.0))


def test_grids_points_and_axes():
    g = GroundGrid.centered(10.0, 20.0, 0.5, (4, 6), down=-3.0)
    p = g.points()
    assert p.shape == (4, 6, 3) and p.dtype == np.float64
    np.testing.assert_allclose(p[..., 0].mean(), 10.0)
    np.testing.assert_allclose(p[..., 1].mean(), 20.0)
    np.testing.assert_array_equal(p[..., 2], -3.0)
    s = SlantGrid([0, 0, -1000], [2, 0, 0], [0, 1800, 0], np.arange(3.0), R0 + np.arange(4.0))
    q = s.points()
    # distance from the track line (north axis through the origin) = slant_range; north = along_track
    np.testing.assert_allclose(np.hypot(q[..., 1], q[..., 2] + 1000), np.broadcast_to(s.slant_range, (3, 4)))
    np.testing.assert_allclose(q[..., 0], np.broadcast_to(s.along_track[:, None], (3, 4)))
    # the plane contains the look point's direction: (0, 1800, 1000)/R0 is the in-plane normal
    np.testing.assert_allclose(s.normal_in_plane, np.array([0, EAST, ALT]) / R0)
    assert PointGrid(q).axes()[2] == "row_index"


def test_lagrange_kernel_reproduces_cubics_and_pulses_of_a_cubic_exactly():
    """The 4-point Lagrange kernel interpolates any cubic polynomial exactly (its defining property), and the
    compiled gather with it (mode "lagrange") returns a cubic pulse at any fractional sample to float32 rounding."""
    from sarnav.imaging.kernels import point_kernel

    rng = np.random.default_rng(np.random.SeedSequence(28))
    coef = rng.standard_normal(4)
    poly = lambda x: np.polyval(coef, x)  # noqa: E731
    x = rng.uniform(0.0, 1.0, 50)
    taps = np.arange(-1, 3)
    interp = (point_kernel("lagrange", x[:, None] - taps[None, :]) * poly(taps)[None, :]).sum(axis=1)
    np.testing.assert_allclose(interp, poly(x), rtol=0, atol=1e-12)
    assert point_kernel("lagrange", np.array([0.0, 1.0, 2.0])).tolist() == [1.0, 0.0, 0.0]
    # one pulse whose samples follow a cubic in the sample index; pixels on a line from the antenna
    n = 64
    ranges = 1000.0 + np.arange(n) * 0.5
    u = np.arange(n) / n
    data = (np.polyval(coef, u) + 1j * np.polyval(coef[::-1], u))[None, :]
    rc = PulseData(data, ranges, np.zeros(1), np.zeros((1, 3)), None, compressed=True, wavelength=LAM)
    r = 1000.0 + rng.uniform(2.0, 29.0, 40)
    pts = np.column_stack([r, np.zeros(40), np.zeros(40)])
    got = backproject_points(rc, pts, interpolation="lagrange") * np.exp(-4j * np.pi * r / LAM)
    uu = (r - 1000.0) / 0.5 / n
    want = np.polyval(coef, uu) + 1j * np.polyval(coef[::-1], uu)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * np.max(np.abs(want)))
