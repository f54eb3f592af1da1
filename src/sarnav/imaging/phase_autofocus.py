"""Phase autofocus for back-projected images: phase-gradient (PGA) and minimum-entropy (MEA).

A back-projected image keeps the spherical wavefront of every scatterer: the azimuth spectrum of a
scatterer depends on where it is (a point 20 m off-centre at 5 km shifts its spectrum by a large
fraction of the band, FastSAR ``autofocus.py`` notes; anchors-wave2 §4.1), so a per-pulse phase
error does not sit at one spectral position. The *deramp* used here: multiply by
``exp(-j 4 pi r / lambda)``, r the range from the aperture centre c, and sample the image on the
polar grid (r, u = direction cosine against the track): then, to first order in the pulse offset
s_k = (a_k - c).v, every scatterer's contribution of pulse k is ``exp(-j 4 pi s_k u / lambda)``, a
tone whose frequency ``-2 s_k / lambda`` (cycles per unit u) is the same for all scatterers
(:func:`sarnav.imaging.ffbp.polar_image`). A per-pulse phase error ``phi_k`` (data multiplied by
``exp(j phi_k)``) therefore multiplies the u-spectrum at that frequency, as in a polar-format
image, and the classic estimators apply:

* :func:`pga` — Wahl, Eichel, Ghiglia & Jakowatz, IEEE TAES 30(3) 1994 §II: per range line, shift
  the brightest sample to the centre, window (width shrinking each iteration), FFT, phase
  difference estimate ``dphi(n) = arg sum_r G_r(n) conj(G_r(n-1))`` (the ML / "phase difference"
  kernel, Jakowatz et al. 1996 §4.5), integrate, remove constant and linear terms, correct,
  iterate until the update is below ``tol``.
* :func:`minimum_entropy` — image-entropy minimisation (Kragh, MIT LL 2006; Fienup & Miller,
  JOSA A 20(4) 2003 eq. 5 gradient): ``H = -sum (I/E) ln(I/E)`` of the intensity I of the polar
  image, minimised over the spectral phase with L-BFGS using the analytic gradient
  ``dH/dphi_n = -(2/(E N)) sum_r Im(G'_rn conj(FFT_u[(ln I + 1) g]_rn))``; first over a low-order
  Legendre basis (large smooth errors), then over every in-band bin.

Constant and linear phase only move the image (unobservable to both, torchbp ``phase_to_pos``
docstring; anchors-sar L431): both functions return the phase with them removed (least squares over
the pulses). The phase is estimated per spectral bin and interpolated to the pulses.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.fft as sfft
from scipy.optimize import minimize

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData
from sarnav.imaging.ffbp import polar_image

__all__ = ["AutofocusResult", "pga", "minimum_entropy", "detrend_phase", "image_entropy"]


@dataclass
class AutofocusResult:
    """phase: (P,) phase error removed [rad] (constant and linear terms removed); corrected: the pulses
    multiplied by exp(-j phase); metadata: iterations, final entropy / update size."""

    phase: np.ndarray
    corrected: PulseData
    metadata: dict = field(default_factory=dict)


def detrend_phase(phase, weights=None) -> np.ndarray:
    """``phase`` minus its (weighted) least-squares constant + linear fit over the sample index."""
    phase = np.asarray(phase, dtype=np.float64)
    x = np.linspace(-1.0, 1.0, phase.size)
    w = np.ones(phase.size) if weights is None else np.asarray(weights, dtype=np.float64)
    a = np.stack([np.ones_like(x), x], axis=1) * np.sqrt(w)[:, None]
    coef, *_ = np.linalg.lstsq(a, phase * np.sqrt(w), rcond=None)
    return phase - coef[0] - coef[1] * x


def image_entropy(img) -> float:
    """Shannon entropy of the normalised intensity, ``-sum p ln p``, p = |img|^2 / sum |img|^2 (nats)."""
    i = np.abs(np.asarray(img)) ** 2
    p = i / i.sum()
    p = p[p > 0]
    return float(-np.sum(p * np.log(p)))


class _Spectrum:
    """u-spectrum of the deramped polar image and its mapping to pulses."""

    def __init__(self, rc, grid, positions, wavelength, interpolation, upsample, oversample):
        vals, _r, u, s, lam = polar_image(rc, grid, positions, wavelength=wavelength, oversample=oversample,
                                          interpolation=interpolation, upsample=upsample)
        self.n = vals.shape[1]
        du = float(u[1] - u[0])
        self.freq = sfft.fftshift(sfft.fftfreq(self.n, du))            # cycles per unit u, increasing
        self.spec = sfft.fftshift(sfft.fft(vals, axis=1), axes=1)      # G(r, n)
        self.f_pulse = -2.0 * s / lam                                   # frequency of each pulse
        lo, hi = float(self.f_pulse.min()), float(self.f_pulse.max())
        half = 0.5 / (self.n * du)
        self.band = (self.freq >= lo - half) & (self.freq <= hi + half)
        if np.count_nonzero(self.band) < 8:
            raise InputDataError("grid", f"scene too narrow for autofocus: {np.count_nonzero(self.band)} spectral "
                                 "bins in the aperture's band (need >= 8; widen the grid across track)")

    def image(self, phase_bins: np.ndarray) -> np.ndarray:
        g = self.spec * np.exp(-1j * phase_bins)[None, :]
        return sfft.ifft(sfft.ifftshift(g, axes=1), axis=1)

    def to_pulses(self, phase_bins: np.ndarray) -> np.ndarray:
        fb = self.freq[self.band]
        return np.interp(self.f_pulse, fb, phase_bins[self.band])


def _check_common(rc, iterations):
    if not isinstance(rc, PulseData) or not rc.compressed:
        raise InputDataError("rc", "must be range-compressed PulseData (compressed=True)")
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or iterations < 1:
        raise ConfigError("iterations", f"must be an integer >= 1, got {iterations!r}")


def _finish(rc: PulseData, spec: _Spectrum, phase_bins: np.ndarray, meta: dict) -> AutofocusResult:
    phase = detrend_phase(spec.to_pulses(phase_bins))
    data = np.asarray(rc.data) * np.exp(-1j * phase)[:, None].astype(np.complex128)
    corrected = replace(rc, data=data.astype(np.result_type(rc.data, np.complex64)),
                        metadata=dict(rc.metadata, autofocus=meta.get("method")))
    return AutofocusResult(phase, corrected, meta)


def _pga_estimate(img: np.ndarray, band: np.ndarray, width: int) -> np.ndarray:
    """One PGA step: centre-shift, window, phase-difference estimate over the band; (N,) phase."""
    n = img.shape[1]
    peak = np.argmax(np.abs(img), axis=1)
    shifted = np.empty_like(img)
    for r in range(img.shape[0]):
        shifted[r] = np.roll(img[r], n // 2 - peak[r])
    win = np.zeros(n)
    lo = max(0, n // 2 - width // 2)
    win[lo:lo + width] = 1.0
    g = sfft.fftshift(sfft.fft(sfft.ifftshift(shifted * win[None, :], axes=1), axis=1), axes=1)
    dphi = np.angle(np.sum(g[:, 1:] * np.conj(g[:, :-1]), axis=0))
    phi = np.concatenate([[0.0], np.cumsum(dphi)])
    idx = np.flatnonzero(band)
    out = np.zeros(n)
    out[idx] = detrend_phase(phi[idx])
    out[: idx[0]] = out[idx[0]]
    out[idx[-1] + 1:] = out[idx[-1]]
    return out


def _window_width(img: np.ndarray, floor: int) -> int:
    """Width [samples] of the centre-shifted mean intensity above -15 dB of its peak, times 2."""
    n = img.shape[1]
    peak = np.argmax(np.abs(img), axis=1)
    prof = np.zeros(n)
    for r in range(img.shape[0]):
        prof += np.abs(np.roll(img[r], n // 2 - peak[r])) ** 2
    above = np.flatnonzero(prof >= prof.max() * 10 ** (-1.5))
    return int(min(n, max(floor, 2 * (above.max() - above.min() + 1))))


def pga(rc: PulseData, grid, positions=None, *, wavelength: float | None = None, iterations: int = 15,
        tol: float = 1e-3, rows: float = 1.0, interpolation: str = "upsample", upsample: int = 4,
        oversample: float = 2.0, shrink: float = 0.5, min_width: int = 16) -> AutofocusResult:
    """Phase-gradient autofocus of the back-projected image of ``rc`` over ``grid`` (module doc).

    Parameters
    ----------
    rc : range-compressed pulses (phase errors unknown); grid : the scene (any grid of
        :mod:`sarnav.imaging.grid`); positions, wavelength : as ``backproject``.
    iterations : maximum PGA iterations; tol : stop when the rms update over the band < tol [rad].
    rows : fraction of range lines used, the brightest by peak intensity (0 < rows <= 1).
    oversample : polar-image samples per Nyquist sample (2: the band fills half the u-spectrum, so
        the centre shift does not wrap the band; 1 left a 0.28 rad bias on a focused scene).
    shrink, min_width : the window starts at the full line and is multiplied by ``shrink`` each
        iteration down to ``min_width`` samples (Wahl 1994 §II.C).

    Returns
    -------
    AutofocusResult (phase (P,) [rad], corrected pulses, metadata: iterations, last update rms).
    """
    _check_common(rc, iterations)
    if not (0.0 < rows <= 1.0):
        raise ConfigError("rows", f"must be in (0, 1], got {rows!r}")
    spec = _Spectrum(rc, grid, positions, wavelength, interpolation, upsample, oversample)
    total = np.zeros(spec.n)
    img = spec.image(total)
    keep = np.argsort(np.max(np.abs(img), axis=1))[::-1][: max(1, int(round(rows * img.shape[0])))]
    width = _window_width(img[keep], 8)
    it, rms = 0, float("inf")
    for it in range(1, iterations + 1):
        est = _pga_estimate(img[keep], spec.band, width)
        total += est
        img = spec.image(total)
        rms = float(np.sqrt(np.mean(est[spec.band] ** 2)))
        width = max(min_width, int(shrink * width))
        if rms < tol:
            break
    return _finish(rc, spec, total, {"method": "pga", "iterations": it, "last_update_rms": rms})


def _entropy_and_grad(phase_band, spec: _Spectrum, rows):
    phase = np.zeros(spec.n)
    phase[spec.band] = phase_band
    gp = spec.spec[rows] * np.exp(-1j * phase)[None, :]
    g = sfft.ifft(sfft.ifftshift(gp, axes=1), axis=1)
    inten = np.abs(g) ** 2
    e = inten.sum()
    tiny = e * 1e-300 + 1e-300
    w = np.log(inten + tiny) + 1.0
    h = -np.sum(inten / e * np.log(inten / e + 1e-300))
    hh = sfft.fftshift(sfft.fft(w * g, axis=1), axes=1)
    grad = -(2.0 / (e * spec.n)) * np.sum(np.imag(gp * np.conj(hh)), axis=0)
    return float(h), grad[spec.band]


def minimum_entropy(rc: PulseData, grid, positions=None, *, wavelength: float | None = None, iterations: int = 200,
                    basis_order: int = 12, rows: float = 0.5, interpolation: str = "upsample", upsample: int = 4,
                    oversample: float = 2.0) -> AutofocusResult:
    """Minimum-entropy autofocus of the back-projected image of ``rc`` over ``grid`` (module doc).

    ``basis_order``: Legendre polynomials 2..order fitted first (0 skips the smooth stage);
    ``iterations``: L-BFGS iterations of each stage; ``rows``: fraction of brightest range lines used.
    """
    _check_common(rc, iterations)
    if not (0.0 < rows <= 1.0):
        raise ConfigError("rows", f"must be in (0, 1], got {rows!r}")
    if isinstance(basis_order, bool) or not isinstance(basis_order, (int, np.integer)) or basis_order < 0:
        raise ConfigError("basis_order", f"must be an integer >= 0, got {basis_order!r}")
    spec = _Spectrum(rc, grid, positions, wavelength, interpolation, upsample, oversample)
    img0 = spec.image(np.zeros(spec.n))
    keep = np.argsort(np.max(np.abs(img0), axis=1))[::-1][: max(1, int(round(rows * img0.shape[0])))]
    nb = int(np.count_nonzero(spec.band))
    phase = np.zeros(nb)
    if basis_order >= 2:
        x = np.linspace(-1.0, 1.0, nb)
        basis = np.stack([np.polynomial.legendre.Legendre.basis(k)(x) for k in range(2, basis_order + 1)], axis=1)

        def fun_c(c):
            h, gr = _entropy_and_grad(basis @ c, spec, keep)
            return h, basis.T @ gr

        res = minimize(fun_c, np.zeros(basis.shape[1]), jac=True, method="L-BFGS-B",
                       options={"maxiter": iterations})
        phase = basis @ res.x
    res = minimize(lambda ph: _entropy_and_grad(ph, spec, keep), phase, jac=True, method="L-BFGS-B",
                   options={"maxiter": iterations})
    full = np.zeros(spec.n)
    full[spec.band] = res.x
    idx = np.flatnonzero(spec.band)
    full[: idx[0]] = full[idx[0]]
    full[idx[-1] + 1:] = full[idx[-1]]
    return _finish(rc, spec, full, {"method": "minimum_entropy", "iterations": int(res.nit),
                                    "entropy": float(res.fun)})
