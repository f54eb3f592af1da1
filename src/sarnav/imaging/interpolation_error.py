"""Predicted mean-square error of interpolating band-limited data with a short kernel.

Interpolating samples x(n) of a signal with a kernel k, ``y(t) = sum_n x(n) k(t - n)``, at positions
uniformly spread over the sample cell: for a complex tone of normalised frequency f (cycles per
sample) the mean-square error relative to the tone's power is (Parseval over one cell; the standard
interpolation-error spectrum, e.g. Parker, Kenyon & Troxel, IEEE TMI 2(1) 1983, eq. 9):

    eps(f) = |1 - K(f)|^2 + sum_{k != 0} |K(f + k)|^2,         K = continuous Fourier transform of k.

A signal whose spectrum is flat over |f| <= 1/(2 os) (``os`` = sampling rate / signal bandwidth,
the oversampling) has error ``mean_f eps(f)`` over that band; a separable 2-D kernel applied to a
2-D flat band has ``eps(fr, fu) = |1 - K(fr)K(fu)|^2 + sum_{(k1,k2) != 0} |K(fr+k1)|^2 |K(fu+k2)|^2``.

Kernels: "nearest" (box), "linear" (triangle, K = sinc^2), "cubic" (Keys 1981, a = -1/2). The
``upsample`` mode of back-projection is "linear" at ``os * upsample`` (the FFT zero-padding is exact
for a band-limited periodic pulse).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sarnav.errors import ConfigError

__all__ = ["kernel_spectrum", "interpolation_error", "interpolation_error_2d", "KERNELS"]

KERNELS = ("nearest", "linear", "cubic")
_ALIASES = 6          # images k = -6..6 in the alias sum (|K| falls as 1/f^2 .. 1/f^4)
_BAND_POINTS = 401    # quadrature points across the band


def _kernel(name: str, x: np.ndarray) -> np.ndarray:
    ax = np.abs(x)
    if name == "nearest":
        return np.where(ax < 0.5, 1.0, np.where(ax == 0.5, 0.5, 0.0))
    if name == "linear":
        return np.clip(1.0 - ax, 0.0, None)
    a = -0.5
    return np.where(ax <= 1.0, (a + 2) * ax**3 - (a + 3) * ax**2 + 1,
                    np.where(ax < 2.0, a * ax**3 - 5 * a * ax**2 + 8 * a * ax - 4 * a, 0.0))


def kernel_spectrum(name: str, f) -> np.ndarray:
    """Continuous Fourier transform K(f) of an interpolation kernel (real, even) at frequencies f."""
    if name not in KERNELS:
        raise ConfigError("kernel", f"must be one of {KERNELS}, got {name!r}")
    f = np.asarray(f, dtype=np.float64)
    if name == "nearest":
        return np.sinc(f)
    if name == "linear":
        return np.sinc(f) ** 2
    # Keys cubic: numerical cosine transform on a fine grid (the kernel is piecewise cubic on [-2, 2])
    x = (np.arange(2000) + 0.5) / 1000.0               # midpoints on (0, 2] (error of the rule ~1e-8)
    k = _kernel("cubic", x)
    return 2.0 * np.cos(2.0 * np.pi * np.multiply.outer(f, x)) @ k / 1000.0


def _band(os: float) -> np.ndarray:
    if not (math.isfinite(os) and os >= 1.0):
        raise ConfigError("oversample", f"must be finite and >= 1 (sampling rate / bandwidth), got {os!r}")
    return np.linspace(-0.5 / os, 0.5 / os, _BAND_POINTS)


@functools.lru_cache(maxsize=256)
def _spectra(name: str, os: float):
    f = _band(os)
    k0 = kernel_spectrum(name, f)
    alias = sum(kernel_spectrum(name, f + k) ** 2 for k in range(-_ALIASES, _ALIASES + 1) if k != 0)
    return k0, alias


def interpolation_error(name: str, os: float) -> float:
    """Relative mean-square error (linear, not dB) of kernel ``name`` on a flat band at oversampling ``os``."""
    k0, alias = _spectra(name, float(os))
    return float(np.mean((1.0 - k0) ** 2 + alias))


def interpolation_error_2d(name: str, os_1: float, os_2: float) -> float:
    """Relative mean-square error of the separable 2-D kernel on a flat 2-D band (module doc)."""
    a0, aa = _spectra(name, float(os_1))
    b0, ba = _spectra(name, float(os_2))
    tot1 = a0**2 + aa                                   # sum over all k1 of |K(f1 + k1)|^2
    tot2 = b0**2 + ba
    eps = (1.0 - np.outer(a0, b0)) ** 2 + np.outer(tot1, tot2) - np.outer(a0**2, b0**2)
    return float(np.mean(eps))
