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


# --- the predicted precision of the least-squares shift (issue 10) -------------------------------------------------

def _correlated_noise(rng, shape, n):
    """(n, *shape) complex noise: white noise through a separable low-pass (a processed image's noise)."""
    from scipy import ndimage

    w = (rng.standard_normal((n,) + shape) + 1j * rng.standard_normal((n,) + shape)) / np.sqrt(2)
    return ndimage.uniform_filter(w.real, (0, 5, 2)) + 1j * ndimage.uniform_filter(w.imag, (0, 5, 2))


def _blob(shape, amp=30.0, centre=(20.0, 15.0), width=(6.0, 2.0)):
    i, j = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    return amp * np.exp(-((i - centre[0]) / width[0]) ** 2 - ((j - centre[1]) / width[1]) ** 2) * np.exp(0.3j * i)


def test_separable_noise_quadratic_form_equals_the_brute_force_covariance():
    from sarnav.imaging.registration import SeparableNoise

    rng = np.random.default_rng(3)
    noise = _correlated_noise(rng, (41, 30), 60)
    model = SeparableNoise.from_images(noise, 10)
    h = rng.standard_normal((11, 7)) + 1j * rng.standard_normal((11, 7))
    rows = np.arange(5, 16)
    # the model's own covariance, built entry by entry
    C = np.zeros((77, 77), complex)
    for a in range(77):
        for b in range(77):
            ia, ja, ib, jb = a // 7, a % 7, b // 7, b % 7
            d = jb - ja
            rho = model.rho[d] if d >= 0 else np.conj(model.rho[-d])
            C[a, b] = model.power * model.rows[rows[ia], rows[ib]] * rho
    hv = h.ravel()
    assert np.isclose(model.quadratic(h, rows), np.real(np.conj(hv) @ C @ hv), rtol=1e-10)


def test_predicted_shift_sigma_matches_a_monte_carlo_of_the_estimator():
    """Two noisy copies of one template, the noise the model describes: the least-squares shift's spread is the
    first-order prediction (within the Monte Carlo error of 200 trials, ~5 %, and the estimator's second order)."""
    from sarnav.imaging.registration import SeparableNoise, magnitude_shift_precision, refine_shift

    rng = np.random.default_rng(11)
    shape = (41, 31)
    S = _blob(shape)
    model = SeparableNoise.from_images(_correlated_noise(rng, (200, 80), 8), shape[1])
    noise = _correlated_noise(rng, shape, 400)
    rows = np.arange(shape[0])
    est, pred = [], []
    for k in range(200):
        c, y = S + noise[2 * k], S + noise[2 * k + 1]
        s = refine_shift(np.abs(c), np.abs(y), (0.0, 0.0))
        est.append(s)
        pred.append(magnitude_shift_precision(c, y, s, (model, rows), (model, rows)))
    ratio = np.std(est, axis=0) / np.sqrt(np.mean(np.square(pred), axis=0))
    assert np.all((ratio > 0.85) & (ratio < 1.15)), ratio


@pytest.mark.parametrize("amp, snr_db, low", [(6.0, 25.4, 0.85), (3.0, 19.4, 0.85)])
def test_predicted_shift_sigma_holds_near_the_noise_floor(amp, snr_db, low):
    """The same at 25 and 19 dB peak SNR, where the template's own noise adds gradient energy the shift cannot use
    (the curvature of the least-squares cost is the energy the two images share) and much of the chip is near the
    noise floor (Rician magnitudes). The former model (the noisy template's Σ g g, first-order noise everywhere)
    fails both here: rows std / rms σ 1.97 at 25 dB; rms of error / σ 3.5 at 19 dB (a σ too small on the images whose
    noise inflated the gradient). Checked per trial as well as on average. Over six seeds at 19 dB: std / rms σ
    0.86-0.99 with the mismatch test's gain corrected for its regressor's noise (``corrected_gain``); 0.69-0.79 before,
    when the attenuated gain left signal in the residual and kappa fired on half the pairs (docs/scenarios/rda-nav.md
    §6)."""
    from sarnav.imaging.registration import SeparableNoise, magnitude_shift_precision, refine_shift

    rng = np.random.default_rng(11)
    shape = (41, 31)
    S = _blob(shape, amp=amp)
    model = SeparableNoise.from_images(_correlated_noise(rng, (200, 80), 8), shape[1])
    assert 10 * np.log10(amp**2 / model.power) == pytest.approx(snr_db, abs=0.5)
    noise = _correlated_noise(rng, shape, 400)
    rows = np.arange(shape[0])
    est, pred = [], []
    for k in range(200):
        c, y = S + noise[2 * k], S + noise[2 * k + 1]
        s = refine_shift(np.abs(c), np.abs(y), (0.0, 0.0))
        est.append(s)
        pred.append(magnitude_shift_precision(c, y, s, (model, rows), (model, rows)))
    est, pred = np.array(est), np.array(pred)
    ratio = np.std(est, axis=0) / np.sqrt(np.mean(np.square(pred), axis=0))
    z_rms = np.sqrt(np.mean(np.square(est / pred), axis=0))
    assert np.all((ratio > low) & (ratio < 1.2)), ratio
    assert np.all((z_rms > max(low, 0.7)) & (z_rms < 1.2)), z_rms


def test_corrected_gain_removes_the_attenuation_of_a_noisy_regressor():
    """y = 2 x + 1 fitted on x seen through noise of variance v: least squares finds 2 lambda (lambda = 1 - v / var x,
    here 0.5), the corrected gain 2; a regressor that is all noise falls back to least squares."""
    from sarnav.imaging.registration import corrected_gain

    rng = np.random.default_rng(7)
    x = rng.standard_normal(200_000)
    y = 2.0 * x + 1.0 + 0.3 * rng.standard_normal(x.size)
    seen = x + rng.standard_normal(x.size)                       # v = 1 = var x: lambda = 0.5
    a_ls = np.polyfit(seen, y, 1)[0]
    assert a_ls == pytest.approx(1.0, abs=0.02)
    a, b = corrected_gain(seen, y, 1.0)
    assert a == pytest.approx(2.0, abs=0.03) and b == pytest.approx(1.0, abs=0.03)
    assert corrected_gain(seen, y, np.full(x.size, 1.0))[0] == pytest.approx(a, rel=1e-12)
    assert corrected_gain(seen, y, 10.0)[0] == pytest.approx(a_ls, rel=1e-9)  # no spread above the noise
    from sarnav.errors import InputDataError

    for bad in (np.ones(3), -1.0, np.nan):
        with pytest.raises(InputDataError, match="^noise_variance"):
            corrected_gain(seen, y, bad)


@pytest.mark.parametrize("amp, fired_before", [(3.0, 0.3), (2.0, 0.9)])
def test_mismatch_test_does_not_take_the_noise_floor_for_a_mismatch(amp, fired_before):
    """Two noisy copies of one template, 19 and 16 dB peak SNR, nothing else different: kappa stays 1 in at least
    90 % of the pairs with the gain fitted by ``corrected_gain``. With the least-squares gain (attenuated by the
    template's noise to ~0.8 and ~0.6) it fired in ~50 % and ~98 % (the check that this test can fail)."""
    from sarnav.imaging.registration import corrected_gain, mismatch_ratio, rician_weight

    rng = np.random.default_rng(5)
    S = _blob((41, 31), amp=amp)
    N = float(np.mean(np.abs(_correlated_noise(rng, (50, 80), 8)) ** 2))
    noise = _correlated_noise(rng, S.shape, 400)
    fired_ls, fired = [], []
    for k in range(200):
        c, y = np.abs(S + noise[2 * k]), np.abs(S + noise[2 * k + 1])
        a, b = np.polyfit(c.ravel(), y.ravel(), 1)
        fired_ls.append(mismatch_ratio(y - a * c - b, c, a, N, N) > 1.0)
        a, b = corrected_gain(c, y, 0.5 * N * rician_weight(S + noise[2 * k], N))
        fired.append(mismatch_ratio(y - a * c - b, c, a, N, N) > 1.0)
    assert np.mean(fired) <= 0.1 and np.mean(fired_ls) >= fired_before, (np.mean(fired), np.mean(fired_ls))


@pytest.mark.xfail(strict=True, reason="known: refine_shift's Gauss-Newton weights (np.gradient) are not the "
                   "prediction's (the spline derivative): sigma 1.34-1.37 x too small on near-Nyquist speckle")
@pytest.mark.parametrize("coherence", [1.0, 0.6])
def test_predicted_shift_sigma_holds_on_speckle_sampled_near_nyquist(coherence):
    """Speckle 20 dB over the noise, correlated over 2 columns (a range axis sampled near Nyquist), the second image's
    speckle partly decorrelated (another pass): 150 trials. Known miss, kept so a fix is noticed (docs/scenarios/
    rda-nav.md §6): the shift is the fixed point of refine_shift's Gauss-Newton, whose weights are np.gradient of the
    template; the prediction uses the spline derivative. Measured (2026-12-05): with the estimator's own weights in the
    prediction this passes (0.85-0.98) but the rda-nav SNR -20 dB range sigma becomes 0.82 x conservative (NIS 0.91);
    with the spline derivative as Jacobian (the exact least-squares estimator) the spread falls 25 % here but grows
    45 % on a smooth template at 25 dB, and the SNR -20 dB range error grows from 17.8 to 21.5 mm."""
    from sarnav.imaging.registration import SeparableNoise, magnitude_shift_precision, refine_shift

    rng = np.random.default_rng(5)
    shape = (41, 31)
    model = SeparableNoise.from_images(_correlated_noise(rng, (100, 80), 8), shape[1])
    rows = np.arange(shape[0])
    texture = 10.0 * _correlated_noise(rng, shape, 1)[0]
    est, pred = [], []
    for _ in range(150):
        n = _correlated_noise(rng, shape, 2)
        fresh = 10.0 * _correlated_noise(rng, shape, 1)[0]
        c, y = texture + n[0], coherence * texture + np.sqrt(1 - coherence**2) * fresh + n[1]
        s = refine_shift(np.abs(c), np.abs(y), (0.0, 0.0))
        est.append(s)
        pred.append(magnitude_shift_precision(c, y, s, (model, rows), (model, rows)))
    ratio = np.std(est, axis=0) / np.sqrt(np.mean(np.square(pred), axis=0))
    assert np.all((ratio > 0.8) & (ratio < 1.15)), ratio


@pytest.mark.parametrize("amplitude", [0.0, 0.5, 1.0, 2.0, 4.0])
def test_rician_weight_is_the_variance_of_a_noisy_magnitude(amplitude):
    """Against a Monte Carlo of |A + n| (n complex Gaussian of power N): its variance over N/2. The pixel handed to
    the function has the mean power A^2 + N, from which it estimates A."""
    from sarnav.imaging.registration import rician_weight

    rng = np.random.default_rng(int(10 * amplitude))
    N = 2.0
    n = np.sqrt(N / 2) * (rng.standard_normal(400_000) + 1j * rng.standard_normal(400_000))
    expected = np.var(np.abs(amplitude + n)) / (N / 2)
    w = rician_weight(np.array([np.sqrt(amplitude**2 + N)]), N)[0]
    assert w == pytest.approx(expected, rel=0.01)
    assert 2 - np.pi / 2 - 1e-12 <= w <= 1.0


def test_mismatch_ratio_is_one_for_noise_and_large_for_a_decorrelated_pair():
    from sarnav.imaging.registration import SeparableNoise, magnitude_shift_precision, mismatch_ratio

    rng = np.random.default_rng(5)
    shape = (41, 31)
    texture = 10.0 * _correlated_noise(rng, shape, 1)[0]  # bright speckle, 20 dB above the noise
    n = _correlated_noise(rng, shape, 2)
    p0 = float(np.mean(np.abs(n) ** 2))
    c, y = texture + n[0], texture + n[1]
    assert mismatch_ratio(np.abs(y) - np.abs(c), np.abs(c), 1.0, p0, p0) == 1.0
    fresh = 10.0 * _correlated_noise(rng, shape, 1)[0]
    y2 = 0.7 * texture + np.sqrt(1 - 0.49) * fresh + n[1]  # coherence 0.7 between the passes
    assert mismatch_ratio(np.abs(y2) - np.abs(c), np.abs(c), 1.0, p0, p0) > 10.0
    model = SeparableNoise.from_images(_correlated_noise(rng, (100, 80), 4), shape[1])
    model = type(model)(power=p0, rows=model.rows, rho=model.rho)
    rows = np.arange(shape[0])
    plain = magnitude_shift_precision(c, y2, (0.0, 0.0), (model, rows), (model, rows), mismatch=False)
    with_mm = magnitude_shift_precision(c, y2, (0.0, 0.0), (model, rows), (model, rows))
    assert np.all(np.array(with_mm) > 2.0 * np.array(plain))


def test_separable_noise_from_images_equals_the_direct_sums():
    """Row covariance and range correlation (one matrix product and one FFT) against the sums of their definition."""
    from sarnav.imaging.registration import SeparableNoise

    n = _correlated_noise(np.random.default_rng(8), (23, 40), 5)
    model = SeparableNoise.from_images(n, 12)
    T, P, N = n.shape
    p0 = np.mean(np.abs(n) ** 2)
    rows = np.array([[np.sum(n[:, i, :] * np.conj(n[:, k, :])) for k in range(P)] for i in range(P)]) / (T * N * p0)
    rho = np.array([np.mean(n[:, :, :N - d] * np.conj(n[:, :, d:])) for d in range(12)]) / p0
    np.testing.assert_allclose(model.rows, rows, rtol=0, atol=1e-13)
    np.testing.assert_allclose(model.rho, rho, rtol=0, atol=1e-13)
    assert model.power == pytest.approx(p0, rel=1e-15)


# --- clutter whose phase turned between the passes (relief from another pass, issue 29) ----------------------------

def _turned_pair(rng, q, amp=10.0, snr_db=20.0, oversample=(8, 2), shape=(256, 128), chip=(slice(100, 151),
                                                                                             slice(30, 85))):
    """(reference chip, image chip, noise chips, phase turn): Hamming-band speckle (``oversample`` rows x columns per
    resolution cell), a point of peak ``amp`` x the clutter's rms at the chip's centre, receiver noise ``snr_db``
    below the clutter; the image's scatterers turned by exp(j 2 pi q x / rho_rows) (a slope seen from another pass:
    a fraction q of the looks not shared). The turn relative to the point's row, as ``reference_in_flight`` gives it."""
    def band(n, over):
        f = np.fft.fftfreq(n)
        return np.where(np.abs(f) < 0.5 / over, 0.54 + 0.46 * np.cos(2 * np.pi * f * over), 0.0)

    P = band(shape[0], oversample[0])[:, None] * band(shape[1], oversample[1])[None, :]
    P /= np.sqrt(np.mean(P**2))
    dk = q / oversample[0]
    x = np.arange(shape[0])[:, None]

    def image(w):
        return np.fft.ifft2(np.fft.fft2(w) * P)

    def white():
        return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)

    i0, j0 = (chip[0].start + chip[0].stop) // 2, (chip[1].start + chip[1].stop) // 2
    point = np.zeros(shape)
    point[i0, j0] = 1.0
    point = image(point)
    point *= amp / np.abs(point).max()
    w, gain = white(), 10 ** (snr_db / 20)
    ref = gain * (image(w) + point) + image(white())
    img = gain * (image(w * np.exp(2j * np.pi * dk * x)) + point * np.exp(2j * np.pi * dk * i0)) + image(white())
    rows = np.arange(chip[0].start, chip[0].stop)
    turn = np.repeat((2 * np.pi * dk * (rows - i0))[:, None], chip[1].stop - chip[1].start, axis=1)
    return ref[chip], img[chip], turn, lambda: image(white())[chip[0], chip[1].start - 10:chip[1].stop + 15]


def test_a_phase_turn_of_zero_changes_nothing_and_a_turn_widens_sigma():
    from sarnav.imaging.registration import SeparableNoise, magnitude_shift_precision, refine_shift

    rng = np.random.default_rng(5)
    ref, img, turn, noise = _turned_pair(rng, 0.3)
    model = SeparableNoise.from_images(np.array([noise() for _ in range(20)]), 60)
    rows = np.arange(ref.shape[0])
    s = refine_shift(np.abs(ref), np.abs(img), (0.0, 0.0))
    plain = magnitude_shift_precision(ref, img, s, (model, rows), (model, rows))
    assert magnitude_shift_precision(ref, img, s, (model, rows), (model, rows), phase_turn=0 * turn) == plain
    turned = magnitude_shift_precision(ref, img, s, (model, rows), (model, rows), phase_turn=turn)
    assert turned[0] > 1.2 * plain[0], (turned, plain)
    with pytest.raises(InputDataError, match="phase_turn"):
        magnitude_shift_precision(ref, img, s, (model, rows), (model, rows), phase_turn=turn[:-1])


@pytest.mark.slow
@pytest.mark.parametrize("q", [0.2, 0.4])
def test_predicted_shift_sigma_holds_for_a_point_in_clutter_turned_between_the_passes(q):
    """A point 20 dB over speckle whose phase turns by 2 pi q per azimuth cell between the images (200 pairs): the
    point's magnitude peak moves with its interference with the turned clutter. Kappa scaling of the noise predicts
    the along-track (row) sigma 1.8 x too small (measured 1.87 / 1.79 at q = 0.2 / 0.4, range 1.23 / 1.39); with the
    turn modelled (``phase_turn``) 0.81 / 0.90, range 0.88 / 1.32. (With a point only 10 dB over the clutter it is
    conservative, 0.3-0.5, on these 6-cell chips; on the rda-nav terrain scenario's chips, 1.6 azimuth cells long, it
    gives 0.97 / 0.96 over 28 apertures: docs/scenarios/rda-nav.md §6.)"""
    from sarnav.imaging.registration import SeparableNoise, magnitude_shift_precision, refine_shift

    rng = np.random.default_rng(1)
    _, _, _, noise = _turned_pair(rng, q)
    model = SeparableNoise.from_images(np.array([noise() for _ in range(30)]), 60)
    est, plain, turned = [], [], []
    for _ in range(200):
        ref, img, turn, _ = _turned_pair(rng, q)
        rows = np.arange(ref.shape[0])
        s = refine_shift(np.abs(ref), np.abs(img), (0.0, 0.0))
        est.append(s)
        plain.append(magnitude_shift_precision(ref, img, s, (model, rows), (model, rows)))
        turned.append(magnitude_shift_precision(ref, img, s, (model, rows), (model, rows), phase_turn=turn))
    ratio = [np.std(est, axis=0) / np.sqrt(np.mean(np.square(p), axis=0)) for p in (plain, turned)]
    assert ratio[0][0] > 1.4, ratio
    assert np.all((ratio[1] > 0.7) & (ratio[1] < 1.4)), ratio
