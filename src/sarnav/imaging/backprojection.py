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
* ``"lagrange"``: four-tap cubic Lagrange (error O(h^4): the accurate one on oversampled data);
* ``"upsample"``: band-limited FFT zero-padding of every pulse by ``upsample`` (default 4) and then
  linear interpolation on the finer grid;
* ``"upsample-lagrange"``: the same FFT upsampling, then cubic Lagrange;
* ``"precise"``: the high-accuracy mode: ``"upsample-lagrange"`` with the factor chosen from the data's
  oversampling fs/B so that the predicted error is <= :data:`PRECISE_MAX_ERROR` (-80 dB; ``"lagrange"``
  alone when the data are oversampled enough);
* ``"auto"`` (default): accuracy first, speed second: the cheapest of linear, Lagrange and
  upsample-Lagrange x2..x32 whose predicted error is <= :data:`AUTO_MAX_ERROR` (-60 dB).

docs/backprojection.md gives the measured accuracy of each against exact band-limited (sinc)
interpolation. Samples outside the receive window are zero: a pixel whose range falls outside
``[slant_range[0], slant_range[-1]]`` for a pulse receives nothing from that pulse.

Implementation (docs/backprojection.md "Speed"): numba ``prange`` over blocks of contiguous pixels
(row segments of plane grids: ``GroundGrid``, ``SlantGrid``, ``PlaneGrid``, where the squared range
along a row is an exact quadratic in the column index, so no pixel coordinates are read); per pulse
a vectorised float64 pass computes the range (one square root), the sample index and weight and the
fractional cycle ``f`` of ``2R/lambda``; a vectorised float32 pass turns f into exp(j 2 pi f); a
scalar pass gathers the complex64 samples (two pulses per pass for nearest, linear and Lagrange) and
accumulates in float32 over ``pulse_block`` pulses, each partial sum added to the float64 image.
Geometry is float64: ``f`` is reduced to [-1/2, 1/2) in float64 (error ~1e-16 * 2R/lambda cycles,
1e-11 for R = 2 km at X band) before it is rounded to float32; exp(j 2 pi f) comes from quarter-wave
polynomials in float32 (max error ``PHASE_F32_MAX_ERROR`` ~2e-7, the float32 rounding of the factor),
no transcendental call, so LLVM vectorises it without SVML. The interpolation kernels, the phase factor
and the gathers are in :mod:`sarnav.imaging.kernels` (shared with ``ffbp`` and ``offset_bpa``); this
module holds the geometry passes, the parallel drivers and the input checks that ``ffbp`` and
``offset_bpa`` use too (:func:`check_pulses`, :func:`wavelength_of`, :func:`grid_points`, ...).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData, SarImage
from sarnav.imaging.grid import GroundGrid, PlaneGrid, SlantGrid, as_grid
from sarnav.imaging.interpolation_choice import (AUTO_MAX_ERROR, PRECISE_MAX_ERROR, data_oversampling,
                                                resolve_interpolation)
from sarnav.imaging.kernels import (GATHER_MODE, PAD, PHASE_F32_MAX_ERROR, PHASE_POLY_MAX_ERROR, UPSAMPLED, cis32,
                                    gather, gather_pair, gather_pair_lagrange, padded_pulses, point_kernel,
                                    range_tap)

__all__ = ["backproject", "backproject_numpy", "backproject_points", "backproject_fan", "resolve_interpolation",
           "data_oversampling", "plane_of", "PHASE_F32_MAX_ERROR",
           "INTERPOLATIONS", "PHASE_POLY_MAX_ERROR", "AUTO_MAX_ERROR", "PRECISE_MAX_ERROR",
           "bpa_fan_kernel", "bpa_point_kernel", "check_pulses", "check_interpolation", "wavelength_of", "grid_points", "sar_image"]

INTERPOLATIONS = ("nearest", "linear", "cubic", "lagrange", "upsample", "upsample-lagrange", "precise", "auto")
#: pixels per parallel work item (a block of contiguous pixels: the row stays in L1 cache)
DEFAULT_BLOCK = 512
#: pulses per pass over the image (their samples stay in the L2 cache)
DEFAULT_PULSE_BLOCK = 128


@numba.njit(fastmath=True, cache=True)
def _pass_points(px, py, pz, i0, n, ant, k, u_offset, inv_dr, u_max, shift, two_over_lambda, idx, wgt, cph,
                 sph):  # pragma: no cover - compiled
    """Pass 1 of pulse k at the points i0 .. i0 + n - 1: float64 range and ``range_tap``, float32 ``cis32``."""
    ax = ant[k, 0]
    ay = ant[k, 1]
    az = ant[k, 2]
    for i in range(n):
        dx = px[i0 + i] - ax
        dy = py[i0 + i] - ay
        dz = pz[i0 + i] - az
        idx[i], wgt[i], cph[i] = range_tap(math.sqrt(dx * dx + dy * dy + dz * dz), u_offset, inv_dr, u_max, shift,
                                           two_over_lambda)
    for i in range(n):
        cph[i], sph[i] = cis32(cph[i])


@numba.njit(fastmath=True, cache=True)
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
        idx[i], wgt[i], cph[i] = range_tap(math.sqrt(w2 + q * (beta + q * e2)), u_offset, inv_dr, u_max, shift,
                                           two_over_lambda)
    for i in range(n):
        cph[i], sph[i] = cis32(cph[i])


@numba.njit(fastmath=True, cache=True, inline="always")
def _work_arrays(n):  # pragma: no cover - compiled
    """A work item's arrays for n pixels: float32 accumulators (zero), per-pulse tap positions and phase factors of
    two pulses (``range_tap``, ``cis32``) and the cubic weights of two pulses (8, n) (``gather``,
    ``gather_pair_lagrange``)."""
    idx, idx2 = np.empty(n, np.uint32), np.empty(n, np.uint32)
    wgt, wgt2 = np.empty(n, np.float32), np.empty(n, np.float32)
    cph, cph2 = np.empty(n, np.float32), np.empty(n, np.float32)
    sph, sph2 = np.empty(n, np.float32), np.empty(n, np.float32)
    return (np.zeros(n, np.float32), np.zeros(n, np.float32), idx, wgt, cph, sph, idx2, wgt2, cph2, sph2,
            np.empty((8, n), np.float32))


@numba.njit(parallel=True, fastmath=True, cache=True)
def _bpa_kernel(px, py, pz, ant, data, u_offset, inv_dr, u_max, two_over_lambda, mode, block,
                pulse_block, out_re, out_im):  # pragma: no cover - compiled
    """Accumulate sum_k s_k(R) exp(j 4 pi R / lambda) at arbitrary points into out_re/out_im (float64).

    data: (P, N + 2 PAD) complex64 zero-padded samples; u = R * inv_dr - u_offset is the unpadded
    fractional sample index, valid in [0, u_max]. Pulses are processed in groups of ``pulse_block``
    (their samples stay in L2 cache) summed in float32, each group's sum added to the float64
    output; pixels in parallel blocks of ``block``. Per pulse: a vectorised float64 pass (range, sample
    index and weight, fractional cycle: ``range_tap``), a vectorised float32 pass (phase factor: ``cis32``,
    16 lanes on AVX-512), a scalar pass of gathers (``gather``; two pulses at a time for nearest,
    linear and Lagrange, ``gather_pair``, ``gather_pair_lagrange``).
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
            acc_r, acc_i, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, w4 = _work_arrays(n)
            k = k_start
            while k < k_stop:
                _pass_points(px, py, pz, i0, n, ant, k, u_offset, inv_dr, u_max, shift, two_over_lambda, idx, wgt,
                             cph, sph)
                if mode != 2 and k + 1 < k_stop:
                    _pass_points(px, py, pz, i0, n, ant, k + 1, u_offset, inv_dr, u_max, shift, two_over_lambda,
                                 idx2, wgt2, cph2, sph2)
                    if mode == 3:
                        gather_pair_lagrange(data[k], data[k + 1], n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, w4,
                                             acc_r, acc_i)
                    else:
                        gather_pair(data[k], data[k + 1], mode, n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, acc_r,
                                    acc_i)
                    k += 2
                else:
                    gather(data[k], mode, n, idx, wgt, cph, sph, w4, acc_r, acc_i)
                    k += 1
            for i in range(n):
                out_re[i0 + i] += acc_r[i]
                out_im[i0 + i] += acc_i[i]


#: the point kernel under a public name (``imaging.ffbp``'s level 0 on the image's plane, ``ffbp_surface``)
bpa_point_kernel = _bpa_kernel


@numba.njit(fastmath=True, cache=True)
def _row_origins(origin, e_row, ny):  # pragma: no cover - compiled
    """origin + i e_row (ny, 3): a plane grid's rows as the lines of ``bpa_fan_kernel`` (compiled like the kernels,
    so the rows' float64 coordinates round as they did inside the former plane kernel)."""
    out = np.empty((ny, 3))
    for i in range(ny):
        out[i, 0] = origin[0] + i * e_row[0]
        out[i, 1] = origin[1] + i * e_row[1]
        out[i, 2] = origin[2] + i * e_row[2]
    return out


@numba.njit(parallel=True, fastmath=True, cache=True)
def bpa_fan_kernel(origins, e_cols, nx, ant, data, u_offset, inv_dr, u_max, two_over_lambda, mode, block,
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
            acc_r, acc_i, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, w4 = _work_arrays(n)
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
                    if mode == 3:
                        gather_pair_lagrange(data[k], data[k + 1], n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, w4,
                                             acc_r, acc_i)
                    else:
                        gather_pair(data[k], data[k + 1], mode, n, idx, wgt, cph, sph, idx2, wgt2, cph2, sph2, acc_r,
                                    acc_i)
                    k += 2
                else:
                    gather(data[k], mode, n, idx, wgt, cph, sph, w4, acc_r, acc_i)
                    k += 1
            base = row * nx + j0
            for i in range(n):
                out_re[base + i] += acc_r[i]
                out_im[base + i] += acc_i[i]


# ---------------------------------------------------------------------------------------------
# input checking and preparation (shared by the compiled and the numpy implementation)

def wavelength_of(rc: PulseData, wavelength) -> float:
    """The carrier wavelength [m]: ``wavelength`` if given, else ``rc.carrier_wavelength``; finite and > 0."""
    if wavelength is None:
        wavelength = rc.carrier_wavelength
        if wavelength is None:
            raise ConfigError("wavelength", "not given, and rc carries no wavelength; "
                              "pass wavelength= [m] > 0")
    lam = float(wavelength)
    if not math.isfinite(lam) or lam <= 0:
        raise ConfigError("wavelength", f"must be finite and > 0 m, got {wavelength!r}")
    return lam


def check_pulses(rc: PulseData, positions):
    """(samples (P, N), slant ranges (N,) float64, antenna positions (P, 3) float64) of range-compressed pulses
    ``rc`` with a uniform range axis, the positions ``positions`` or else ``rc.positions``; finite."""
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


def check_interpolation(interpolation: str, upsample: int) -> int:
    """``upsample`` as an int after checking it and ``interpolation`` (one of :data:`INTERPOLATIONS`)."""
    if interpolation not in INTERPOLATIONS:
        raise ConfigError("interpolation", f"must be one of {INTERPOLATIONS}, got {interpolation!r}")
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)) or not 2 <= upsample <= 64:
        raise ConfigError("upsample", f"must be an integer in [2, 64], got {upsample!r}")
    return int(upsample)


def _prepare(rc, positions, interpolation, upsample, wavelength, dtype=np.complex128):
    """(padded samples, range axis, n samples, positions, wavelength): the pulses as the kernels read them
    (``padded_pulses``: upsampled when the interpolation says so, n samples from column PAD, zeros around)."""
    upsample = check_interpolation(interpolation, upsample)
    data, rng, pos = check_pulses(rc, positions)
    lam = wavelength_of(rc, wavelength)
    padded, rng, n = padded_pulses(data, rng, upsample if interpolation in UPSAMPLED else 1, dtype)
    return padded, rng, n, pos, lam


def grid_points(grid) -> tuple[object, np.ndarray]:
    """(grid, its (..., 3) float64 pixel positions) of any grid :func:`sarnav.imaging.grid.as_grid` takes."""
    g = as_grid(grid)
    pts = np.asarray(g.points(), dtype=np.float64)
    if not np.all(np.isfinite(pts)):
        raise InputDataError("grid", "pixel positions must be finite (found NaN/inf)")
    return g, pts


def sar_image(g, values: np.ndarray, rc: PulseData, lam: float, interpolation: str, upsample: int,
              algorithm: str) -> SarImage:
    """The ``SarImage`` of ``values`` on grid ``g`` with the former's metadata (``algorithm``, wavelength, ...)."""
    y, x, y_name, x_name = g.axes()
    meta = {"algorithm": algorithm, "wavelength": lam, "interpolation": interpolation,
            "n_pulses": int(rc.n_pulses)}
    if interpolation in UPSAMPLED:
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
    check_interpolation(interpolation, upsample)
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim < 1 or pts.shape[-1] != 3:
        raise InputDataError("points", f"must have shape (..., 3), got {pts.shape}")
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth, pts.size // 3)
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
    line is exactly quadratic in j, so the cost per point-pulse is that of a plane grid (``bpa_fan_kernel``).
    The same sums as :func:`backproject_points` at those points (to float32 accumulation order).
    """
    check_interpolation(interpolation, upsample)
    origins = np.asarray(origins, dtype=np.float64)
    steps = np.asarray(steps, dtype=np.float64)
    if origins.ndim != 2 or origins.shape[-1] != 3 or steps.shape != origins.shape:
        raise InputDataError("origins", f"origins and steps must both have shape (L, 3), got {origins.shape}, {steps.shape}")
    if not (np.all(np.isfinite(origins)) and np.all(np.isfinite(steps))):
        raise InputDataError("origins", "must be finite (found NaN/inf)")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputDataError("n", f"must be an integer >= 1 (points per line), got {n!r}")
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth,
                                                        origins.shape[0] * int(n))
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
    padded, rng, n, pos, lam = _prepare(rc, positions, interpolation, upsample, wavelength, np.complex64)
    dr = float(rng[1] - rng[0])
    pos = np.ascontiguousarray(pos)
    common = (float(rng[0]) / dr, 1.0 / dr, float(n - 1), 2.0 / lam, GATHER_MODE[interpolation], int(block),
              int(pulse_block))
    if fan is not None:
        origins, e_cols, nx = fan
        out_re = np.zeros(origins.shape[0] * nx)
        out_im = np.zeros(origins.shape[0] * nx)
        bpa_fan_kernel(np.ascontiguousarray(origins, dtype=np.float64), np.ascontiguousarray(e_cols, dtype=np.float64),
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
        bpa_fan_kernel(_row_origins(origin, e_row, ny), np.ascontiguousarray(np.broadcast_to(e_col, (ny, 3))),
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
    interpolation : "auto" (default), "nearest", "linear", "cubic" (Keys), "lagrange" (cubic Lagrange),
        "upsample" (FFT ×``upsample`` then linear), "upsample-lagrange" (FFT ×``upsample`` then Lagrange) or
        "precise" (high accuracy, <= -75 dB). "auto" chooses from the data's oversampling fs/B
        (:func:`resolve_interpolation`) for accuracy first (<= -60 dB: predicted <= -65 dB), speed second:
        fs/B = 1.2 -> upsample-lagrange ×5, fs/B = 2 -> ×3, fs/B = 4 -> upsample ×7 on a large image;
        "precise" for <= -80 dB predicted (fs/B = 1.2 -> ×8, 2 -> ×5);
        docs/backprojection.md
        gives each mode's measured error.
    bandwidth : signal bandwidth B [Hz] for "auto"; default ``rc.bandwidth`` or estimated
        from the pulses' power spectrum.
    wavelength : carrier wavelength [m]; default ``rc.carrier_wavelength`` (``rc.wavelength``, else
        None): a ``PulseData`` needs no ``RadarParams`` to be back-projected.
    upsample : FFT oversampling factor for ``interpolation="upsample"`` (integer in [2, 64]).
    block : pixels per parallel work item (tuning only; the result does not depend on it beyond the float32
        accumulation's last bits: a freshly compiled Lagrange row kernel differed by ~1e-6 relative between block
        sizes, tests/imaging/test_backprojection.py).
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
        g, pts = grid_points(g)
    check_interpolation(interpolation, upsample)
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth, int(np.prod(g.shape)))
    if plane is None:
        values = backproject_points(rc, pts, positions, interpolation, wavelength=wavelength, upsample=upsample,
                                    block=block, pulse_block=pulse_block)
    else:
        _check_blocks(block, pulse_block)
        out_re, out_im = _form(rc, positions, interpolation, upsample, wavelength, block, pulse_block, plane=plane)
        values = (out_re + 1j * out_im).reshape(g.shape)
    return sar_image(g, values, rc, wavelength_of(rc, wavelength), interpolation, upsample, "bpa")


def backproject_numpy(rc: PulseData, grid, positions=None, interpolation: str = "auto", *,
                      wavelength: float | None = None, upsample: int = 4, pulses=None,
                      bandwidth: float | None = None) -> SarImage:
    """Straightforward float64 numpy back-projection: the exact reference for :func:`backproject`.

    Loops over pulses, vectorised over pixels; complex128 samples, ``numpy.exp`` for the phase.
    Same arguments and interpolation rules as :func:`backproject`; ``pulses`` (a slice or index
    array) restricts the sum to some pulses (used to time it on fewer pulses).
    """
    g, pts = grid_points(grid)
    check_interpolation(interpolation, upsample)
    if isinstance(rc, PulseData):
        interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bandwidth, int(np.prod(g.shape)))
    padded, rng, n, pos, lam = _prepare(rc, positions, interpolation, upsample, wavelength)
    sel = np.arange(padded.shape[0]) if pulses is None else np.arange(padded.shape[0])[pulses]
    flat = pts.reshape(-1, 3)
    dr = rng[1] - rng[0]
    out = np.zeros(flat.shape[0], dtype=np.complex128)
    mode = GATHER_MODE[interpolation]
    for k in sel:
        r = np.sqrt(np.sum((flat - pos[k]) ** 2, axis=1))
        u = (r - rng[0]) / dr
        valid = (u >= 0.0) & (u <= n - 1)
        uc = np.clip(u, 0.0, n - 1) + PAD + (0.5 if mode == 0 else 0.0)
        j = np.floor(uc).astype(np.int64)
        w = uc - j
        row = padded[k]
        if mode == 0:
            s = row[j]
        elif mode == 1:
            s = row[j] * (1.0 - w) + row[j + 1] * w
        else:
            s = sum(point_kernel("cubic" if mode == 2 else "lagrange", d - w) * row[j + d] for d in (-1, 0, 1, 2))
        out += np.where(valid, s * np.exp(1j * 4.0 * np.pi * r / lam), 0.0)
    return sar_image(g, out.reshape(pts.shape[:-1]), rc, lam, interpolation, upsample, "bpa-numpy")
