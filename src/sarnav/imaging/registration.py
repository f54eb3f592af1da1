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

from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft

from sarnav.errors import ConfigError, InputDataError

__all__ = ["Registration", "register", "register_axis", "cross_correlation"]


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
