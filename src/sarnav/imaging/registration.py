"""Image-to-image registration by FFT cross-correlation with a sub-pixel peak.

The correlation is the full linear 2-D cross-correlation of the paper's eq. (46)
(notes/seed-001 §2.8, Bourke 1996)::

    C(k, l) = sum_{m,n} X(m, n) conj(Y(m - k, n - l)),   X = image, Y = reference,

computed with zero-padded FFTs (size >= 2M-1 x 2N-1, so no wrap-around). A peak at (k, l) means
``image(m, n) ≈ reference(m - k, n - l)``: the image is the reference moved by +k rows and +l
columns. The paper gives no sub-pixel method (gap G6); two are offered:

* ``"dft"`` (default): matrix-multiply DFT of the cross-power spectrum on a grid refined ``upsample``
  times around the integer peak (Guizar-Sicairos, Thurman & Fienup, Opt. Lett. 33, 156 (2008)), in
  two stages (1/10 pixel over ±1.5 pixel, then 1/upsample over ±0.15 pixel); exact for band-limited
  images up to the grid step 1/upsample.
* ``"parabola"``: a three-point parabola through the peak along each axis (biased towards the
  nearest integer for sharp peaks; kept for comparison).

Magnitude images (the default, robust to the phase ramps a position error causes, gap G6) have
their mean removed before correlation, so the pedestal does not bias the peak towards zero lag.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft

from sarnav.errors import ConfigError, InputDataError

__all__ = ["Registration", "register", "register_axis", "cross_correlation", "refine_shift", "distinctness",
           "SeparableNoise", "magnitude_shift_precision", "corrected_gain"]


@dataclass
class Registration:
    """Result of :func:`register`.

    Attributes
    ----------
    shift_pixels : (rows, columns) shift of ``image`` relative to ``reference`` [pixels].
    shift_m : (along y, along x) shift in metres (pixel shift times the image spacing), or None when
        the inputs are plain arrays without ``spacing``.
    peak : normalised correlation coefficient at the peak, |C| / (||X|| ||Y||), in [0, 1].
    surface : correlation magnitude, zero lag at the centre (``lags_y``, ``lags_x`` label it).
    lags_y, lags_x : integer lags of the rows / columns of ``surface`` [pixels].
    """

    shift_pixels: tuple[float, float]
    shift_m: tuple[float, float] | None
    peak: float
    surface: np.ndarray
    lags_y: np.ndarray
    lags_x: np.ndarray


def _as_array(img, field):
    data = np.asarray(getattr(img, "data", img))
    if data.ndim != 2 or min(data.shape) < 2:
        raise InputDataError(field, f"must be a 2-D image of at least 2x2 pixels, got shape {data.shape}")
    if not np.all(np.isfinite(data)):
        raise InputDataError(field, "contains NaN or inf")
    return data


def _prepare(data, use_magnitude):
    if use_magnitude:
        a = np.abs(data).astype(np.float64)
        return a - a.mean()
    return data.astype(np.complex128)


def cross_correlation(reference, image, *, use_magnitude: bool = True):
    """Cross-power spectrum and linear cross-correlation of eq. (46).

    Returns
    -------
    spectrum : (Pm, Pn) complex, FFT(X) * conj(FFT(Y)) on the zero-padded grid.
    corr : (Pm, Pn) the correlation C(k, l) at lag (k mod Pm, l mod Pn) (complex, or real for
        magnitude images).
    norm : ||X|| ||Y|| (for the normalised coefficient).
    """
    y = _prepare(_as_array(reference, "reference"), use_magnitude)
    x = _prepare(_as_array(image, "image"), use_magnitude)
    if x.shape != y.shape:
        raise InputDataError("image", f"shape {x.shape} differs from the reference shape {y.shape}")
    m, n = x.shape
    shape = (sfft.next_fast_len(2 * m - 1), sfft.next_fast_len(2 * n - 1))
    spectrum = sfft.fftn(x, shape) * np.conj(sfft.fftn(y, shape))
    corr = sfft.ifftn(spectrum)
    if use_magnitude:
        corr = corr.real
    norm = float(np.sqrt(np.sum(np.abs(x) ** 2) * np.sum(np.abs(y) ** 2)))
    return spectrum, corr, norm


def _signed(idx, size):
    return idx - size if idx > size // 2 else idx


def _dft_patch(spectrum, cy, cx, offs):
    """Inverse DFT of ``spectrum`` at lags (cy + offs) x (cx + offs) (matrix-multiply DFT)."""
    pm, pn = spectrum.shape
    fy = sfft.fftfreq(pm) * pm  # signed integer frequencies
    fx = sfft.fftfreq(pn) * pn
    ey = np.exp(2j * np.pi * np.outer(cy + offs, fy) / pm)
    ex = np.exp(2j * np.pi * np.outer(fx, cx + offs) / pn)
    return (ey @ spectrum) @ ex / (pm * pn)


def _upsampled_peak(spectrum, k0, l0, upsample, use_magnitude):
    """Guizar-Sicairos matrix-DFT refinement of the correlation peak around integer lag (k0, l0).

    Two stages keep the matrices small: a 1/10-pixel grid over ±1.5 pixel, then a 1/``upsample``
    grid over ±1.5/10 pixel around the first-stage maximum (grid step 1/upsample in the end).
    """
    cy, cx = float(k0), float(l0)
    stages = [(min(10, upsample), 1.5)]
    if upsample > 10:
        stages.append((upsample, 1.5 / 10))
    for factor, half in stages:
        offs = np.arange(-round(half * factor), round(half * factor) + 1) / factor
        fine = _dft_patch(spectrum, cy, cx, offs)
        score = fine.real if use_magnitude else np.abs(fine)
        i, j = np.unravel_index(np.argmax(score), score.shape)
        if i in (0, len(offs) - 1) or j in (0, len(offs) - 1):
            raise InputDataError("image", "correlation peak not resolved by the sub-pixel search")
        cy, cx = cy + offs[i], cx + offs[j]
    return cy, cx, float(np.abs(fine[i, j]))


def _parabola_offset(cm, c0, cp):
    den = cm - 2.0 * c0 + cp
    return 0.0 if den == 0 else 0.5 * (cm - cp) / den


def register(reference, image, *, use_magnitude: bool = True, subpixel: str = "dft",
             upsample: int = 100, spacing: tuple[float, float] | None = None) -> Registration:
    """Shift of ``image`` relative to ``reference`` by 2-D cross-correlation (paper eq. 46).

    Parameters
    ----------
    reference, image : equal-shape 2-D arrays (complex or real) or ``SarImage``.
    use_magnitude : correlate mean-removed magnitudes (default) instead of complex pixels.
    subpixel : "dft" (upsampled DFT, default), "parabola" or "none".
    upsample : refinement factor of the "dft" search (grid step 1/upsample pixel), >= 1.
    spacing : (dy, dx) pixel spacing [m]; defaults to the reference ``SarImage`` spacing.

    Returns
    -------
    Registration
    """
    if subpixel not in ("dft", "parabola", "none"):
        raise ConfigError("subpixel", f"must be 'dft', 'parabola' or 'none', got {subpixel!r}")
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)) or upsample < 1:
        raise ConfigError("upsample", f"must be an integer >= 1, got {upsample!r}")
    if spacing is None and hasattr(reference, "dy"):
        spacing = (reference.dy, reference.dx)
        if hasattr(image, "dy") and not np.allclose((image.dy, image.dx), spacing, rtol=1e-9):
            raise InputDataError("image", f"pixel spacing {(image.dy, image.dx)} differs from the reference {spacing}")
    spectrum, corr, norm = cross_correlation(reference, image, use_magnitude=use_magnitude)
    pm, pn = corr.shape
    score = corr if use_magnitude else np.abs(corr)
    i0, j0 = np.unravel_index(np.argmax(score), score.shape)
    k0, l0 = _signed(int(i0), pm), _signed(int(j0), pn)
    peak_val = float(abs(corr[i0, j0]))
    if subpixel == "dft":
        ky, lx, peak_val = _upsampled_peak(spectrum, k0, l0, int(upsample), use_magnitude)
    elif subpixel == "parabola":
        ky = k0 + _parabola_offset(score[(i0 - 1) % pm, j0], score[i0, j0], score[(i0 + 1) % pm, j0])
        lx = l0 + _parabola_offset(score[i0, (j0 - 1) % pn], score[i0, j0], score[i0, (j0 + 1) % pn])
    else:
        ky, lx = float(k0), float(l0)
    surface = sfft.fftshift(np.abs(corr))
    lags_y = np.arange(pm) - pm // 2
    lags_x = np.arange(pn) - pn // 2
    shift_m = None if spacing is None else (float(ky) * float(spacing[0]), float(lx) * float(spacing[1]))
    return Registration(
        shift_pixels=(float(ky), float(lx)),
        shift_m=shift_m,
        peak=peak_val / norm if norm > 0 else 0.0,
        surface=surface,
        lags_y=lags_y,
        lags_x=lags_x,
    )


def register_axis(reference, image, axis: int = 0, *, use_magnitude: bool = True, upsample: int = 100,
                  circular: bool = False) -> tuple[float, float]:
    """Shift along one axis only: 1-D cross-correlations along ``axis``, summed over the other axis.

    ``C(k) = sum_n sum_m X(m, n) conj(Y(m - k, n))`` for ``axis=0`` (eq. 46 at l = 0, i.e. when the
    other axis is known to be aligned, as for the two looks of mapdrift), zero-padded, with the
    peak refined by a 1-D matrix DFT of the summed cross-power spectrum (1/10 sample over ±1, then
    1/``upsample`` over ±0.1). Much cheaper than :func:`register` for large images. ``circular=True``
    correlates circularly (no zero padding): right for images that are periodic by construction,
    e.g. the inverse FFTs of mapdrift's looks, whose responses may wrap around the array ends.

    Returns
    -------
    shift : shift of ``image`` relative to ``reference`` along ``axis`` [samples].
    peak : normalised correlation coefficient at the peak.
    """
    if axis not in (0, 1):
        raise ConfigError("axis", f"must be 0 or 1, got {axis!r}")
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)) or upsample < 1:
        raise ConfigError("upsample", f"must be an integer >= 1, got {upsample!r}")
    y = _prepare(_as_array(reference, "reference"), use_magnitude)
    x = _prepare(_as_array(image, "image"), use_magnitude)
    if x.shape != y.shape:
        raise InputDataError("image", f"shape {x.shape} differs from the reference shape {y.shape}")
    m = x.shape[axis]
    pm = m if circular else sfft.next_fast_len(2 * m - 1)
    spectrum = np.sum(sfft.fft(x, pm, axis=axis) * np.conj(sfft.fft(y, pm, axis=axis)), axis=1 - axis)
    corr = sfft.ifft(spectrum)
    score = corr.real if use_magnitude else np.abs(corr)
    i0 = int(np.argmax(score))
    k0 = _signed(i0, pm)
    f = sfft.fftfreq(pm) * pm
    centre, value = float(k0), abs(corr[i0])
    stages = [(min(10, upsample), 1.0)] + ([(upsample, 0.1)] if upsample > 10 else [])
    for factor, half in stages:  # 1/10 sample over +-1, then 1/upsample over +-0.1
        offs = np.arange(-round(half * factor), round(half * factor) + 1) / factor
        # elementwise product and sum (no BLAS call: small products suffer from BLAS thread start-up)
        fine = np.sum(np.exp(2j * np.pi * np.outer(centre + offs, f) / pm) * spectrum[None, :], axis=1) / pm
        fscore = fine.real if use_magnitude else np.abs(fine)
        j = int(np.argmax(fscore))
        centre, value = centre + offs[j], float(np.abs(fine[j]))
    norm = float(np.sqrt(np.sum(np.abs(x) ** 2) * np.sum(np.abs(y) ** 2)))
    return float(centre), (value / norm if norm > 0 else 0.0)


def _magnitudes(reference, image):
    c = np.abs(np.asarray(reference)).astype(np.float64)
    y = np.abs(np.asarray(image)).astype(np.float64)
    if c.shape != y.shape or c.ndim != 2 or min(c.shape) < 3:
        raise InputDataError("image", f"reference and image must be equal 2-D arrays of >= 3x3, got {c.shape}, {y.shape}")
    return c, y


def _spline_gradient(c: np.ndarray, shift, axis: int, eps: float = 1e-3) -> np.ndarray:
    """d/ds_axis of the cubic-spline shifted template ``ndimage.shift(c, s, order=3, mode="nearest")`` at ``shift``
    (central difference in s): the Jacobian of the least-squares shift estimator. ``np.gradient`` of the samples is
    not: on data sampled near Nyquist (range, fs/B ~ 1.2) a central difference of the samples underestimates the
    derivative and so the gradient energy."""
    from scipy import ndimage

    d = np.zeros(2)
    d[axis] = eps
    s = np.asarray(shift, dtype=np.float64)
    return (ndimage.shift(c, s + d, order=3, mode="nearest") - ndimage.shift(c, s - d, order=3, mode="nearest")) / (2 * eps)


def refine_shift(reference, image, shift, iterations: int = 8) -> tuple[float, float]:
    """Least-squares sub-pixel shift: Gauss-Newton on ``image = a * reference(shifted by s) + b`` started at ``shift``
    (e.g. the correlation peak of :func:`register`); the estimator whose precision :func:`shift_precision` predicts.
    Cubic-spline shifts, edges continued (``mode="nearest"``); steps are limited to 0.5 pixel per iteration."""
    from scipy import ndimage

    c, y = _magnitudes(reference, image)
    s = np.asarray(shift, dtype=np.float64).copy()
    for _ in range(int(iterations)):
        cs = ndimage.shift(c, s, order=3, mode="nearest")
        gy, gx = np.gradient(cs)
        A = np.column_stack([cs.ravel(), np.ones(cs.size)])
        (a, b), *_ = np.linalg.lstsq(A, y.ravel(), rcond=None)
        r = (y - a * cs - b).ravel()
        J = np.column_stack([-a * gy.ravel(), -a * gx.ravel(), cs.ravel(), np.ones(cs.size)])  # d(model)/d(s, a, b)
        step, *_ = np.linalg.lstsq(J, r, rcond=None)
        if not np.all(np.isfinite(step)):
            raise InputDataError("image", "least-squares shift refinement diverged (no finite step): no match")
        ds = np.clip(step[:2], -0.5, 0.5)  # Gauss-Newton step of (s, a, b); only s is kept
        s += ds
        if np.max(np.abs(ds)) < 1e-4:
            break
    return float(s[0]), float(s[1])


@dataclass(frozen=True)
class SeparableNoise:
    """Receiver noise of a formed image, for the quadratic forms of :func:`magnitude_shift_precision`.

    ``E[n(i, j) conj(n(i', j'))] = power * rows[i, i'] * rho[j' - j]`` (``rho[-d] = conj(rho[d])``): a full covariance
    between rows (azimuth) and a stationary correlation along columns (range). Range compression is a convolution, so
    the noise is stationary in range; the azimuth compression of a short block is not (RDA compresses a weak chirp
    linearly on a zero-padded block and keeps the block's rows, so the noise variance and correlation change with the
    row), and a stationary model of it under-states the variance of a shift by ~10 % near the block centre.
    Separability holds while range migration within the block is below a range bin (RCMC then mixes columns little).
    """

    power: float
    rows: np.ndarray
    rho: np.ndarray

    @classmethod
    def from_images(cls, images, max_lag: int, power: float | None = None) -> "SeparableNoise":
        """Estimate from realisations ``images`` (T, P, N) of the image-formation chain applied to noise alone:
        row covariance averaged over columns and realisations, range correlation over rows, columns and realisations
        (lags 0 .. max_lag - 1). ``power``: the noise power per pixel the model stands for (default: the images')."""
        n = np.asarray(images, dtype=np.complex128)
        if n.ndim != 3 or n.shape[0] < 1 or max_lag < 1 or n.shape[2] <= max_lag:
            raise InputDataError("noise_images", f"need (T, P, N > {max_lag}) noise images, got {n.shape}")
        p0 = float(np.mean(np.abs(n) ** 2))
        if not p0 > 0:
            raise InputDataError("noise_images", "have no power")
        T, P, N = n.shape
        flat = np.ascontiguousarray(n.transpose(1, 0, 2)).reshape(P, T * N)
        rows = (flat @ flat.conj().T) / (T * N * p0)  # sum over t, j of n[t, i, j] conj(n[t, k, j])
        # sum_j n[j] conj(n[j + d]) for every lag at once: the inverse FFT of |FFT|^2 summed over t and rows,
        # zero-padded to 2N (linear, not circular, correlation); equal to the direct sums to FFT rounding
        spectrum = np.sum(np.abs(sfft.fft(n, 2 * N, axis=2)) ** 2, axis=(0, 1))
        lagged = np.conj(sfft.ifft(spectrum)[:max_lag])
        rho = lagged / (T * P * (N - np.arange(max_lag)) * p0)
        return cls(power=p0 if power is None else float(power), rows=rows, rho=rho)

    def quadratic(self, h: np.ndarray, rows) -> float:
        """``E|sum_ij conj(h_ij) n_ij|^2`` for ``h`` (m, k) placed on the image rows ``rows`` (m,) and k columns."""
        m, k = h.shape
        if k > self.rho.size:
            raise InputDataError("h", f"spans {k} columns, the noise model {self.rho.size}")
        d = np.arange(k)[None, :] - np.arange(k)[:, None]  # j' - j
        P = np.where(d >= 0, self.rho[np.abs(d)], np.conj(self.rho[np.abs(d)]))
        C = self.rows[np.ix_(rows, rows)]
        return float(np.real(np.sum(C * (np.conj(h) @ P @ h.T)))) * self.power


def _phase_turn(ref: np.ndarray, phase_turn, noise_power: float) -> tuple[np.ndarray | None, float]:
    """(exp(j turn) - 1, the clutter's power per pixel) of :func:`magnitude_shift_precision`'s ``phase_turn`` (None,
    0 without one). The clutter's power: the reference's median pixel power over ln 2 (a speckle pixel's power is
    exponential: robust to the few bright points of a chip), less its noise."""
    if phase_turn is None:
        return None, 0.0
    turn = np.asarray(phase_turn, dtype=np.float64)
    if turn.shape != ref.shape or not np.all(np.isfinite(turn)):
        raise InputDataError("phase_turn", f"must be finite and of the reference's shape {ref.shape}, got {turn.shape}")
    clutter = max(float(np.median(np.abs(ref) ** 2)) / math.log(2.0) - float(noise_power), 0.0)
    return np.exp(1j * turn) - 1.0, clutter


def magnitude_shift_precision(reference, image, shift, noise_reference, noise_image,
                              mismatch: bool = True, phase_turn=None) -> tuple[float, float]:
    """Predicted 1-sigma [pixels] (rows, columns) of the least-squares shift (:func:`refine_shift`) of two *complex*
    images registered by their magnitudes: the first-order (Cramer-Rao-like) error of the shift from the receiver
    noise of both images and, with ``mismatch``, from whatever else differs between them.

    ``noise_reference``, ``noise_image``: (:class:`SeparableNoise`, rows (m,)) of each: the noise model of the image the
    chip was cut from and the image rows it occupies. Where the signal dominates, a complex perturbation n enters the
    magnitude as ``Re(n exp(-j phi))`` (phi the image phase), so with ``g_k = a d|template|/dk`` the gradient of the
    fitted template and ``h = g_k exp(j phi)``: ``var(g_k^T m) = E|sum conj(h) n|^2 / 2`` for each image (the
    reference's noise shifted with it and scaled by the fitted gain a), and ``var(s_k) = (sum) / E_k^2``.

    Near the noise floor (issue 29): ``h`` carries per pixel the square root of :func:`rician_weight` (the magnitude of
    a pixel near the floor is Rice-distributed, its variance below the first-order N/2), and ``E_k`` is the gradient
    energy the two images *share*, ``min(g_k^T g_k, sum g_k d|image|/dk)``, not the noisy template's ``g_k^T g_k``:
    the curvature of the least-squares cost in s is ``a^2 sum (d|ref|/dk)^2 - a sum r d^2|ref|/dk^2``, and the
    template's own noise in the residual r cancels its gradient energy in the first sum; the cross product with the
    other image (independent noise) estimates what remains without that bias.
    The receiver noise comes from the radar's noise floor and the image-formation chain (known; the fit's residual
    would under-state it: a chip a few azimuth correlation lengths long lets the fitted gain and offset absorb much
    of it).

    Scene changes between the passes (speckle decorrelated by time or baseline, geometry) are not in that model; they
    are in the fit's residual ``r = |image| - a |reference(shifted)| - b``. With ``mismatch`` the residual power over
    the pixels where the template stands 10 dB above the noise (where ``Re(n exp(-j phi))`` is the magnitude noise and
    its variance is ``(N_image + a^2 N_reference) / 2``; the fit's gain a by :func:`corrected_gain`, since least squares
    on the noisy template attenuates it and leaves signal in those pixels' residual) is compared with that
    expectation: a ratio kappa significantly
    above 1 (beyond three standard errors of a noise-only ratio, ``sqrt(2 / n)`` over n pixels) scales the
    prediction by sqrt(kappa): the mismatch is treated as more noise of the same spectrum (the shared gradient energy
    leaves out the decorrelated texture's gradients, which the other image does not have) (docs/scenarios/rda-nav.md
    §6).

    ``phase_turn`` (the reference's shape) [rad]: how far the phase of the scene's clutter at each pixel has turned
    between the passes relative to the target's pixel (over relief seen from another pass:
    ``measurements.sar_product.reference_in_flight``). Linearised about the target's phase, the image's clutter c
    differs from the reference's by ``(exp(j turn) - 1) c``, a mismatch that is zero at the target and grows away from
    it, where the registration's weights are; noise of the same spectrum scaled by kappa misses it (1.3-1.4 x too
    small a sigma on slopes). Its variance is the image noise's quadratic form of ``h conj(exp(j turn) - 1)`` scaled
    to the clutter's power C (the median pixel power of the reference over ln 2, less its noise), and kappa is taken on
    the residual power it leaves unexplained, ``C |exp(j turn) - 1|^2 / 2`` per pixel."""
    from scipy import ndimage

    ref = np.asarray(reference, dtype=np.complex128)
    img = np.asarray(image, dtype=np.complex128)
    if ref.shape != img.shape or ref.ndim != 2 or min(ref.shape) < 3:
        raise InputDataError("image", f"reference and image must be equal 2-D arrays of >= 3x3, got {ref.shape}, {img.shape}")
    shifted = ndimage.shift(ref.real, shift, order=3, mode="nearest") + 1j * ndimage.shift(ref.imag, shift, order=3,
                                                                                           mode="nearest")
    cs = ndimage.shift(np.abs(ref), shift, order=3, mode="nearest")
    A = np.column_stack([cs.ravel(), np.ones(cs.size)])
    (a, b), *_ = np.linalg.lstsq(A, np.abs(img).ravel(), rcond=None)
    if mismatch:  # the residual of the complex-shifted template: the magnitude's own interpolation error is no mismatch
        cz = np.abs(shifted)
        az, bz = corrected_gain(cz, np.abs(img), 0.5 * noise_reference[0].power * rician_weight(shifted, noise_reference[0].power))
        turn, clutter = _phase_turn(ref, phase_turn, noise_reference[0].power)
        scale = mismatch_ratio(np.abs(img) - az * cz - bz, cz, az, noise_reference[0].power, noise_image[0].power,
                               explained=None if turn is None else 0.5 * clutter * np.abs(turn) ** 2)
    else:
        scale, turn, clutter = 1.0, None, 0.0
    out = []
    w_img = np.sqrt(rician_weight(img, noise_image[0].power))
    w_ref = np.sqrt(rician_weight(shifted, noise_reference[0].power))
    for axis in (0, 1):
        g = a * _spline_gradient(np.abs(ref), shift, axis)
        num = 0.5 * noise_image[0].quadratic(w_img * g * np.exp(1j * np.angle(img)), noise_image[1])
        num += 0.5 * a * a * noise_reference[0].quadratic(w_ref * g * np.exp(1j * np.angle(shifted)), noise_reference[1])
        # the curvature of the least-squares cost in s: the gradient energy both images share (see the docstring)
        num *= scale
        if turn is not None:  # the clutter turned against the target (docstring)
            num += 0.5 * clutter / noise_image[0].power * noise_image[0].quadratic(
                w_img * g * np.exp(1j * np.angle(img)) * np.conj(turn), noise_image[1])
        energy = min(float(np.sum(g * g)), max(float(np.sum(g * _spline_gradient(np.abs(img), (0.0, 0.0), axis))), 0.0))
        out.append(np.sqrt(max(num, 0.0)) / energy if energy > 0 else np.inf)
    return float(out[0]), float(out[1])



def corrected_gain(x, y, noise_variance) -> tuple[float, float]:
    """(a, b) of ``y ~ a x + b`` when the regressor ``x`` carries noise of variance ``noise_variance`` per pixel (the
    template's magnitude noise): the least-squares slope over the attenuation its noise causes. Least squares on a
    noisy regressor estimates ``lambda a``, ``lambda = 1 - sum(v) / sum((x - mean x)^2)`` (the reliability ratio;
    errors in variables, Fuller 1987, *Measurement Error Models*, §1.1); the moment estimator divides it out. Where
    the regressor's spread is not above its noise (``lambda <= 0``: no signal to fit a gain on) the plain least squares
    is returned. Why (issue 29): near the noise floor (15 dB peak SNR, lambda ~ 0.5) the attenuated gain leaves
    ``(1 - lambda) a |s|`` of the signal in the residual of the bright pixels, which :func:`mismatch_ratio` took for a
    scene mismatch (kappa 3-4 with none)."""
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    xc = x - x.mean()
    sxx = float(np.sum(xc * xc))
    v = np.asarray(noise_variance, dtype=np.float64)
    if (v.ndim and v.size != x.size) or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise InputDataError("noise_variance", f"must be one finite value >= 0 or one per sample ({x.size}), got shape "
                             f"{v.shape}")
    spread = sxx - (float(np.sum(v)) if v.ndim else float(v) * x.size)
    denom = spread if spread > 0 else sxx
    a = float(np.sum(xc * (y - y.mean()))) / denom if denom > 0 else 0.0
    return a, float(y.mean() - a * x.mean())


def rician_weight(x, noise_power: float) -> np.ndarray:
    """Variance of the magnitude of each pixel of ``x`` relative to the first-order ``noise_power / 2``: a pixel of
    amplitude A in complex Gaussian noise of power N has a Rice-distributed magnitude of variance
    ``A^2 + N - (pi N / 4) L_{1/2}(-K)^2`` (K = A^2 / N, L_{1/2} the Laguerre function; Rice 1944), which is N/2 for
    K >> 1 and (1 - pi/4) N (Rayleigh) for K = 0. K is estimated from the pixel's own power, ``max(|x|^2 / N - 1, 0)``.
    Returns ``2 (K + 1 - pi/4 L^2)`` in [0.43, 1]: near the noise floor the first-order model over-states the magnitude
    noise by up to 2.3x in variance."""
    from scipy import special

    K = np.maximum(np.abs(np.asarray(x)) ** 2 / float(noise_power) - 1.0, 0.0)
    L = (1.0 + K) * special.ive(0, K / 2) + K * special.ive(1, K / 2)  # L_{1/2}(-K) with the exp(-K/2) folded in
    return np.clip(2.0 * (K + 1.0 - 0.25 * np.pi * L * L), 2.0 - 0.5 * np.pi, 1.0)


#: the residual power must exceed the receiver noise's by this factor (a mismatch at least as strong as the noise:
#: an image pair focused differently, e.g. with the estimated speed against the true one, leaves a residual of the
#: same order that moves the shift little; measured over the rda-nav variants, docs/scenarios/rda-nav.md §3)
MISMATCH_KAPPA = 2.0
#: a pixel counts as bright (first-order magnitude noise) where the template's power is this many times the noise
BRIGHT_FACTOR = 10.0


def mismatch_ratio(residual, template, a: float, n_reference: float, n_image: float, explained=None) -> float:
    """kappa (>= 1) of :func:`magnitude_shift_precision`: the residual power over the bright pixels (template power >
    ``BRIGHT_FACTOR`` x the noise), less the part ``explained`` (per pixel) by a modelled mismatch, against the
    receiver noise's expectation ``(N_image + a^2 N_reference) / 2`` there; 1 unless it exceeds both
    ``MISMATCH_KAPPA`` and 1 + three standard errors ``3 sqrt(2 / n)`` (n bright pixels, at least 8)."""
    bright = template**2 > BRIGHT_FACTOR * n_reference
    n = int(np.count_nonzero(bright))
    expected = 0.5 * (n_image + a * a * n_reference)
    if n < 8 or not expected > 0:
        return 1.0
    power = residual[bright] ** 2 - (0.0 if explained is None else np.asarray(explained)[bright])
    kappa = float(np.mean(power)) / expected
    return kappa if kappa > max(MISMATCH_KAPPA, 1.0 + 3.0 * math.sqrt(2.0 / n)) else 1.0


def distinctness(surface: np.ndarray, exclude: tuple[int, int]) -> float:
    """Height of the highest correlation outside the main peak's neighbourhood (``exclude`` = half sizes in rows and
    columns) relative to the main peak, for a magnitude correlation surface (``Registration.surface``): near 1 when
    another match is as good (an ambiguous scene), near 0 for a distinct one."""
    s = np.asarray(surface, dtype=np.float64)
    i, j = np.unravel_index(int(np.argmax(s)), s.shape)
    peak = s[i, j]
    if not peak > 0:
        return 1.0
    mask = np.ones(s.shape, dtype=bool)
    mask[max(i - exclude[0], 0):i + exclude[0] + 1, max(j - exclude[1], 0):j + exclude[1] + 1] = False
    return float(s[mask].max() / peak) if mask.any() else 0.0
