"""Predicted mean-square error of interpolating band-limited data with a short kernel.

Interpolating samples x(n) of a signal with a kernel k, ``y(t) = sum_n x(n) k(t - n)``, at positions
uniformly spread over the sample cell: for a complex tone of normalised frequency f (cycles per
sample) the mean-square error relative to the tone's power is (Parseval over one cell; the standard
interpolation-error spectrum, e.g. Parker, Kenyon & Troxel, IEEE TMI 2(1) 1983, eq. 9):

    eps(f) = |1 - K(f)|^2 + sum_{k != 0} |K(f + k)|^2,         K = continuous Fourier transform of k.

A signal whose spectrum is flat over |f| <= 1/(2 os) (``os`` = sampling rate / signal bandwidth,
the oversampling) has error ``mean_f eps(f)`` over that band; a separable 2-D kernel applied to a
2-D flat band has ``eps(fr, fu) = |1 - K(fr)K(fu)|^2 + sum_{(k1,k2) != 0} |K(fr+k1)|^2 |K(fu+k2)|^2``.

Kernels (defined in :mod:`sarnav.imaging.kernels`): "nearest" (box), "linear" (triangle, K = sinc^2),
"cubic" (Keys 1981, a = -1/2), "lagrange" (4-point cubic Lagrange). The
``upsample`` mode of back-projection is "linear" at ``os * upsample`` (the FFT zero-padding is exact
for a band-limited periodic pulse). FFBP also has "kaiser6": the 6-tap Kaiser-windowed sinc
``k(x) = sinc(x) I0(beta sqrt(1 - (x/3)^2)) / I0(beta)`` on |x| < 3 (interpolating: k(0) = 1, k(n) = 0),
with beta the one minimising the error at the data's oversampling (:func:`kaiser_beta`); at os 2 it
is -50.6 dB in 2-D where Keys cubic is -26.4 dB, so it reaches a given error with half the samples
per dimension.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sarnav.errors import ConfigError
from sarnav.imaging.kernels import KERNELS, WINDOWED, point_kernel, windowed_sinc

__all__ = ["kernel_spectrum", "interpolation_error", "interpolation_error_2d", "kaiser_beta", "search_kaiser_beta",
           "windowed_sinc", "kernel_values", "summed_interpolation_error", "KERNELS", "WINDOWED"]

_ALIASES = 6          # images k = -6..6 in the alias sum (|K| falls as 1/f^2 .. 1/f^4)
_BAND_POINTS = 401    # quadrature points across the band


@functools.lru_cache(maxsize=8)
def _window_nodes(half: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes x on (0, half) and weights of a 160-point Gauss-Legendre rule in theta, x = half sin(theta)."""
    t, w = np.polynomial.legendre.leggauss(160)
    theta = (t + 1.0) * (np.pi / 4.0)
    return half * np.sin(theta), half * np.cos(theta) * w * (np.pi / 4.0)


def kernel_spectrum(name: str, f, beta: float | None = None) -> np.ndarray:
    """Continuous Fourier transform K(f) of an interpolation kernel (real, even) at frequencies f
    (``beta``: the window of a :data:`WINDOWED` kernel)."""
    f = np.asarray(f, dtype=np.float64)
    if name in WINDOWED:
        if beta is None or not math.isfinite(beta) or beta < 0:
            raise ConfigError("beta", f"a windowed kernel needs its window's beta >= 0 (kaiser_beta), got {beta!r}")
        # Gauss-Legendre in theta, x = (taps/2) sin(theta): the window's sqrt(1 - (x / half)^2) = cos(theta) becomes
        # smooth; 160 nodes reach 1e-13 where a 4000-point midpoint rule had 7e-10 (and took 10x the time: kaiser_beta
        # at a new os took 3 s of an FFBP call)
        x, dx = _window_nodes(WINDOWED[name] / 2)
        return 2.0 * np.cos(2.0 * np.pi * np.multiply.outer(f, x)) @ (windowed_sinc(x, WINDOWED[name], beta) * dx)
    if name not in KERNELS:
        raise ConfigError("kernel", f"must be one of {KERNELS + tuple(WINDOWED)}, got {name!r}")
    if name == "nearest":
        return np.sinc(f)
    if name == "linear":
        return np.sinc(f) ** 2
    # Keys or Lagrange cubic: numerical cosine transform on a fine grid (piecewise cubic kernels on [-2, 2])
    x = (np.arange(2000) + 0.5) / 1000.0               # midpoints on (0, 2] (error of the rule ~1e-8)
    k = point_kernel(name, x)
    return 2.0 * np.cos(2.0 * np.pi * np.multiply.outer(f, x)) @ k / 1000.0


def kernel_values(name: str, x, os: float | None = None) -> np.ndarray:
    """The kernel ``name`` at distances x (a :data:`WINDOWED` kernel with :func:`kaiser_beta` at ``os``)."""
    if name in WINDOWED:
        return windowed_sinc(x, WINDOWED[name], kaiser_beta(name, float(os)))
    if name not in KERNELS:
        raise ConfigError("kernel", f"must be one of {KERNELS + tuple(WINDOWED)}, got {name!r}")
    return point_kernel(name, x)


def _band(os: float) -> np.ndarray:
    if not (math.isfinite(os) and os >= 1.0):
        raise ConfigError("oversample", f"must be finite and >= 1 (sampling rate / bandwidth), got {os!r}")
    return np.linspace(-0.5 / os, 0.5 / os, _BAND_POINTS)


@functools.lru_cache(maxsize=256)
def _spectra(name: str, os: float, beta: float | None = None):
    f = _band(os)
    if name in WINDOWED and beta is None:
        beta = kaiser_beta(name, os)
    k0 = kernel_spectrum(name, f, beta)
    alias = sum(kernel_spectrum(name, f + k, beta) ** 2 for k in range(-_ALIASES, _ALIASES + 1) if k != 0)
    return k0, alias


def interpolation_error(name: str, os: float, beta: float | None = None) -> float:
    """Relative mean-square error (linear, not dB) of kernel ``name`` on a flat band at oversampling ``os``
    (a :data:`WINDOWED` kernel with ``beta``, default :func:`kaiser_beta`)."""
    k0, alias = _spectra(name, float(os), beta)
    return float(np.mean((1.0 - k0) ** 2 + alias))


def summed_interpolation_error(name: str, os: float) -> float:
    """Relative mean-square error (linear) that interpolating every pulse leaves in an image summing many of them,
    after one fitted complex gain: each pulse is interpolated at its own fractional position, so the alias terms
    and the position-dependent part of the response add incoherently and average out over the aperture; what stays
    is the mean response's ripple across the band, ``mean_f |g - K(f)|^2 / g^2`` with g = mean_f K(f) (the
    coherent part of the module doc's eps(f)). Linear at os 8: -48.3 dB (full per-sample error: -44.0 dB);
    measured in the image (x4 against x16 upsampled exact back-projection, benchmarks/bench_ffbp.py scene):
    -47.2 dB. The averaging needs the fractional positions spread across the aperture (range migration over many
    samples, as on the FFBP benchmark's 2048-pulse aperture); with little migration the error tends to the
    per-sample :func:`interpolation_error` (benchmarks/bench_bpa.py, 128 pulses: -44.5 dB measured). So this is
    the lower end of a range whose upper end is the per-sample error."""
    k0, _ = _spectra(name, float(os))
    g = float(np.mean(k0))
    return float(np.mean((g - k0) ** 2) / g**2)


#: the windowed kernels' beta searched (``search_kaiser_beta``) at os 1.5, 1.6, ..., 4.0: the search takes 0.12-0.28 s,
#: which every FFBP call (a process's first at each os) paid, and ``ffbp(..., error_db=)`` weighs 26 os per kernel;
#: between the nodes ``kaiser_beta`` interpolates linearly (beta is smooth in os; the error it costs is < 0.01 dB,
#: tests/imaging/test_interpolation_default.py re-derives the tables)
KAISER_BETA_OS = (1.5, 4.0)
KAISER_BETA = {
    "kaiser6": (3.3194, 3.6764, 3.9882, 4.2653, 4.5158, 4.7454, 4.9590, 5.1609, 5.3543, 5.5411, 5.7215, 5.8936, 6.0555,
                6.2056, 6.3434, 6.4694, 6.5844, 6.6893, 6.7853, 6.8732, 6.9537, 7.0282, 7.0970, 7.1605, 7.2196, 7.2748),
    "kaiser8": (4.3301, 4.8220, 5.2632, 5.6669, 6.0428, 6.3946, 6.7206, 7.0169, 7.2834, 7.5220, 7.7363, 7.9293, 8.1043,
                8.2637, 8.4100, 8.5445, 8.6691, 8.7844, 8.8922, 8.9925, 9.0864, 9.1745, 9.2576, 9.3358, 9.4099, 9.4803),
    "kaiser10": (5.3595, 6.0004, 6.5834, 7.1145, 7.5925, 8.0179, 8.3962, 8.7346, 9.0393, 9.3152, 9.5668, 9.7968, 10.0082,
                 10.2039, 10.3860, 10.5569, 10.7185, 10.8726, 11.0201, 11.1616, 11.2979, 11.4279, 11.5516, 11.6687,
                 11.7796, 11.8840),
}
#: kaiser6's table and its os range under their earlier names
KAISER6_BETA_OS, KAISER6_BETA = KAISER_BETA_OS, KAISER_BETA["kaiser6"]


@functools.lru_cache(maxsize=64)
def kaiser_beta(name: str, os: float) -> float:
    """The Kaiser window's beta of :data:`WINDOWED` kernel ``name`` at oversampling ``os``: the one that minimises its
    1-D error (:func:`search_kaiser_beta`), at os 1.5-4 read from :data:`KAISER_BETA` (linear between its 0.1
    nodes)."""
    table = KAISER_BETA.get(name)
    if table is not None and isinstance(os, (int, float)) and KAISER_BETA_OS[0] <= os <= KAISER_BETA_OS[1]:
        nodes = np.linspace(KAISER_BETA_OS[0], KAISER_BETA_OS[1], len(table))
        return float(np.interp(float(os), nodes, table))
    return search_kaiser_beta(name, os)


@functools.lru_cache(maxsize=64)
def search_kaiser_beta(name: str, os: float) -> float:
    """The Kaiser window's beta that minimises the 1-D error of :data:`WINDOWED` kernel ``name`` at oversampling
    ``os`` (a bounded scalar search over 0 .. 3 taps; the 2-D optimum, searched with Nelder-Mead, differs by
    0.2-0.3 %: 4.734 against 4.745 at os 2, 6.45 against 6.47 at os 3)."""
    from scipy.optimize import minimize_scalar

    if name not in WINDOWED:
        raise ConfigError("kernel", f"must be one of {tuple(WINDOWED)}, got {name!r}")
    _band(os)
    res = minimize_scalar(lambda b: math.log(interpolation_error(name, os, float(b))), bounds=(0.0, 3.0 * WINDOWED[name]),
                          method="bounded", options={"xatol": 1e-3})
    return float(res.x)


def interpolation_error_2d(name: str, os_1: float, os_2: float, beta_1: float | None = None,
                           beta_2: float | None = None) -> float:
    """Relative mean-square error of the separable 2-D kernel on a flat 2-D band (module doc)."""
    a0, aa = _spectra(name, float(os_1), beta_1)
    b0, ba = _spectra(name, float(os_2), beta_2)
    tot1 = a0**2 + aa                                   # sum over all k1 of |K(f1 + k1)|^2
    tot2 = b0**2 + ba
    eps = (1.0 - np.outer(a0, b0)) ** 2 + np.outer(tot1, tot2) - np.outer(a0**2, b0**2)
    return float(np.mean(eps))
