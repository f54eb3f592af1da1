"""The interpolation kernels of the image formers in one place: definitions, tables and compiled tap loops.

Kernels (distance x in samples; all interpolating: k(0) = 1, k(n) = 0 for the other integers n):

* "nearest" (box), "linear" (triangle), "cubic": Keys (1981) cubic convolution, a = -1/2 (:func:`keys_cubic`),
  "lagrange": the 4-point cubic Lagrange interpolator (:func:`lagrange_cubic`; error O(h^4) where Keys' is O(h^3):
  on oversampled data it is the more accurate of the two, -77.5 dB against -70.7 dB at fs/B = 8), all four by
  :func:`point_kernel`;
* Kaiser-windowed sinc of N taps, ``sinc(x) I0(beta sqrt(1 - (2x/N)^2)) / I0(beta)`` on |x| < N/2
  (:func:`windowed_sinc`): FFBP's "kaiser6" (:data:`WINDOWED`, beta from the oversampling:
  ``interpolation_error.kaiser_beta``) and the RDA's range-migration correction "sinc8" / "sinc16"
  (:data:`RCMC_KERNELS`, beta 2.5, rows normalised to unit DC gain: :func:`rcmc_kernel_table`).

Users: back-projection (``backprojection``, FFBP's level 0 and ``offset_bpa``) interpolates each range-compressed
pulse, zero-padded by :data:`PAD` samples at each end, at the fractional sample of a range (:func:`range_tap`) with
nearest / linear / cubic / lagrange (:func:`gather`, :func:`gather_pair`; :data:`GATHER_MODE`) or FFT upsampling then linear
(:func:`padded_pulses`: the buffer the kernels read; :func:`upsample_pulses`); FFBP interpolates its polar images with a separable N x N kernel read from a table
(:func:`tabulate`; :func:`polar_tap` locates a point, :func:`taps_2d` sums the taps); the RDA reads
:func:`rcmc_kernel_table` in its compiled RCMC loop. Every interpolated sample is rotated by exp(j 2 pi f), f the
fractional cycle of 2 R / lambda reduced in float64: in float32 from quarter-wave polynomials (:func:`cis32`, max
error :data:`PHASE_F32_MAX_ERROR`) or in float64 from half-angle polynomials (:func:`cis64`,
:data:`PHASE_POLY_MAX_ERROR`; :func:`demodulate_parts` applies it to an array), no transcendental call in the loops,
so LLVM vectorises them without SVML. The kernels' predicted errors on band-limited data:
:mod:`sarnav.imaging.interpolation_error`; their measured accuracy: docs/backprojection.md.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np
import scipy.fft as sfft

from sarnav.errors import ConfigError, InputDataError

__all__ = ["KEYS_A", "KERNELS", "WINDOWED", "RCMC_KERNELS", "RCMC_TABLE_STEPS", "PAD", "GATHER_MODE", "RANGE_KERNEL", "UPSAMPLED",
           "PHASE_POLY_MAX_ERROR", "PHASE_F32_MAX_ERROR", "keys_cubic", "point_kernel", "windowed_sinc", "tabulate",
           "rcmc_kernel_table", "upsample_pulses", "padded_pulses", "lagrange_cubic", "cis32", "cis64", "demodulate_parts", "range_tap", "gather",
           "gather_pair", "gather_pair_lagrange", "polar_tap", "taps_2d", "taps_down", "taps_along"]

# ---------------------------------------------------------------------------------------------
# kernel definitions and tables (numpy)

#: Keys (1981) cubic-convolution parameter
KEYS_A = -0.5
#: piecewise-polynomial kernels of back-projection's range interpolation (:func:`point_kernel`)
KERNELS = ("nearest", "linear", "cubic", "lagrange")
#: windowed-sinc kernels: name -> taps (beta from the oversampling, ``interpolation_error.kaiser_beta``)
WINDOWED = {"kaiser6": 6, "kaiser8": 8, "kaiser10": 10}
#: RCMC interpolation kernels of the RDA: name -> (taps, Kaiser beta); "none" skips RCMC.
RCMC_KERNELS = {"sinc8": (8, 2.5), "sinc16": (16, 2.5), "none": (0, 0.0)}
#: fractional positions per sample of :func:`rcmc_kernel_table`
RCMC_TABLE_STEPS = 1024


def keys_cubic(x):
    """Keys (1981) cubic convolution kernel, a = -1/2, at distances x (4 taps: support |x| < 2)."""
    x = np.abs(x)
    a = KEYS_A
    return np.where(x <= 1.0, (a + 2.0) * x ** 3 - (a + 3.0) * x ** 2 + 1.0,
                    np.where(x < 2.0, a * x ** 3 - 5.0 * a * x ** 2 + 8.0 * a * x - 4.0 * a, 0.0))


def lagrange_cubic(x):
    """The 4-point cubic Lagrange interpolator as a kernel at distances x (support |x| < 2): the weights of the
    cubic through the samples at -1, 0, 1, 2 (Schafer & Rabiner, Proc. IEEE 61(6) 1973, "A digital signal processing
    approach to interpolation"): (1 - x^2)(2 - x)/2 on [0, 1], -(x - 1)(x - 2)(x - 3)/6 on [1, 2]."""
    x = np.abs(x)
    return np.where(x <= 1.0, 0.5 * (1.0 - x * x) * (2.0 - x),
                    np.where(x < 2.0, -(x - 1.0) * (x - 2.0) * (x - 3.0) / 6.0, 0.0))


def point_kernel(name: str, x) -> np.ndarray:
    """The kernel ``name`` of :data:`KERNELS` at distances x (float64): box (0.5 at |x| = 1/2), triangle, Keys or
    Lagrange."""
    ax = np.abs(np.asarray(x, dtype=np.float64))
    if name == "nearest":
        return np.where(ax < 0.5, 1.0, np.where(ax == 0.5, 0.5, 0.0))
    if name == "linear":
        return np.clip(1.0 - ax, 0.0, None)
    if name == "lagrange":
        return lagrange_cubic(ax)
    return keys_cubic(ax)


def windowed_sinc(x, taps: int, beta: float) -> np.ndarray:
    """Kaiser-windowed sinc of ``taps`` taps: sinc(x) I0(beta sqrt(1 - (2x/taps)^2)) / I0(beta), 0 for |x| >= taps/2."""
    x = np.asarray(x, dtype=np.float64)
    arg = np.clip(1.0 - (2.0 * x / taps) ** 2, 0.0, None)
    return np.where(np.abs(x) < taps / 2, np.sinc(x) * np.i0(beta * np.sqrt(arg)) / np.i0(beta), 0.0)


def tabulate(kernel, taps: int, steps: int) -> np.ndarray:
    """(steps + 1, taps) weights ``kernel(x)`` (a function of distance arrays) for a point at fraction w = i / steps
    past sample ``floor``: tap t multiplies sample ``floor - (taps/2 - 1) + t``, at distance w - t + taps/2 - 1."""
    w = np.arange(steps + 1) / steps
    return kernel(w[:, None] - np.arange(taps)[None, :] + (taps // 2 - 1))


@lru_cache(maxsize=8)
def rcmc_kernel_table(taps: int = 8, beta: float = 2.5, steps: int = RCMC_TABLE_STEPS) -> np.ndarray:
    """Windowed-sinc interpolation weights of the RDA's RCMC, shape (steps + 1, taps) (:func:`tabulate`).

    Row q interpolates at fractional offset ``q / steps`` past sample ``base``; tap t multiplies sample
    ``base - taps/2 + 1 + t``. Weight = :func:`windowed_sinc` (Cumming & Wong 2005 §3.4), each row
    normalised to sum 1 (unit gain at zero frequency); rows 0 and ``steps`` are exact unit impulses.
    The returned array is read-only (cached).
    """
    half = taps // 2
    w = tabulate(lambda x: windowed_sinc(x, taps, beta), taps, steps)
    w /= w.sum(axis=1, keepdims=True)
    w[0] = 0.0
    w[0, half - 1] = 1.0
    w[-1] = 0.0
    w[-1, half] = 1.0
    w.setflags(write=False)
    return w


def upsample_pulses(data: np.ndarray, rng: np.ndarray, factor: int, dtype=np.complex128):
    """Band-limited interpolation of every pulse by FFT zero-padding: (P, (N-1)*factor + 1) samples
    on the range axis ``rng[0] + i dr / factor`` (the wrapped tail beyond the last sample dropped): the
    samples of :func:`padded_pulses` without its zero columns (a view of its buffer).
    """
    buf, fine, m = padded_pulses(data, rng, factor, dtype)
    return buf[:, PAD:PAD + m], fine


def padded_pulses(data: np.ndarray, rng: np.ndarray, factor: int = 1, dtype=np.complex128):
    """(buffer, range axis, m): the pulses FFT-upsampled by ``factor`` (1: as they are) as the back-projection
    kernels read them, m samples per pulse on ``rng[0] + i dr / factor`` in columns PAD .. PAD + m - 1 of a zeroed
    (P, >= m + 2 PAD) buffer; every other column is zero.

    Upsampling is FFT zero-padding. The FFTs run at N' = ``scipy.fft.next_fast_len(N)``: pulses of a length the FFT
    does slowly (the peer's CPHD collect read at fs/B 4 has 6529 samples, a prime: x7 took 1.9 s for 1812 pulses,
    0.33 s at 6534) are extended by N' - N samples that bridge the last samples back to the first (a cubic Hermite
    curve matching values and one-sided slopes), so the period the FFT assumes gains no new jump, and the output
    still stops at the last sample. Against zero samples (a jump at each end of the gap: "precise" -73 dB on a CPHD
    window of half the period, -80.6 dB unpadded) the bridge measures -84.6 dB there, -89.8 dB on the DFT lattice
    (-91.9 unpadded).
    Both FFTs run in place in the one buffer that is returned: a large array's first write costs page faults
    (on a Firecracker VM 0.3 s for the 166 MB of the peer's 1024^2 collect at x7, ~10 % of the image), so the
    spectrum, the zero-padded spectrum and the padded samples share it instead of being three arrays.
    ``dtype`` complex64: FFTs in single precision (the compiled kernels keep complex64 samples anyway;
    rounding ~1e-7 of the samples, -130 dB), complex128 for the float64 reference (tests/imaging/test_cphd_accuracy.py).
    """
    data = np.asarray(data)
    if data.ndim != 2 or data.shape[1] < 1:
        raise InputDataError("data", f"must be (pulses, samples) with at least one sample, got shape {data.shape}")
    if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or not 1 <= factor <= 64:
        raise ConfigError("upsample", f"must be an integer in [1, 64], got {factor!r}")
    n_p, n0 = data.shape
    rng = np.asarray(rng, dtype=np.float64)
    if rng.shape != (n0,) or (n0 > 1 and not rng[1] > rng[0]):
        raise InputDataError("slant_range", f"must be {n0} increasing ranges, one per sample, got shape {rng.shape}")
    if factor == 1:
        buf = np.zeros((n_p, n0 + 2 * PAD), dtype=dtype)
        buf[:, PAD:PAD + n0] = data
        return buf, rng, n0
    n = sfft.next_fast_len(n0)
    size = n * factor
    buf = np.zeros((n_p, size + 2 * PAD), dtype=dtype)
    v = buf[:, PAD:PAD + size]             # one period of the upsampled pulse
    v[:, :n0] = data
    if n > n0 and n0 >= 2:   # the gap bridged by a cubic Hermite curve from the last samples to the first ones
        g = n - n0 + 1
        t = np.arange(1, g) / g
        p0, p1 = data[:, -1:], data[:, :1]
        m0, m1 = (data[:, -1:] - data[:, -2:-1]) * g, (data[:, 1:2] - data[:, :1]) * g
        h00, h10, h01, h11 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t, -2 * t**3 + 3 * t**2, t**3 - t**2
        v[:, n0:n] = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
    workers = max(1, numba.get_num_threads())          # the FFTs use the kernel's threads
    _in_place(sfft.fft, v[:, :n], workers)
    h = (n + 1) // 2                      # non-negative frequencies 0 .. h-1 stay where they are
    v[:, size - (n - h):] = v[:, h:n]     # the negative ones move to the end of the period (no overlap: factor >= 2)
    v[:, h:n] = 0
    v[:, :h] *= factor                    # the ifft's 1/size against the fft's n
    v[:, size - (n - h):] *= factor
    if n % 2 == 0:                        # split the Nyquist bin symmetrically
        v[:, size - n // 2] *= 0.5
        v[:, n // 2] = v[:, size - n // 2]
    _in_place(sfft.ifft, v, workers)
    m = (n0 - 1) * factor + 1
    buf[:, PAD + m:] = 0                  # the wrapped tail beyond the last sample
    return buf, rng[0] + np.arange(m) * ((rng[1] - rng[0]) / factor), m


def _in_place(transform, view, workers) -> None:
    """``transform`` (scipy.fft.fft or ifft) of each row of ``view``, written back into it."""
    out = transform(view, axis=1, workers=workers, overwrite_x=True)
    if not np.shares_memory(out, view):   # scipy chose a new array (not the case on scipy 1.x for complex input)
        view[...] = out


# ---------------------------------------------------------------------------------------------
# the phase factor exp(j 2 pi f) of an interpolated sample

def _fit_even_poly(fun, degree: int) -> np.ndarray:
    """Least-squares coefficients c_i of ``fun(x) ~ sum_i c_i x^(2i)`` on [0, pi/2] (x^2 powers)."""
    x = 0.5 * np.pi * 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, 4001)))  # Chebyshev-spaced
    coef, *_ = np.linalg.lstsq(np.vander(x * x, degree + 1, increasing=True), fun(x), rcond=None)
    return coef


# sin(x) = x * S(x^2), cos(x) = C(x^2) on |x| <= pi/2
_SIN = _fit_even_poly(lambda x: np.sinc(x / np.pi), 5)
_COS = _fit_even_poly(np.cos, 6)


def _phase_poly_error() -> float:
    x = np.linspace(-0.5 * np.pi, 0.5 * np.pi, 100001)
    t = x * x
    es = np.max(np.abs(x * np.polynomial.polynomial.polyval(t, _SIN) - np.sin(x)))
    ec = np.max(np.abs(np.polynomial.polynomial.polyval(t, _COS) - np.cos(x)))
    return float(max(es, ec))


#: max abs error of the float64 sin/cos polynomials of :func:`cis64` on [-pi/2, pi/2] (measured at import)
PHASE_POLY_MAX_ERROR = _phase_poly_error()
_S0, _S1, _S2, _S3, _S4, _S5 = (float(c) for c in _SIN)
_C0, _C1, _C2, _C3, _C4, _C5, _C6 = (float(c) for c in _COS)


@numba.njit(fastmath=True, cache=True, inline="always")
def cis64(f):  # pragma: no cover - compiled
    """(cos, sin) of 2 pi f for f in [-1/2, 1/2] in float64: sin and cos of the half angle pi f from their
    polynomials (error ``PHASE_POLY_MAX_ERROR``), then the double-angle formulas."""
    xh = math.pi * f
    t = xh * xh
    sn = xh * (_S0 + t * (_S1 + t * (_S2 + t * (_S3 + t * (_S4 + t * _S5)))))
    cs = _C0 + t * (_C1 + t * (_C2 + t * (_C3 + t * (_C4 + t * (_C5 + t * _C6)))))
    return cs * cs - sn * sn, 2.0 * sn * cs


@numba.njit(fastmath=True, cache=True)
def _demod_kernel(values, r, two_over_lambda, out_re, out_im):  # pragma: no cover - compiled
    # serial: ~1 ns a point; a parallel region per subaperture cost more than the work on a loaded machine
    for i in range(values.size):
        cyc = r[i] * two_over_lambda
        c, s_ = cis64(-(cyc - np.floor(cyc + 0.5)))
        out_re[i] = values[i].real * c - values[i].imag * s_
        out_im[i] = values[i].real * s_ + values[i].imag * c


def demodulate_parts(values: np.ndarray, r: np.ndarray, lam: float):
    """(re, im) of ``values * exp(-j 4 pi r / lambda)`` (float64; the phase reduced to its fractional cycle in
    float64, then :func:`cis64`): FFBP's polar images are demodulated by their range from the subaperture centre."""
    out_re = np.empty(values.size)
    out_im = np.empty(values.size)
    _demod_kernel(np.ascontiguousarray(values.ravel()), np.ascontiguousarray(r.ravel()), 2.0 / lam, out_re, out_im)
    return out_re, out_im


def _fit_quarter_wave() -> tuple[np.ndarray, np.ndarray]:
    """Least-squares odd / even polynomials of sin(2 pi x), cos(2 pi x) on [0, 1/4] cycle (x and x^2 powers)."""
    x = 0.125 * (1.0 - np.cos(np.linspace(0.0, np.pi, 4001)))           # Chebyshev-spaced on [0, 1/4]
    s, *_ = np.linalg.lstsq(np.vander(x * x, 5, increasing=True) * x[:, None], np.sin(2 * np.pi * x), rcond=None)
    c, *_ = np.linalg.lstsq(np.vander(x * x, 6, increasing=True), np.cos(2 * np.pi * x), rcond=None)
    return s, c


_QS, _QC = _fit_quarter_wave()
_A1, _A3, _A5, _A7, _A9 = (np.float32(v) for v in _QS)
_B0, _B2, _B4, _B6, _B8, _B10 = (np.float32(v) for v in _QC)


@numba.njit(fastmath=True, cache=True, inline="always")
def cis32(f):  # pragma: no cover - compiled
    """(cos, sin) of 2 pi f for f in [-1/2, 1/2] in float32 (quarter-wave polynomials, max error
    ``PHASE_F32_MAX_ERROR``); (0, 0) for the out-of-window marker f = 2 (:func:`range_tap`)."""
    a = abs(f)
    big = a > np.float32(0.25)
    x = np.float32(0.5) - a if big else a                 # [0, 1/4]: cos(2 pi a) = -cos(2 pi (1/2 - a))
    x2 = x * x
    sp = x * (_A1 + x2 * (_A3 + x2 * (_A5 + x2 * (_A7 + x2 * _A9))))
    cp = _B0 + x2 * (_B2 + x2 * (_B4 + x2 * (_B6 + x2 * (_B8 + x2 * _B10))))
    m = np.float32(0.0) if a > np.float32(0.5) else np.float32(1.0)
    return (-cp if big else cp) * m, (-sp if f < np.float32(0.0) else sp) * m


def _cis_error() -> float:
    """Max |cis32(f) - exp(j 2 pi f)| over [-1/2, 1/2], evaluated in float32 as the kernel does."""
    f = np.linspace(-0.5, 0.5, 200001).astype(np.float32)
    a = np.abs(f)
    x = np.where(a > 0.25, np.float32(0.5) - a, a).astype(np.float32)
    x2 = x * x
    sp = x * (_A1 + x2 * (_A3 + x2 * (_A5 + x2 * (_A7 + x2 * _A9))))
    cp = _B0 + x2 * (_B2 + x2 * (_B4 + x2 * (_B6 + x2 * (_B8 + x2 * _B10))))
    val = np.where(a > 0.25, -cp, cp) + 1j * np.where(f < 0, -sp, sp)
    return float(np.max(np.abs(val - np.exp(2j * np.pi * f.astype(np.float64)))))


#: max abs error of the float32 phase factor of the back-projection kernels (measured at import, ~1e-7:
#: the float32 rounding of the factor itself)
PHASE_F32_MAX_ERROR = _cis_error()

# ---------------------------------------------------------------------------------------------
# range interpolation of padded complex64 pulses (back-projection)

#: zero samples added at each end of every pulse so that the cubic taps never leave the array
PAD = 2
#: the gather mode of each range interpolation ("upsample": linear on the upsampled pulses, "upsample-lagrange":
#: Lagrange on them)
GATHER_MODE = {"nearest": 0, "linear": 1, "cubic": 2, "upsample": 1, "lagrange": 3, "upsample-lagrange": 3}
#: the point kernel (:data:`KERNELS`) of each range interpolation, and those that FFT-upsample the pulses first
RANGE_KERNEL = {"nearest": "nearest", "linear": "linear", "cubic": "cubic", "lagrange": "lagrange",
                "upsample": "linear", "upsample-lagrange": "lagrange"}
UPSAMPLED = ("upsample", "upsample-lagrange")


@numba.njit(fastmath=True, cache=True, inline="always")
def range_tap(r, u_offset, inv_dr, u_max, shift, two_over_lambda):  # pragma: no cover - compiled
    """(padded sample index, weight, fractional cycle) of a pixel at range r, all from float64: the position
    of r on the sample lattice and f = frac(2 r / lambda) in [-1/2, 1/2) (exp(j 4 pi r / lambda) = exp(j 2 pi f));
    f = 2 marks a range outside the receive window [0, u_max] (no contribution, :func:`cis32`)."""
    u = r * inv_dr - u_offset
    valid = (u >= 0.0) & (u <= u_max)
    uc = min(max(u, 0.0), u_max) + (PAD + shift)
    # np.floor stays float64 and the index goes through int32 (uc < 2^31): math.floor returns an int64, and float64 ->
    # int64 does not vectorise without AVX-512 (AMD Zen 3: this pass took 2.7x as long); the values are the same
    fl = np.floor(uc)
    cyc = r * two_over_lambda
    f = cyc - np.floor(cyc + 0.5)    # exact in float64 (error ~1e-16 cycles per cycle of 2 r / lambda)
    # unsigned index: no negative-index wraparound test in the gathers
    return np.uint32(np.int32(fl)), np.float32(uc - fl), np.float32(f if valid else 2.0)


@numba.njit(fastmath=True, cache=True)
def gather(d, mode, n, idx, wgt, cph, sph, w4, acc_r, acc_i):  # pragma: no cover - compiled
    """acc += s(idx + wgt) * (cph + j sph) for one pulse's complex64 samples ``d`` (scalar gathers: re and im
    in one 8-byte load), interpolated as ``mode`` (:data:`GATHER_MODE`) says; float32 within a pulse block."""
    a = KEYS_A
    one = np.uint32(1)
    two = np.uint32(2)
    if mode == 0:
        for i in range(n):
            s0 = d[idx[i]]
            c = cph[i]
            s = sph[i]
            acc_r[i] += s0.real * c - s0.imag * s
            acc_i[i] += s0.real * s + s0.imag * c
    elif mode == 1:
        for i in range(n):
            j = idx[i]
            w = wgt[i]
            c = cph[i]
            s = sph[i]
            s0 = d[j]
            s1 = d[j + one]
            sr = s0.real + w * (s1.real - s0.real)
            si = s0.imag + w * (s1.imag - s0.imag)
            acc_r[i] += sr * c - si * s
            acc_i[i] += sr * s + si * c
    else:
        if mode == 2:
            for i in range(n):  # Keys kernel at distances 1+w, w, 1-w, 2-w (vectorised)
                w = wgt[i]
                x1 = np.float32(1.0) + w
                x2 = np.float32(1.0) - w
                x3 = np.float32(2.0) - w
                w4[0, i] = ((a * x1 - 5.0 * a) * x1 + 8.0 * a) * x1 - 4.0 * a
                w4[1, i] = ((a + 2.0) * w - (a + 3.0)) * w * w + 1.0
                w4[2, i] = ((a + 2.0) * x2 - (a + 3.0)) * x2 * x2 + 1.0
                w4[3, i] = ((a * x3 - 5.0 * a) * x3 + 8.0 * a) * x3 - 4.0 * a
        else:
            _lagrange_weights(wgt, n, w4, 0)
        for i in range(n):
            j = idx[i]
            sm = d[j - one]
            s0 = d[j]
            s1 = d[j + one]
            s2 = d[j + two]
            sr = w4[0, i] * sm.real + w4[1, i] * s0.real + w4[2, i] * s1.real + w4[3, i] * s2.real
            si = w4[0, i] * sm.imag + w4[1, i] * s0.imag + w4[2, i] * s1.imag + w4[3, i] * s2.imag
            c = cph[i]
            s = sph[i]
            acc_r[i] += sr * c - si * s
            acc_i[i] += sr * s + si * c


#: fast-math without reassociation: LLVM may reassociate the scalar remainder of a vectorised loop differently from
#: its vector body, so a pixel's weights (and the image) would depend on where the block's end falls (seen with a
#: freshly compiled kernel on numba 0.68.1: ``block=37`` against the default differed by 1e-6 on 5 % of the pixels)
_NO_REASSOC = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}


@numba.njit(fastmath=_NO_REASSOC, cache=True)
def _lagrange_weights(wgt, n, w, r0):  # pragma: no cover - compiled
    """Rows r0 .. r0 + 3 of w: the cubic Lagrange weights through the samples at -1, 0, 1, 2 for fractions wgt
    (vectorised; compiled on its own, not inlined by numba, so that its fast-math flags are its own)."""
    for i in range(n):
        x = wgt[i]
        xp = x + np.float32(1.0)
        xm = x - np.float32(1.0)
        x2 = x - np.float32(2.0)
        w[r0, i] = -x * xm * x2 * np.float32(1.0 / 6.0)
        w[r0 + 1, i] = xp * xm * x2 * np.float32(0.5)
        w[r0 + 2, i] = -xp * x * x2 * np.float32(0.5)
        w[r0 + 3, i] = xp * x * xm * np.float32(1.0 / 6.0)


@numba.njit(fastmath=True, cache=True)
def gather_pair_lagrange(d, e, n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, w8, acc_r, acc_i):  # pragma: no cover
    """:func:`gather` of two pulses with the Lagrange kernel (mode 3) in one pass over the pixels (weights of the
    first pulse in rows 0-3 of the (8, n) work array ``w8``, of the second in rows 4-7)."""
    _lagrange_weights(wgt, n, w8, 0)
    _lagrange_weights(wgt2, n, w8, 4)
    one = np.uint32(1)
    two = np.uint32(2)
    for i in range(n):
        j = idx[i]
        k = idx2[i]
        a0, a1, a2, a3 = d[j - one], d[j], d[j + one], d[j + two]
        b0, b1, b2, b3 = e[k - one], e[k], e[k + one], e[k + two]
        sr = w8[0, i] * a0.real + w8[1, i] * a1.real + w8[2, i] * a2.real + w8[3, i] * a3.real
        si = w8[0, i] * a0.imag + w8[1, i] * a1.imag + w8[2, i] * a2.imag + w8[3, i] * a3.imag
        tr = w8[4, i] * b0.real + w8[5, i] * b1.real + w8[6, i] * b2.real + w8[7, i] * b3.real
        ti = w8[4, i] * b0.imag + w8[5, i] * b1.imag + w8[6, i] * b2.imag + w8[7, i] * b3.imag
        c, s, c2, s2 = cph[i], sph[i], cph2[i], sph2[i]
        acc_r[i] += (sr * c - si * s) + (tr * c2 - ti * s2)
        acc_i[i] += (sr * s + si * c) + (tr * s2 + ti * c2)


@numba.njit(fastmath=True, cache=True)
def gather_pair(d, e, mode, n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, acc_r, acc_i):  # pragma: no cover
    """:func:`gather` of two pulses (samples d with idx, wgt, cph, sph; e with idx2, ...) in one pass over the
    pixels: one load and store of the accumulators per two pulses (nearest and linear)."""
    one = np.uint32(1)
    if mode == 0:
        for i in range(n):
            s0 = d[idx[i]]
            t0 = e[idx2[i]]
            c, s, c2, s2 = cph[i], sph[i], cph2[i], sph2[i]
            acc_r[i] += (s0.real * c - s0.imag * s) + (t0.real * c2 - t0.imag * s2)
            acc_i[i] += (s0.real * s + s0.imag * c) + (t0.real * s2 + t0.imag * c2)
    else:
        for i in range(n):
            j = idx[i]
            k = idx2[i]
            w = wgt[i]
            v = wgt2[i]
            s0 = d[j]
            s1 = d[j + one]
            t0 = e[k]
            t1 = e[k + one]
            sr = s0.real + w * (s1.real - s0.real)
            si = s0.imag + w * (s1.imag - s0.imag)
            tr = t0.real + v * (t1.real - t0.real)
            ti = t0.imag + v * (t1.imag - t0.imag)
            c, s, c2, s2 = cph[i], sph[i], cph2[i], sph2[i]
            acc_r[i] += (sr * c - si * s) + (tr * c2 - ti * s2)
            acc_i[i] += (sr * s + si * c) + (tr * s2 + ti * c2)


# ---------------------------------------------------------------------------------------------
# separable 2-D interpolation of a flat complex64 image from a kernel table (FFBP's polar images)

@numba.njit(fastmath=True, cache=True, inline="always")
def polar_tap(qx, qy, qz, ref_r, centre, v, r0, inv_dr, u0, inv_du, nr, nu, two_over_lambda,
              half):  # pragma: no cover - compiled
    """Where point q falls on a polar image (range r from ``centre``, direction cosine u against ``v``; samples r0 +
    i / inv_dr, u0 + j / inv_du, (nr, nu)), in float64: (flat index of its (2 half) x (2 half) kernel support, range
    and angle weights in [0, 1), fractional cycle of 2 (r(q) - ref_r) / lambda; 2 marks a point off the image):
    the tap positions of :func:`taps_2d`."""
    dx = qx - centre[0]
    dy = qy - centre[1]
    dz = qz - centre[2]
    r = math.sqrt(dx * dx + dy * dy + dz * dz)
    u = (dx * v[0] + dy * v[1] + dz * v[2]) / r
    fr = (r - r0) * inv_dr
    fu = (u - u0) * inv_du
    ir = np.floor(fr)      # float, and int32 below: vectorises without AVX-512 (:func:`range_tap`)
    iu = np.floor(fu)
    lo = half - 1.0
    valid = (ir >= lo) & (iu >= lo) & (ir <= nr - 1.0 - half) & (iu <= nu - 1.0 - half)
    irc = min(max(ir, lo), nr - 1.0 - half)
    iuc = min(max(iu, lo), nu - 1.0 - half)
    cyc = (r - ref_r) * two_over_lambda
    f = cyc - np.floor(cyc + 0.5)        # fractional cycle, exact in float64
    return (np.uint32(np.int32((irc - lo) * nu + (iuc - lo))), np.float32(fr - ir), np.float32(fu - iu),
            np.float32(f if valid else 2.0))


@numba.njit(fastmath=True, cache=True)
def taps_2d(img, nu, n, base, wr, wu, f, ktab, out_re, out_im, o0):  # pragma: no cover - compiled
    """out[o0 + i] += the N x N kernel interpolation of the flat complex64 image (rows of ``nu``) at base[i] (the
    support's first sample; weights: the rows of the kernel table ``ktab`` (F + 1, N) (:func:`tabulate`) nearest the
    fractions wr[i] along rows, wu[i] along columns), times exp(j 2 pi f[i]) (zero for the off-image marker f = 2);
    scalar gathers, the tap loops unrolled for the kernels' literal sizes."""
    nt = ktab.shape[1]
    if nt == 6:
        _taps_n(img, nu, n, base, wr, wu, f, ktab, 6, out_re, out_im, o0)
    elif nt == 4:
        _taps_n(img, nu, n, base, wr, wu, f, ktab, 4, out_re, out_im, o0)
    else:
        _taps_n(img, nu, n, base, wr, wu, f, ktab, nt, out_re, out_im, o0)


@numba.njit(fastmath=True, cache=True, inline="always")
def _taps_n(img, nu, n, base, wr, wu, f, ktab, nt, out_re, out_im, o0):  # pragma: no cover - compiled
    scale = np.float32(ktab.shape[0] - 1)
    for i in range(n):
        a = np.int64(wr[i] * scale + np.float32(0.5))
        c = np.int64(wu[i] * scale + np.float32(0.5))
        b = base[i]
        sr = np.float32(0.0)
        si = np.float32(0.0)
        for t in range(nt):
            row = b + np.uint32(t * nu)
            rr = np.float32(0.0)
            ri = np.float32(0.0)
            for k in range(nt):
                p = img[row + np.uint32(k)]
                rr += ktab[c, k] * p.real
                ri += ktab[c, k] * p.imag
            sr += ktab[a, t] * rr
            si += ktab[a, t] * ri
        cs, sn = cis32(f[i])
        out_re[o0 + i] += sr * cs - si * sn
        out_im[o0 + i] += sr * sn + si * cs


@numba.njit(fastmath=True, cache=True, inline="always")
def taps_down(flat, cnu, base, w, cs, sn, ktab, nt, scale, jre, jim):  # pragma: no cover - compiled
    """jre[k] + j jim[k] = the nt-tap interpolation of the flat complex64 image ``flat`` (rows of ``cnu``) down a column
    from the flat index base[k] (fraction w[k]: the nearest row of the kernel table ``ktab``, ``scale`` = its rows - 1)
    times (cs[k] + j sn[k]): pass 1 of FFBP's two-pass merge (``ffbp_merge``)."""
    for k in range(base.size):
        t0 = np.int64(w[k] * scale + np.float32(0.5))
        sr = np.float32(0.0)
        si = np.float32(0.0)
        for t in range(nt):
            p = flat[base[k] + t * cnu]
            sr += ktab[t0, t] * p.real
            si += ktab[t0, t] * p.imag
        jre[k] = sr * cs[k] - si * sn[k]
        jim[k] = sr * sn[k] + si * cs[k]


@numba.njit(fastmath=True, cache=True, inline="always")
def taps_along(jre, jim, base, w, cs, sn, ktab, nt, scale, are, aim):  # pragma: no cover - compiled
    """are[j] + j aim[j] = the nt-tap interpolation of the row (jre, jim) from base[j] (fraction w[j]) times
    (cs[j] + j sn[j]): pass 2 of FFBP's two-pass merge (``ffbp_merge``)."""
    for j in range(base.size):
        t0 = np.int64(w[j] * scale + np.float32(0.5))
        sr = np.float32(0.0)
        si = np.float32(0.0)
        for t in range(nt):
            sr += ktab[t0, t] * jre[base[j] + t]
            si += ktab[t0, t] * jim[base[j] + t]
        are[j] = sr * cs[j] - si * sn[j]
        aim[j] = sr * sn[j] + si * cs[j]
