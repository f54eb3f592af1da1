"""The CPHD reference's chip taken through the DEM to the in-flight geometry
(``measurements.sar_product.reference_in_flight_geometry``, ``ImagingSettings.terrain_correction``).

Checked against an independent construction: a reference "image" whose every pixel holds a smooth complex field of
the ground point it sees from the reference pass (found by bisection on the range equation over the hills, not by the
code under test), read back along another pass: the chip must hold the field at the ground points the *in-flight*
lattice sees, to the accuracy of cubic interpolation, where the uncorrected chip differs by the terrain's parallax.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.measurements.sar_aperture import ImagingSettings
from sarnav.measurements.sar_product import reference_in_flight, reference_in_flight_geometry
from sarnav.radar.ground_scene import HillTerrain

PRF, SPEED, ALT, DX = 100.0, 10.0, 1000.0, 0.5


def _track(east: float, up: float, times) -> np.ndarray:
    """A northbound straight track at ``ALT + up``, ``east`` metres east of the origin (look right: east)."""
    return np.stack([SPEED * times, np.full(times.size, east), np.full(times.size, -(ALT + up))], axis=1)


def _ground(P, r, terrain: HillTerrain) -> np.ndarray:
    """The ground point east of P (northbound: the zero-Doppler plane is north = P_n) at slant range r on the hills,
    by 80 bisections of the range equation in east (independent of the code under test)."""
    lo, hi = np.zeros(np.shape(r)), np.asarray(r, dtype=np.float64).copy()
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        down = -terrain.height(P[..., 0], P[..., 1] + mid)
        f = mid**2 + (down - P[..., 2]) ** 2 - r * r
        lo, hi = np.where(f < 0, mid, lo), np.where(f < 0, hi, mid)
    e = 0.5 * (lo + hi)
    return np.stack([P[..., 0], P[..., 1] + e, -terrain.height(P[..., 0], P[..., 1] + e)], axis=-1)


def _field(q) -> np.ndarray:
    """A smooth complex field on the ground (wavelengths of 9-14 m: well sampled by the lattice)."""
    return (1.5 + np.sin(q[..., 0] / 2.0 + q[..., 1] / 3.0)) * np.exp(1j * (q[..., 0] / 1.7 + q[..., 1] / 1.5))


@pytest.fixture(scope="module")
def world():
    times = np.arange(100) / PRF
    hills = HillTerrain(np.array([[0.5, 1820.0], [-3.0, 1790.0]]), np.array([25.0, 40.0]), np.array([18.0, -12.0]))
    ref_track = _track(30.0, 20.0, times)  # the reference pass: 30 m aside, 20 m up (the terrain scenario's)
    x = 2000.0 + DX * np.arange(240)
    rows = np.arange(100)
    P = np.broadcast_to(ref_track[rows][:, None, :], (100, x.size, 3))
    image = SimpleNamespace(data=_field(_ground(P, np.broadcast_to(x, (100, x.size)), hills)), x=x, dx=DX,
                            shape=(100, x.size))
    return SimpleNamespace(times=times, hills=hills, ref_track=ref_track, image=image)


def _lattice_ground(w, track, rows, cols, target) -> np.ndarray:
    """The ground points (bisection) of the in-flight lattice: the chip's lattice moved to where the target falls
    from ``track`` (its time and range of closest approach there instead of from the reference pass)."""
    def approach(tr):
        d = np.linalg.norm(tr - target, axis=1)
        i = int(np.argmin(d))
        return w.times[0] + (target[0] - tr[0, 0]) / SPEED, float(np.hypot(*(target - tr[i])[1:]))
    (eta0, r0), (eta_a, r_a) = approach(w.ref_track), approach(track)
    shape = (rows.size, cols.size)
    eta = np.broadcast_to(w.times[0] + rows[:, None] / PRF + (eta_a - eta0), shape)
    r = np.broadcast_to(w.image.x[0] + cols[None, :] * DX + (r_a - r0), shape)
    P = np.stack([SPEED * eta, np.full(shape, track[0, 1]), np.full(shape, track[0, 2])], axis=-1)
    return _ground(P, r, w.hills)


def _expected(w, track, rows, cols, target):
    """The field at the ground points of the in-flight lattice."""
    return _field(_lattice_ground(w, track, rows, cols, target))


@pytest.mark.parametrize("east, up", [(0.0, 0.0), (3.0, -2.0)])
def test_the_chip_holds_the_reference_at_the_ground_points_of_the_in_flight_lattice(world, east, up):
    """Flight track on the reference pass's nominal line (0, 0) and a few metres off it (a navigation error): over two
    hills of 18 and -12 m the corrected chip is the field at the in-flight lattice's ground points within 1 % rms
    (measured 0.02 %: cubic interpolation of a field of 9-14 m wavelength on 0.1 x 0.5 m pixels), while the chip the
    reference pass saw differs by more than 10 % (measured 19 %: the parallax of 30 m aside and 20 m up over the
    hills)."""
    w = world
    target = np.array([0.5 * SPEED, 1800.0, -float(w.hills.height(0.5 * SPEED, 1800.0))])
    track = _track(east, up, w.times)
    r0 = float(np.linalg.norm(w.ref_track[50] - target))
    j0 = int(round((r0 - w.image.x[0]) / DX))
    rows, cols = np.arange(35, 66), np.arange(j0 - 40, j0 + 41)
    chip = reference_in_flight_geometry(w.image, rows, cols, target, w.times, PRF, track, w.ref_track, w.hills,
                                        "right")
    want = _expected(w, track, rows, cols, target)
    scale = np.sqrt(np.mean(np.abs(want) ** 2))
    err = np.sqrt(np.mean(np.abs(chip - want) ** 2)) / scale
    plain = np.sqrt(np.mean(np.abs(w.image.data[np.ix_(rows, cols)] - want) ** 2)) / scale
    assert err < 0.01, err
    assert plain > 0.1, plain


def test_flat_ground_seen_from_the_same_pass_is_the_chip_itself(world):
    """No hills and the flight on the reference track: the lattice is the reference's own and the chip comes back to
    interpolation rounding (the pixels are read at their own centres)."""
    w = world
    flat = HillTerrain(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    x = w.image.x
    P = np.broadcast_to(w.ref_track[:, None, :], (100, x.size, 3))
    image = SimpleNamespace(data=_field(_ground(P, np.broadcast_to(x, (100, x.size)), flat)), x=x, dx=DX,
                            shape=(100, x.size))
    target = np.array([0.5 * SPEED, 1800.0, 0.0])
    rows, cols = np.arange(35, 66), np.arange(100, 141)
    chip = reference_in_flight_geometry(image, rows, cols, target, w.times, PRF, w.ref_track, w.ref_track, flat,
                                        "right")
    assert np.max(np.abs(chip - image.data[np.ix_(rows, cols)])) < 1e-6


def test_a_chip_beyond_the_reference_image_is_refused(world):
    w = world
    target = np.array([0.5 * SPEED, 1800.0, -float(w.hills.height(0.5 * SPEED, 1800.0))])
    with pytest.raises(InputDataError, match="leaves the reference image"):
        reference_in_flight_geometry(w.image, np.arange(35, 66), np.arange(200, 300), target, w.times, PRF,
                                     _track(0.0, 0.0, w.times), w.ref_track, w.hills, "right")


def test_terrain_correction_is_a_boolean_setting():
    assert ImagingSettings().terrain_correction is True
    with pytest.raises(ConfigError, match="^terrain_correction"):
        ImagingSettings(terrain_correction="yes")


def test_a_range_axis_sampled_near_nyquist_is_read_band_limited(world):
    """Speckle-like range signal, a sum of 40 complex tones within 0.42 of the sampling rate (fs/B = 1.2, as the
    radar's range axis): the chip read through the DEM equals the signal at each pixel's reference range (computed by
    bisection and the parallel tracks' closest approach) within -40 dB (measured -43.4 dB); a cubic spline of the
    samples without the FFT upsampling first gives -18.2 dB (measured with WARP_UPSAMPLE = 1), so this fails then."""
    w = world
    rng = np.random.default_rng(4)
    f = rng.uniform(-0.42, 0.42, 40)
    a = rng.standard_normal(40) + 1j * rng.standard_normal(40)
    x = w.image.x

    def g(r):
        return np.sum(a * np.exp(2j * np.pi * f * ((np.asarray(r)[..., None] - x[0]) / DX)), axis=-1)

    image = SimpleNamespace(data=np.broadcast_to(g(x), (100, x.size)).copy(), x=x, dx=DX, shape=(100, x.size))
    target = np.array([0.5 * SPEED, 1800.0, -float(w.hills.height(0.5 * SPEED, 1800.0))])
    track = _track(2.0, 1.0, w.times)
    r0 = float(np.linalg.norm(w.ref_track[50] - target))
    j0 = int(round((r0 - x[0]) / DX))
    rows, cols = np.arange(35, 66), np.arange(j0 - 40, j0 + 41)
    chip = reference_in_flight_geometry(image, rows, cols, target, w.times, PRF, track, w.ref_track, w.hills, "right")
    # the ground points of the in-flight lattice (as _expected places it), then their range from the reference pass
    d_ref = np.linalg.norm(w.ref_track - target, axis=1).min()
    d_fl = np.linalg.norm(track - target, axis=1).min()
    eta = w.times[0] + rows[:, None] / PRF + 0.0 * cols[None, :]
    r = x[0] + cols[None, :] * DX + (d_fl - d_ref) + 0.0 * eta
    P = np.stack([SPEED * eta, np.full(eta.shape, track[0, 1]), np.full(eta.shape, track[0, 2])], axis=-1)
    q = _ground(P, r, w.hills)
    want = g(np.hypot(q[..., 1] - w.ref_track[0, 1], q[..., 2] - w.ref_track[0, 2]))
    err_db = 10 * np.log10(np.mean(np.abs(chip - want) ** 2) / np.mean(np.abs(want) ** 2))
    assert err_db < -40.0, err_db


def test_the_phase_turn_is_the_two_passes_phase_difference_at_the_lattice_ground_points(world):
    """``reference_in_flight(..., wavelength)``'s second value: (4 pi / lambda) (r_ref - r_flight) at each lattice
    pixel's ground point, relative to the centre pixel, against the bisection's ground points and the tracks' own
    perpendicular distances (straight northbound passes). Over the hills it turns by many cycles across the chip (the
    flat-Earth fringe and the slopes), so a wrong ground point or sign shows; within 0.05 rad (measured 0.026 at
    worst: mm of height from the DEM solver's fixed-point iterations, k_z ~ 7 rad/m)."""
    w = world
    lam = 0.0307
    target = np.array([0.5 * SPEED, 1800.0, -float(w.hills.height(0.5 * SPEED, 1800.0))])
    track = _track(3.0, -2.0, w.times)
    r0 = float(np.linalg.norm(w.ref_track[50] - target))
    j0 = int(round((r0 - w.image.x[0]) / DX))
    rows, cols = np.arange(35, 66), np.arange(j0 - 40, j0 + 41)
    chip, turn = reference_in_flight(w.image, rows, cols, target, w.times, PRF, track, w.ref_track, w.hills, "right",
                                     lam)
    np.testing.assert_array_equal(chip, reference_in_flight_geometry(w.image, rows, cols, target, w.times, PRF, track,
                                                                     w.ref_track, w.hills, "right"))
    assert reference_in_flight(w.image, rows, cols, target, w.times, PRF, track, w.ref_track, w.hills, "right")[1] is None
    # the bisection's ground points of the in-flight lattice and the passes' perpendicular distances to them
    q = _lattice_ground(w, track, rows, cols, target)
    dist = [np.hypot(q[..., 1] - tr[0, 1], q[..., 2] - tr[0, 2]) for tr in (w.ref_track, track)]
    want = 4 * np.pi / lam * (dist[0] - dist[1])
    want -= want[rows.size // 2, cols.size // 2]
    assert np.ptp(want) > 4 * np.pi
    np.testing.assert_allclose(turn, want, atol=0.05)
