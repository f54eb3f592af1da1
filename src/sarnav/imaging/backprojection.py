"""Time-domain back-projection (BPA) onto any pixel grid, compiled, with float64 geometry.

For each pixel p and pulse k (Lindstrom 2020 thesis (4.26)–(4.28); notes/seed-000 §8)::

    A(p) = sum_k  s_k( R_k(p) ) * exp(+j 4 pi R_k(p) / lambda),    R_k(p) = || p - a_k ||

with ``s_k`` the range-compressed pulse k (baseband, a target at range R peaks at R with phase
``-4 pi R / lambda``, docs/conventions.md), ``a_k`` the antenna positions the processor believes
(``rc.positions`` or the ``positions`` argument: an image formed with an estimated trajectory) and
lambda the wavelength at the centre frequency (thesis L903).

Range interpolation of ``s_k`` at the fractional sample ``u = (R - r_0)/dr`` (thesis gap: not
specified) — ``interpolation=``:

* ``"nearest"``: the closest sample;
* ``"linear"``: two-tap linear;
* ``"cubic"``: four-tap Keys cubic convolution (a = -1/2, Keys 1981);
* ``"upsample"``: band-limited FFT zero-padding of every pulse by ``upsample`` (default 4) and then
  linear interpolation on the finer grid.

docs/backprojection.md gives the measured accuracy of each against exact band-limited (sinc)
interpolation. Samples outside the receive window are zero: a pixel whose range falls outside
``[slant_range[0], slant_range[-1]]`` for a pulse receives nothing from that pulse.

Implementation (docs/backprojection.md "Speed"): numba ``prange`` over blocks of contiguous pixels
(row segments of plane grids: ``GroundGrid``, ``SlantGrid``, ``PlaneGrid``, where the squared range
along a row is an exact quadratic in the column index, so no pixel coordinates are read); per pulse
a vectorised float64 pass computes the range (one square root), the sample index and weight and the
fractional cycle ``f`` of ``2R/lambda``; a vectorised float32 pass turns f into exp(j 2 pi f); a
scalar pass gathers the complex64 samples (two pulses per pass for nearest and linear) and
accumulates in float32 over ``pulse_block`` pulses, each partial sum added to the float64 image.
Geometry is float64: ``f`` is reduced to [-1/2, 1/2) in float64 (error ~1e-16 * 2R/lambda cycles,
1e-11 for R = 2 km at X band) before it is rounded to float32; exp(j 2 pi f) comes from quarter-wave
polynomials in float32 (max error ``PHASE_F32_MAX_ERROR`` ~2e-7, the float32 rounding of the factor),
no transcendental call, so LLVM vectorises it without SVML.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import scipy.fft as sfft

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData, SarImage
from sarnav.imaging.grid import GroundGrid, PlaneGrid, SlantGrid, as_grid
from sarnav.imaging.interpolation_error import interpolation_error

__all__ = ["backproject", "backproject_numpy", "backproject_points", "resolve_interpolation", "data_oversampling",
           "plane_of", "PHASE_F32_MAX_ERROR",
           "INTERPOLATIONS", "PHASE_POLY_MAX_ERROR", "AUTO_MAX_ERROR"]

INTERPOLATIONS = ("nearest", "linear", "cubic", "upsample", "auto")
#: "auto" picks the cheapest of linear / upsample x2..x16 whose predicted error (flat band, linear
#: kernel at fs/B * factor, sarnav.imaging.interpolation_error) is at most this (-35 dB)
AUTO_MAX_ERROR = 10.0 ** -3.5
_MODE = {"nearest": 0, "linear": 1, "cubic": 2, "upsample": 1}
#: zero samples added at each end of every pulse so that the cubic taps never leave the array
_PAD = 2
#: pixels per parallel work item (a block of contiguous pixels: the row stays in L1 cache)
DEFAULT_BLOCK = 512
#: pulses per pass over the image (their samples stay in the L2 cache)
DEFAULT_PULSE_BLOCK = 128
#: Keys (1981) cubic-convolution parameter
_KEYS_A = -0.5


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


#: max abs error of the sin/cos polynomials on [-pi/2, pi/2] (measured at import)
PHASE_POLY_MAX_ERROR = _phase_poly_error()
_S0, _S1, _S2, _S3, _S4, _S5 = (float(c) for c in _SIN)
_C0, _C1, _C2, _C3, _C4, _C5, _C6 = (float(c) for c in _COS)


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
def _index_at(r, u_offset, inv_dr, u_max, shift, two_over_lambda):  # pragma: no cover - compiled
    """(padded sample index, weight, fractional cycle) of a pixel at range r, all from float64: the position
    of r on the sample lattice and f = frac(2 r / lambda) in [-1/2, 1/2) (exp(j 4 pi r / lambda) = exp(j 2 pi f));
    f = 2 marks a range outside the receive window [0, u_max] (no contribution, ``_cis``)."""
    u = r * inv_dr - u_offset
    valid = (u >= 0.0) & (u <= u_max)
    uc = min(max(u, 0.0), u_max) + (_PAD + shift)
    fl = math.floor(uc)
    cyc = r * two_over_lambda
    f = cyc - math.floor(cyc + 0.5)    # exact in float64 (error ~1e-16 cycles per cycle of 2 r / lambda)
    # unsigned index: no negative-index wraparound test in the gathers
    return np.uint32(fl), np.float32(uc - fl), np.float32(f if valid else 2.0)


@numba.njit(fastmath=True, cache=True, inline="always")
def _cis(f):  # pragma: no cover - compiled
    """(cos, sin) of 2 pi f for f in [-1/2, 1/2] in float32 (quarter-wave polynomials, max error
    ``PHASE_F32_MAX_ERROR``); (0, 0) for the out-of-window marker f = 2."""
    a = abs(f)
    big = a > np.float32(0.25)
    x = np.float32(0.5) - a if big else a                 # [0, 1/4]: cos(2 pi a) = -cos(2 pi (1/2 - a))
    x2 = x * x
    sp = x * (_A1 + x2 * (_A3 + x2 * (_A5 + x2 * (_A7 + x2 * _A9))))
    cp = _B0 + x2 * (_B2 + x2 * (_B4 + x2 * (_B6 + x2 * (_B8 + x2 * _B10))))
    m = np.float32(0.0) if a > np.float32(0.5) else np.float32(1.0)
    return (-cp if big else cp) * m, (-sp if f < np.float32(0.0) else sp) * m


def _cis_error() -> float:
    """Max |_cis(f) - exp(j 2 pi f)| over [-1/2, 1/2], evaluated in float32 as the kernel does."""
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


@numba.njit(fastmath=True, cache=True, inline="always")
def _gather(d, mode, n, idx, wgt, cph, sph, w4, acc_r, acc_i):  # pragma: no cover - compiled
    """acc += s(idx + wgt) * (cph + j sph) for one pulse's complex64 samples ``d`` (scalar gathers: re and im
    in one 8-byte load), interpolated as ``mode`` says; float32 within a pulse block."""
    a = _KEYS_A
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
        for i in range(n):  # Keys kernel at distances 1+w, w, 1-w, 2-w (vectorised)
            w = wgt[i]
            x1 = np.float32(1.0) + w
            x2 = np.float32(1.0) - w
            x3 = np.float32(2.0) - w
            w4[0, i] = ((a * x1 - 5.0 * a) * x1 + 8.0 * a) * x1 - 4.0 * a
            w4[1, i] = ((a + 2.0) * w - (a + 3.0)) * w * w + 1.0
            w4[2, i] = ((a + 2.0) * x2 - (a + 3.0)) * x2 * x2 + 1.0
            w4[3, i] = ((a * x3 - 5.0 * a) * x3 + 8.0 * a) * x3 - 4.0 * a
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


@numba.njit(fastmath=True, cache=True, inline="always")
def _gather_pair(d, e, mode, n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, acc_r, acc_i):  # pragma: no cover
    """``_gather`` of two pulses (samples d with idx, wgt, cph, sph; e with idx2, ...) in one pass over the
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


@numba.njit(fastmath=True, cache=True, inline="always")
def _pass_points(px, py, pz, i0, n, ant, k, u_offset, inv_dr, u_max, shift, two_over_lambda, idx, wgt, cph,
                 sph):  # pragma: no cover - compiled
    """Pass 1 of pulse k at the points i0 .. i0 + n - 1: float64 range and ``_index_at``, float32 ``_cis``."""
    ax = ant[k, 0]
    ay = ant[k, 1]
    az = ant[k, 2]
    for i in range(n):
        dx = px[i0 + i] - ax
        dy = py[i0 + i] - ay
        dz = pz[i0 + i] - az
        idx[i], wgt[i], cph[i] = _index_at(math.sqrt(dx * dx + dy * dy + dz * dz), u_offset, inv_dr, u_max, shift,
                                           two_over_lambda)
    for i in range(n):
        cph[i], sph[i] = _cis(cph[i])


@numba.njit(fastmath=True, cache=True, inline="always")
def _pass_row(rx, ry, rz, e_col, e2, jf, n, ant, k, u_offset, inv_dr, u_max, shift, two_over_lambda, idx, wgt,
              cph, sph):  # pragma: no cover - compiled
    """Pass 1 of pulse k along a grid row from (rx, ry, rz): R^2 = |w|^2 + j (2 w.e_col + j |e_col|^2)."""
    wx = rx - ant[k, 0]
    wy = ry - ant[k, 1]
    wz = rz - ant[k, 2]
    w2 = wx * wx + wy * wy + wz * wz
    beta = 2.0 * (wx * e_col[0] + wy * e_col[1] + wz * e_col[2])
    for i in range(n):
        q = jf[i]
        idx[i], wgt[i], cph[i] = _index_at(math.sqrt(w2 + q * (beta + q * e2)), u_offset, inv_dr, u_max, shift,
                                           two_over_lambda)
    for i in range(n):
        cph[i], sph[i] = _cis(cph[i])


@numba.njit(parallel=True, fastmath=True, cache=True)
def _bpa_kernel(px, py, pz, ant, data, u_offset, inv_dr, u_max, two_over_lambda, mode, block,
                pulse_block, out_re, out_im):  # pragma: no cover - compiled
    """Accumulate sum_k s_k(R) exp(j 4 pi R / lambda) at arbitrary points into out_re/out_im (float64).

    data: (P, N + 2 PAD) complex64 zero-padded samples; u = R * inv_dr - u_offset is the unpadded
    fractional sample index, valid in [0, u_max]. Pulses are processed in groups of ``pulse_block``
    (their samples stay in L2 cache) summed in float32, each group's sum added to the float64
    output; pixels in parallel blocks of ``block``. Per pulse: a vectorised float64 pass (range, sample
    index and weight, fractional cycle: ``_index_at``), a vectorised float32 pass (phase factor: ``_cis``,
    16 lanes on AVX-512), a scalar pass of gathers (``_gather``; two pulses at a time for nearest and
    linear, ``_gather_pair``).
    """
    m_total = px.size
    n_pulses = ant.shape[0]
    n_blocks = (m_total + block - 1) // block
    shift = 0.5 if mode == 0 else 0.0
    for k_start in range(0, n_pulses, pulse_block):
        k_stop = min(n_pulses, k_start + pulse_block)
        for blk in numba.prange(n_blocks):
            i0 = blk * block
            n = min(m_total, i0 + block) - i0
            acc_r = np.zeros(n, np.float32)
            acc_i = np.zeros(n, np.float32)
            idx, idx2 = np.empty(n, np.uint32), np.empty(n, np.uint32)
            wgt, wgt2 = np.empty(n, np.float32), np.empty(n, np.float32)
            cph, cph2 = np.empty(n, np.float32), np.empty(n, np.float32)
            sph, sph2 = np.empty(n, np.float32), np.empty(n, np.float32)
            w4 = np.empty((4, n), np.float32)
            k = k_start
            while k < k_stop:
                _pass_points(px, py, pz, i0, n, ant, k, u_offset, inv_dr, u_max, shift, two_over_lambda, idx, wgt,
                             cph, sph)
                if mode != 2 and k + 1 < k_stop:
                    _pass_points(px, py, pz, i0, n, ant, k + 1, u_offset, inv_dr, u_max, shift, two_over_lambda,
                                 idx2, wgt2, cph2, sph2)
                    _gather_pair(data[k], data[k + 1], mode, n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, acc_r,
                                 acc_i)
                    k += 2
                else:
                    _gather(data[k], mode, n, idx, wgt, cph, sph, w4, acc_r, acc_i)
                    k += 1
            for i in range(n):
                out_re[i0 + i] += acc_r[i]
                out_im[i0 + i] += acc_i[i]


@numba.njit(fastmath=True, cache=True)
def _row_origins(origin, e_row, ny):  # pragma: no cover - compiled
    """origin + i e_row (ny, 3): a plane grid's rows as the lines of ``_bpa_fan_kernel`` (compiled like the kernels,
    so the rows' float64 coordinates round as they did inside the former plane kernel)."""
    out = np.empty((ny, 3))
    for i in range(ny):
        out[i, 0] = origin[0] + i * e_row[0]
        out[i, 1] = origin[1] + i * e_row[1]
        out[i, 2] = origin[2] + i * e_row[2]
    return out


@numba.njit(parallel=True, fastmath=True, cache=True)
def _bpa_fan_kernel(origins, e_cols, nx, ant, data, u_offset, inv_dr, u_max, two_over_lambda, mode, block,
                    pulse_block, out_re, out_im):  # pragma: no cover - compiled
    """As ``_bpa_kernel`` for rows of points on straight lines, ``origins[i] + j e_cols[i]`` (j < nx), row-major out.

    Along row i the squared range is exactly quadratic in j: R^2 = |w|^2 + j (2 w.e_col + j |e_col|^2),
    w = origins[i] - a_k (float64), so a point costs one multiply-add pair and a square root instead of its three
    coordinates; work items are row segments of ``block`` points (the recurrence starts at j = 0 of the row, so the
    result does not depend on ``block``). A plane grid's rows (``origins[i] = origin + i e_row``) and a polar grid's
    lines of constant direction from a subaperture centre (``imaging.ffbp`` level 0) are both such rows."""
    ny = origins.shape[0]
    n_seg = (nx + block - 1) // block
    n_pulses = ant.shape[0]
    shift = 0.5 if mode == 0 else 0.0
    for k_start in range(0, n_pulses, pulse_block):
        k_stop = min(n_pulses, k_start + pulse_block)
        for item in numba.prange(ny * n_seg):
            row = item // n_seg
            j0 = (item % n_seg) * block
            n = min(nx, j0 + block) - j0
            acc_r = np.zeros(n, np.float32)
            acc_i = np.zeros(n, np.float32)
            idx, idx2 = np.empty(n, np.uint32), np.empty(n, np.uint32)
            wgt, wgt2 = np.empty(n, np.float32), np.empty(n, np.float32)
            cph, cph2 = np.empty(n, np.float32), np.empty(n, np.float32)
            sph, sph2 = np.empty(n, np.float32), np.empty(n, np.float32)
            w4 = np.empty((4, n), np.float32)
            jf = np.empty(n)
            for i in range(n):
                jf[i] = j0 + i
            e_col = e_cols[row]
            e2 = e_col[0] * e_col[0] + e_col[1] * e_col[1] + e_col[2] * e_col[2]
            rx, ry, rz = origins[row, 0], origins[row, 1], origins[row, 2]
            k = k_start
            while k < k_stop:
                _pass_row(rx, ry, rz, e_col, e2, jf, n, ant, k, u_offset, inv_dr, u_max, shift, two_over_lambda, idx,
                          wgt, cph, sph)
                if mode != 2 and k + 1 < k_stop:
                    _pass_row(rx, ry, rz, e_col, e2, jf, n, ant, k + 1, u_offset, inv_dr, u_max, shift,
                              two_over_lambda, idx2, wgt2, cph2, sph2)
                    _gather_pair(data[k], data[k + 1], mode, n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, acc_r,
                                 acc_i)
                    k += 2
                else:
                    _gather(data[k], mode, n, idx, wgt, cph, sph, w4, acc_r, acc_i)
                    k += 1
            base = row * nx + j0
            for i in range(n):
                out_re[base + i] += acc_r[i]
                out_im[base + i] += acc_i[i]


# ---------------------------------------------------------------------------------------------
# input checking and preparation (shared by the compiled and the numpy implementation)

def _wavelength(rc: PulseData, wavelength) -> float:
    if wavelength is None:
        wavelength = rc.carrier_wavelength
        if wavelength is None:
            raise ConfigError("wavelength", "not given, and rc carries no wavelength; "
                              "pass wavelength= [m] > 0")
    lam = float(wavelength)
    if not math.isfinite(lam) or lam <= 0:
        raise ConfigError("wavelength", f"must be finite and > 0 m, got {wavelength!r}")
    return lam


def _check_pulses(rc: PulseData, positions):
    if not isinstance(rc, PulseData):
        raise InputDataError("rc", f"must be a PulseData, got {type(rc).__name__}")
    if not rc.compressed:
        raise InputDataError("rc", "must be range-compressed (compressed=True); run range_compress first")
    data = np.asarray(rc.data)
    if data.ndim != 2 or data.shape[0] < 1 or data.shape[1] < 2:
        raise InputDataError("rc.data", f"must be (P, N) with P >= 1 pulses and N >= 2 samples, got {data.shape}")
    if not np.all(np.isfinite(data)):
        raise InputDataError("rc.data", "must be finite (found NaN/inf)")
    rng = np.asarray(rc.slant_range, dtype=np.float64)
    if rng.shape != (data.shape[1],):
        raise InputDataError("rc.slant_range", f"must have shape ({data.shape[1]},), got {rng.shape}")
    if not np.all(np.isfinite(rng)):
        raise InputDataError("rc.slant_range", "must be finite (found NaN/inf)")
    d = np.diff(rng)
    if not (d[0] > 0 and np.allclose(d, d[0], rtol=1e-9, atol=0.0)):
        raise InputDataError("rc.slant_range", "must be strictly increasing and uniformly spaced")
    name = "rc.positions" if positions is None else "positions"
    pos = np.asarray(rc.positions if positions is None else positions, dtype=np.float64)
    if pos.shape != (data.shape[0], 3):
        raise InputDataError(name, f"must have shape ({data.shape[0]}, 3) (one position per pulse), got {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise InputDataError(name, "must be finite (found NaN/inf)")
    return data, rng, pos


def _upsample_pulses(data: np.ndarray, rng: np.ndarray, factor: int, dtype=np.complex128):
    """Band-limited interpolation of every pulse by FFT zero-padding: (P, (N-1)*factor + 1) samples
    on the range axis ``rng[0] + i dr / factor`` (the wrapped tail beyond the last sample dropped).
    ``dtype`` complex64: FFTs in single precision (the compiled kernels keep complex64 samples anyway;
    rounding ~1e-7 of the samples, -130 dB), complex128 for the float64 reference."""
    n = data.shape[1]
    workers = max(1, numba.get_num_threads())          # the FFTs use the kernel's threads
    spec = sfft.fft(np.asarray(data, dtype=dtype), axis=1, workers=workers)
    fine = np.zeros((data.shape[0], n * factor), dtype=dtype)
    h = (n + 1) // 2                      # non-negative frequencies 0 .. h-1
    fine[:, :h] = spec[:, :h]
    fine[:, n * factor - (n - h):] = spec[:, h:]
    if n % 2 == 0:                        # split the Nyquist bin symmetrically
        nyq = spec[:, n // 2]
        fine[:, n // 2] = 0.5 * nyq
        fine[:, n * factor - n // 2] = 0.5 * nyq
    out = sfft.ifft(fine, axis=1, workers=workers, overwrite_x=True)
    out *= factor
    m = (n - 1) * factor + 1
    dr = (rng[1] - rng[0]) / factor
    return out[:, :m], rng[0] + np.arange(m) * dr


def data_oversampling(rc: PulseData, bandwidth: float | None = None) -> float:
    """fs / B of range-compressed pulses: fs = c / (2 dr); B = ``bandwidth``, else ``rc.bandwidth``,
    else the width of the pulses' mean power spectrum above 1 % of its peak (>= 1 bin)."""
    rng = np.asarray(rc.slant_range, dtype=np.float64)
    if np.ndim(rc.data) != 2 or np.shape(rc.data)[1] < 2 or rng.ndim != 1 or rng.size < 2 or not rng[1] > rng[0]:
        return 1.0                     # malformed: the input checks that follow name the problem
    fs = 299792458.0 / (2.0 * float(rng[1] - rng[0]))
    bw = bandwidth if bandwidth is not None else rc.bandwidth
    if bw is None:
        data = np.asarray(rc.data)
        sel = data[:: max(1, data.shape[0] // 64)]
        spec = np.mean(np.abs(sfft.fft(sel, axis=1)) ** 2, axis=0)
        bw = fs * max(1, int(np.count_nonzero(spec >= 1e-2 * spec.max()))) / spec.size
    bw = float(bw)
    if not (math.isfinite(bw) and bw > 0):
        raise ConfigError("bandwidth", f"must be finite and > 0 Hz, got {bandwidth!r}")
    return max(1.0, fs / bw)


def resolve_interpolation(rc: PulseData, interpolation: str, upsample: int, bandwidth: float | None = None):
    """(mode, upsample) actually used: "auto" -> "linear" when the data are oversampled enough
    (fs/B >~ 5.6), else "upsample" with the smallest factor 2, 4, 8, 16 meeting ``AUTO_MAX_ERROR``."""
    if interpolation != "auto":
        return interpolation, upsample
    os_ = data_oversampling(rc, bandwidth)
    if interpolation_error("linear", os_) <= AUTO_MAX_ERROR:
        return "linear", upsample
    for factor in (2, 4, 8, 16):
        if interpolation_error("linear", os_ * factor) <= AUTO_MAX_ERROR:
            return "upsample", factor
    return "upsample", 16


def _check_interpolation(interpolation: str, upsample: int) -> int:
    if interpolation not in INTERPOLATIONS:
        raise ConfigError("interpolation", f"must be one of {INTERPOLATIONS}, got {interpolation!r}")
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)) or not 2 <= upsample <= 64:
        raise ConfigError("upsample", f"must be an integer in [2, 64], got {upsample!r}")
    return int(upsample)


def _prepare(rc, positions, interpolation, upsample, wavelength, dtype=np.complex128):
    upsample = _check_interpolation(interpolation, upsample)
    data, rng, pos = _check_pulses(rc, positions)
    lam = _wavelength(rc, wavelength)
    if interpolation == "upsample":
        data, rng = _upsample_pulses(data, rng, upsample, dtype)
    return data, rng, pos, lam


def _points(grid) -> tuple[object, np.ndarray]:
    g = as_grid(grid)
    pts = np.asarray(g.points(), dtype=np.float64)
    if not np.all(np.isfinite(pts)):
        raise InputDataError("grid", "pixel positions must be finite (found NaN/inf)")
    return g, pts


def _image(g, values: np.ndarray, rc: PulseData, lam: float, interpolation: str, upsample: int,
           algorithm: str) -> SarImage:
    y, x, y_name, x_name = g.axes()
    meta = {"algorithm": algorithm, "wavelength": lam, "interpolation": interpolation,
            "n_pulses": int(rc.n_pulses)}
    if interpolation == "upsample":
        meta["upsample"] = int(upsample)
    meta.update(g.metadata())
    return SarImage(values, np.asarray(y, dtype=np.float64), np.asarray(x, dtype=np.float64), y_name, x_name, meta)


# ---------------------------------------------------------------------------------------------
# public API

def backproject_points(rc: PulseData, points, positions=None, interpolation: str = "auto", *,
                       wavelength: float | None = None, upsample: int = 4, block: int = DEFAULT_BLOCK,
                       pulse_block: int = DEFAULT_PULSE_BLOCK, bandwidth: float | None = None) -> np.ndarray:
    """Back-project onto arbitrary points; returns complex128 values of shape ``points.shape[:-1]``.

    Same arguments as :func:`backproject` with ``points`` an ``(..., 3)`` float64 array [m] in the
    frame of the antenna positions.
    """
    _check_interpolation(interpolation, upsample)
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth)
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim < 1 or pts.shape[-1] != 3:
        raise InputDataError("points", f"must have shape (..., 3), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InputDataError("points", "must be finite (found NaN/inf)")
    _check_blocks(block, pulse_block)
    out_re, out_im = _form(rc, positions, interpolation, upsample, wavelength, block, pulse_block, pts.reshape(-1, 3))
    return (out_re + 1j * out_im).reshape(pts.shape[:-1])


def backproject_fan(rc: PulseData, origins, steps, n: int, positions=None, interpolation: str = "auto", *,
                    wavelength: float | None = None, upsample: int = 4, block: int = DEFAULT_BLOCK,
                    pulse_block: int = DEFAULT_PULSE_BLOCK, bandwidth: float | None = None) -> np.ndarray:
    """Back-project onto points on straight lines, ``origins[i] + j steps[i]`` (j < n): (L, n) complex128.

    The lines of a polar grid (constant direction from a subaperture centre, ``imaging.ffbp``): the range along a
    line is exactly quadratic in j, so the cost per point-pulse is that of a plane grid (``_bpa_fan_kernel``).
    The same sums as :func:`backproject_points` at those points (to float32 accumulation order).
    """
    _check_interpolation(interpolation, upsample)
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth)
    origins = np.asarray(origins, dtype=np.float64)
    steps = np.asarray(steps, dtype=np.float64)
    if origins.ndim != 2 or origins.shape[-1] != 3 or steps.shape != origins.shape:
        raise InputDataError("origins", f"origins and steps must both have shape (L, 3), got {origins.shape}, {steps.shape}")
    if not (np.all(np.isfinite(origins)) and np.all(np.isfinite(steps))):
        raise InputDataError("origins", "must be finite (found NaN/inf)")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputDataError("n", f"must be an integer >= 1 (points per line), got {n!r}")
    _check_blocks(block, pulse_block)
    out_re, out_im = _form(rc, positions, interpolation, upsample, wavelength, block, pulse_block,
                           fan=(origins, steps, int(n)))
    return (out_re + 1j * out_im).reshape(origins.shape[0], int(n))


def _check_blocks(block, pulse_block) -> None:
    for name, value in (("block", block), ("pulse_block", pulse_block)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ConfigError(name, f"must be an integer >= 1, got {value!r}")


def _form(rc, positions, interpolation, upsample, wavelength, block, pulse_block, flat=None, plane=None, fan=None):
    """(re, im) float64 of the compiled back-projection at ``flat`` (M, 3) points, on ``plane``
    (origin, e_row, e_col, ny, nx: pixels origin + i e_row + j e_col, row-major) or on ``fan`` (origins (ny, 3),
    e_cols (ny, 3), nx: points origins[i] + j e_cols[i], row-major)."""
    data, rng, pos, lam = _prepare(rc, positions, interpolation, upsample, wavelength, np.complex64)
    n = data.shape[1]
    padded = np.zeros((data.shape[0], n + 2 * _PAD), dtype=np.complex64)
    padded[:, _PAD:_PAD + n] = data
    dr = float(rng[1] - rng[0])
    pos = np.ascontiguousarray(pos)
    common = (float(rng[0]) / dr, 1.0 / dr, float(n - 1), 2.0 / lam, _MODE[interpolation], int(block), int(pulse_block))
    if fan is not None:
        origins, e_cols, nx = fan
        out_re = np.zeros(origins.shape[0] * nx)
        out_im = np.zeros(origins.shape[0] * nx)
        _bpa_fan_kernel(np.ascontiguousarray(origins, dtype=np.float64), np.ascontiguousarray(e_cols, dtype=np.float64),
                        int(nx), pos, padded, *common, out_re, out_im)
    elif plane is None:
        out_re = np.zeros(flat.shape[0])
        out_im = np.zeros(flat.shape[0])
        _bpa_kernel(np.ascontiguousarray(flat[:, 0]), np.ascontiguousarray(flat[:, 1]), np.ascontiguousarray(flat[:, 2]),
                    pos, padded, *common, out_re, out_im)
    else:
        origin, e_row, e_col, ny, nx = plane
        # row segments along the axis of slower range change (the along-track one): neighbouring pixels then read
        # neighbouring samples (cache); the result is the same sum either way
        centre = origin + 0.5 * (ny - 1) * e_row + 0.5 * (nx - 1) * e_col
        los = centre - pos[pos.shape[0] // 2]
        swap = abs(np.dot(e_col, los)) / np.linalg.norm(e_col) > abs(np.dot(e_row, los)) / np.linalg.norm(e_row)
        if swap:
            e_row, e_col, ny, nx = e_col, e_row, nx, ny
        out_re = np.zeros(ny * nx)
        out_im = np.zeros(ny * nx)
        _bpa_fan_kernel(_row_origins(origin, e_row, ny), np.ascontiguousarray(np.broadcast_to(e_col, (ny, 3))),
                        int(nx), pos, padded, *common, out_re, out_im)
        if swap:
            out_re = np.ascontiguousarray(out_re.reshape(ny, nx).T).ravel()
            out_im = np.ascontiguousarray(out_im.reshape(ny, nx).T).ravel()
    return out_re, out_im


#: largest deviation [m] of a grid axis from its arithmetic progression for the plane kernel (phase 4e-7 rad at
#: X band); grids made by regular_axis deviate by ~1e-13 m
_PLANE_TOLERANCE = 1e-9


def _uniform(axis) -> tuple[float, float] | None:
    a = np.asarray(axis, dtype=np.float64)
    step = (a[-1] - a[0]) / (a.size - 1)
    if np.max(np.abs(a - (a[0] + step * np.arange(a.size)))) > _PLANE_TOLERANCE:
        return None
    return float(a[0]), float(step)


def plane_of(grid):
    """(origin, e_row, e_col, ny, nx) when the pixels of ``grid`` are exactly ``origin + i e_row + j e_col``
    (``GroundGrid``, ``SlantGrid``, ``PlaneGrid`` with uniform axes), else None (any other points)."""
    if isinstance(grid, GroundGrid):
        frame = (np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), grid.north, grid.east)
        offset = np.array([0.0, 0.0, float(grid.down)])
    elif isinstance(grid, SlantGrid):
        frame = (grid.origin, grid.direction, grid.normal_in_plane, grid.along_track, grid.slant_range)
        offset = np.zeros(3)
    elif isinstance(grid, PlaneGrid):
        frame = (grid.origin, grid.row_direction, grid.col_direction, grid.rows, grid.cols)
        offset = np.zeros(3)
    else:
        return None
    o, a, b, rows, cols = frame
    ur, uc = _uniform(rows), _uniform(cols)
    if ur is None or uc is None:
        return None
    origin = np.asarray(o, dtype=np.float64) + offset + ur[0] * a + uc[0] * b
    return origin, ur[1] * np.asarray(a, dtype=np.float64), uc[1] * np.asarray(b, dtype=np.float64), rows.size, cols.size


def backproject(rc: PulseData, grid, positions=None, interpolation: str = "auto", *,
                wavelength: float | None = None, upsample: int = 4, block: int = DEFAULT_BLOCK,
                pulse_block: int = DEFAULT_PULSE_BLOCK, bandwidth: float | None = None) -> SarImage:
    """Form a SAR image by time-domain back-projection (thesis (4.27)), compiled and parallel.

    Parameters
    ----------
    rc : range-compressed pulses (``PulseData`` with ``compressed=True``), uniform ``slant_range``.
    grid : a grid from :mod:`sarnav.imaging.grid` (``GroundGrid``, ``SlantGrid``, ``PointGrid``) or an
        ``(Ny, Nx, 3)`` / ``(M, 3)`` float64 array of pixel positions (NED, m).
    positions : (P, 3) antenna positions used for focusing (NED, m); default ``rc.positions``. Pass
        the navigation estimate to form the image the navigation system would see.
    interpolation : "auto" (default), "nearest", "linear", "cubic" (Keys) or "upsample" (FFT
        ×``upsample`` then linear). "auto" chooses from the data's oversampling fs/B
        (:func:`resolve_interpolation`): linear when its predicted error is <= -35 dB (fs/B >~ 5.6),
        else upsample ×2/4/8/16 (fs/B = 1.2 -> ×4, error ~ -35 dB); docs/backprojection.md gives
        each mode's error.
    bandwidth : signal bandwidth B [Hz] for "auto"; default ``rc.bandwidth`` or estimated
        from the pulses' power spectrum.
    wavelength : carrier wavelength [m]; default ``rc.carrier_wavelength`` (``rc.wavelength``, else
        None): a ``PulseData`` needs no ``RadarParams`` to be back-projected.
    upsample : FFT oversampling factor for ``interpolation="upsample"`` (integer in [2, 64]).
    block : pixels per parallel work item (tuning only; the result does not depend on it).
    pulse_block : pulses per pass over the image (tuning only; changes only the float64 summation
        order). Results are deterministic and do not depend on the number of threads.

    Returns
    -------
    SarImage
        complex128 ``(Ny, Nx)`` image with the grid's axes; metadata: algorithm, wavelength,
        interpolation, n_pulses and the grid description.

    Raises
    ------
    InputDataError
        for a malformed ``rc`` (not compressed, bad shapes, NaN), ``positions`` or grid.
    ConfigError
        for an unknown ``interpolation`` or a bad ``upsample`` / ``wavelength`` / ``block``.
    """
    g = as_grid(grid)
    plane = plane_of(g)                     # plane grids: no (Ny, Nx, 3) array of pixel positions is made
    if plane is None:
        g, pts = _points(g)
    _check_interpolation(interpolation, upsample)
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth)
    if plane is None:
        values = backproject_points(rc, pts, positions, interpolation, wavelength=wavelength, upsample=upsample,
                                    block=block, pulse_block=pulse_block)
    else:
        _check_blocks(block, pulse_block)
        out_re, out_im = _form(rc, positions, interpolation, upsample, wavelength, block, pulse_block, plane=plane)
        values = (out_re + 1j * out_im).reshape(g.shape)
    return _image(g, values, rc, _wavelength(rc, wavelength), interpolation, upsample, "bpa")


def backproject_numpy(rc: PulseData, grid, positions=None, interpolation: str = "auto", *,
                      wavelength: float | None = None, upsample: int = 4, pulses=None,
                      bandwidth: float | None = None) -> SarImage:
    """Straightforward float64 numpy back-projection: the exact reference for :func:`backproject`.

    Loops over pulses, vectorised over pixels; complex128 samples, ``numpy.exp`` for the phase.
    Same arguments and interpolation rules as :func:`backproject`; ``pulses`` (a slice or index
    array) restricts the sum to some pulses (used to time it on fewer pulses).
    """
    g, pts = _points(grid)
    _check_interpolation(interpolation, upsample)
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth)
    data, rng, pos, lam = _prepare(rc, positions, interpolation, upsample, wavelength)
    sel = np.arange(data.shape[0]) if pulses is None else np.arange(data.shape[0])[pulses]
    flat = pts.reshape(-1, 3)
    n = data.shape[1]
    padded = np.zeros((data.shape[0], n + 2 * _PAD), dtype=np.complex128)
    padded[:, _PAD:_PAD + n] = data
    dr = rng[1] - rng[0]
    out = np.zeros(flat.shape[0], dtype=np.complex128)
    mode = _MODE[interpolation]
    for k in sel:
        r = np.sqrt(np.sum((flat - pos[k]) ** 2, axis=1))
        u = (r - rng[0]) / dr
        valid = (u >= 0.0) & (u <= n - 1)
        uc = np.clip(u, 0.0, n - 1) + _PAD + (0.5 if mode == 0 else 0.0)
        j = np.floor(uc).astype(np.int64)
        w = uc - j
        row = padded[k]
        if mode == 0:
            s = row[j]
        elif mode == 1:
            s = row[j] * (1.0 - w) + row[j + 1] * w
        else:
            s = sum(_keys_weight(d - w) * row[j + d] for d in (-1, 0, 1, 2))
        out += np.where(valid, s * np.exp(1j * 4.0 * np.pi * r / lam), 0.0)
    return _image(g, out.reshape(pts.shape[:-1]), rc, lam, interpolation, upsample, "bpa-numpy")


def _keys_weight(x):
    """Keys (1981) cubic convolution kernel, a = -1/2."""
    x = np.abs(x)
    a = _KEYS_A
    return np.where(x <= 1.0, (a + 2.0) * x ** 3 - (a + 3.0) * x ** 2 + 1.0,
                    np.where(x < 2.0, a * x ** 3 - 5.0 * a * x ** 2 + 8.0 * a * x - 4.0 * a, 0.0))
