"""Registration recovers known sub-pixel shifts made independently by a Fourier shift."""

import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import SarImage
from sarnav.imaging.registration import register, register_axis

N, CROP = 160, 16


def _speckle(seed, oversample=2.0):
    """Band-limited complex speckle: white complex Gaussian low-passed to 1/oversample of the band."""
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    z = rng.standard_normal((N, N)) + 1j * rng.standard_normal((N, N))
    f = np.fft.fftfreq(N)
    keep = (np.abs(f)[:, None] < 0.5 / oversample) & (np.abs(f)[None, :] < 0.5 / oversample)
    return np.fft.ifft2(np.fft.fft2(z) * keep)


def _fourier_shift(img, dy, dx):
    """img(m - dy, n - dx) by the shift theorem (independent of the estimator)."""
    f = np.fft.fftfreq(N)
    return np.fft.ifft2(np.fft.fft2(img) * np.exp(-2j * np.pi * (f[:, None] * dy + f[None, :] * dx)))


def _crop(a):
    return a[CROP:N - CROP, CROP:N - CROP]  # non-periodic chips: no wrap-around help


@pytest.mark.parametrize("use_magnitude", [True, False])
def test_subpixel_shift_of_speckle_better_than_005_pixel(use_magnitude):
    rng = np.random.default_rng(np.random.SeedSequence(2024))
    for trial in range(6):
        dy, dx = rng.uniform(-6.0, 6.0, 2)
        ref = _speckle(100 + trial)
        img = _fourier_shift(ref, dy, dx)
        r = register(_crop(ref), _crop(img), use_magnitude=use_magnitude, subpixel="dft", upsample=100)
        assert r.shift_pixels[0] == pytest.approx(dy, abs=0.05)
        assert r.shift_pixels[1] == pytest.approx(dx, abs=0.05)
        assert 0.8 < r.peak <= 1.0 + 1e-9


def test_parabola_is_coarser_than_dft_on_magnitude_images():
    # measured comparison (report): the 3-point parabola is biased for the sharp speckle peak
    rng = np.random.default_rng(np.random.SeedSequence(7))
    err_dft, err_par = [], []
    for trial in range(6):
        dy, dx = rng.uniform(-3.0, 3.0, 2)
        ref = _speckle(200 + trial)
        img = _fourier_shift(ref, dy, dx)
        for method, err in (("dft", err_dft), ("parabola", err_par)):
            r = register(_crop(ref), _crop(img), subpixel=method)
            err.append(np.hypot(r.shift_pixels[0] - dy, r.shift_pixels[1] - dx))
    assert max(err_dft) < 0.05
    assert np.mean(err_dft) < np.mean(err_par)


def test_integer_shift_sign_and_metres_from_sar_image():
    ref = _speckle(5)
    img = np.roll(ref, (3, -4), axis=(0, 1))  # image(m, n) = ref(m - 3, n + 4)
    y = 10.0 + 0.25 * np.arange(N - 2 * CROP)
    x = 2000.0 + 0.15 * np.arange(N - 2 * CROP)
    r = register(SarImage(_crop(ref), y, x), SarImage(_crop(img), y, x))
    assert r.shift_pixels == pytest.approx((3.0, -4.0), abs=0.02)
    assert r.shift_m == pytest.approx((3 * 0.25, -4 * 0.15), abs=0.02 * 0.25)
    ky, kx = np.unravel_index(np.argmax(r.surface), r.surface.shape)
    assert (r.lags_y[ky], r.lags_x[kx]) == (3, -4)


@pytest.mark.parametrize("axis", [0, 1])
def test_single_axis_registration(axis):
    rng = np.random.default_rng(np.random.SeedSequence(99 + axis))
    for trial in range(4):
        d = rng.uniform(-4.0, 4.0)
        ref = _speckle(300 + trial)
        img = _fourier_shift(ref, d, 0.0) if axis == 0 else _fourier_shift(ref, 0.0, d)
        shift, peak = register_axis(_crop(ref), _crop(img), axis=axis)
        assert shift == pytest.approx(d, abs=0.05)
        assert 0.5 < peak <= 1.0 + 1e-9


def test_bad_input_named():
    a = np.ones((8, 8))
    with pytest.raises(InputDataError, match="image"):
        register(a, np.ones((8, 9)))
    with pytest.raises(ConfigError, match="subpixel"):
        register(a, a, subpixel="cubic")
    with pytest.raises(ConfigError, match="upsample"):
        register(a, a, upsample=0)
    with pytest.raises(InputDataError, match="reference"):
        register(np.ones(8), a)
    with pytest.raises(ConfigError, match="axis"):
        register_axis(a, a, axis=2)
