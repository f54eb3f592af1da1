"""Back-projection of one block of pulses for a continuum of along-track offsets at the cost of one image.

The candidate trajectories of the velocity-offset search (Hathaway 2023 Alg. 3.3; notes/seed-004 §2.6) differ
from a base trajectory only along one direction e::

    a_k(delta) = b_k + delta * tau_k * e            (candidate delta, pulse k; tau_k the lever, e.g. samples
                                                     since the block start, so delta is in m/sample)

With ``d = p - b_k`` (pixel minus base antenna position), ``R0 = |d|`` and the direction cosine
``g = -(d . e) / R0 = dR/dc``, the range to the candidate antenna is ``R = R0 + c g + O(c^2 / R0)`` with
``c = delta tau_k``. The BPA contribution of pulse k with linear range interpolation (backprojection.py,
thesis (4.27))::

    [s(u0) + (c g / dr) D] exp(j k R0) exp(j k c g),       k = 4 pi / lambda, D = s[j+1] - s[j]

(exact linear interpolation as long as the shifted sample stays in the same range cell) is expanded in
powers of ``delta``::

    I(delta) = sum_{m=0}^{Q} (j k delta)^m / m! M_m  +  (delta / dr) sum_{m=0}^{Q-1} (j k delta)^m / m! N_{m+1}

    M_m = sum_k s_k(u0) exp(j k R0) (tau_k g)^m,   N_m = sum_k D_k exp(j k R0) (tau_k g)^m.

One pass over the pulses accumulates the 2Q + 1 moment images (:func:`offset_moments`); the image of any
offset is then a weighted sum of them (:meth:`OffsetMoments.images`), so L candidates, a bounded Brent
search or a Viterbi trellis cost one pass plus O(Q) per pixel per candidate.

Errors, checked by :meth:`OffsetMoments.images` against ``tolerance`` (phase in radians): truncation
``x^(Q+1) / (Q+1)!`` with ``x = k |delta| max|tau g|``; the neglected range curvature
``k c^2 / (2 R0)``. The test ``tests/imaging/test_offset_bpa.py`` compares with :func:`backproject` on the
candidate positions (error < -60 dB for the search's offsets).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import check_pulses, grid_points, wavelength_of
from sarnav.imaging.kernels import PAD, cis64
from sarnav.signal.data import PulseData

__all__ = ["OffsetMoments", "offset_moments", "order_for"]

#: pixels per parallel work item
DEFAULT_BLOCK = 64
#: pulses per pass over the image
DEFAULT_PULSE_BLOCK = 64


# inlined into _moment_kernel on purpose: compiled on its own (2026-12-07) the velocity search ran 1.7x slower
# (bench_quality_search: one search run 0.65-0.71 s inlined, 1.67 s not), for 10 s less compile time
@numba.njit(fastmath=True, cache=True, inline="always")
def _moment_block(x_, y_, z_, ant, lever, ex, ey, ez, dre, dim, k_start, k_stop, u_offset, inv_dr, u_max,
                  two_over_lambda, m_re, m_im, n_re, n_im, max_x):  # pragma: no cover - compiled
    """Accumulate pulses k_start..k_stop-1 into the moments of one block of pixels (m_*, n_*: (Q+1, n))."""
    n = x_.size
    order = m_re.shape[0] - 1
    lm_r = np.zeros((order + 1, n))   # contiguous local accumulators (the output views are strided)
    lm_i = np.zeros((order + 1, n))
    ln_r = np.zeros((order + 1, n))
    ln_i = np.zeros((order + 1, n))
    a_r = np.empty(n)
    a_i = np.empty(n)
    b_r = np.empty(n)
    b_i = np.empty(n)
    xs = np.empty(n)
    idx = np.empty(n, np.uint64)
    wgt = np.empty(n)
    cph = np.empty(n)
    sph = np.empty(n)
    one = np.uint64(1)
    mx = max_x[0]
    for k in range(k_start, k_stop):
        ax = ant[k, 0]
        ay = ant[k, 1]
        az = ant[k, 2]
        tau = lever[k]
        d_re = dre[k]
        d_im = dim[k]
        # pass 1 (vectorised): range, sample index and weight, phase factor, lever tau g
        for i in range(n):
            dx = x_[i] - ax
            dy = y_[i] - ay
            dz = z_[i] - az
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            u = r * inv_dr - u_offset
            valid = (u >= 0.0) & (u <= u_max)
            uc = min(max(u, 0.0), u_max) + PAD
            fl = np.floor(uc)             # float, then int32: vectorises without AVX-512 (kernels.range_tap)
            idx[i] = np.int32(fl)
            wgt[i] = uc - fl
            cyc = r * two_over_lambda
            ph_c, ph_s = cis64(cyc - np.floor(cyc + 0.5))
            m = 1.0 if valid else 0.0
            cph[i] = ph_c * m
            sph[i] = ph_s * m
            xs[i] = -tau * (dx * ex + dy * ey + dz * ez) / r
        for i in range(n):
            mx = max(mx, abs(xs[i]))
        # pass 2: gather the samples and their first difference, rotate
        for i in range(n):
            j = idx[i]
            w = wgt[i]
            c = cph[i]
            s = sph[i]
            r0 = d_re[j]
            i0 = d_im[j]
            dr_ = d_re[j + one] - r0
            di_ = d_im[j + one] - i0
            sr = r0 + w * dr_
            si = i0 + w * di_
            a_r[i] = sr * c - si * s
            a_i[i] = sr * s + si * c
            b_r[i] = dr_ * c - di_ * s
            b_i[i] = dr_ * s + di_ * c
        # pass 3 (vectorised): moments
        r0m = lm_r[0]
        i0m = lm_i[0]
        for i in range(n):
            r0m[i] += a_r[i]
            i0m[i] += a_i[i]
        for q in range(1, order + 1):
            rm = lm_r[q]
            im = lm_i[q]
            rn = ln_r[q]
            inn = ln_i[q]
            for i in range(n):
                x = xs[i]
                a_r[i] *= x
                a_i[i] *= x
                b_r[i] *= x
                b_i[i] *= x
                rm[i] += a_r[i]
                im[i] += a_i[i]
                rn[i] += b_r[i]
                inn[i] += b_i[i]
    for q in range(order + 1):
        for i in range(n):
            m_re[q, i] += lm_r[q, i]
            m_im[q, i] += lm_i[q, i]
            n_re[q, i] += ln_r[q, i]
            n_im[q, i] += ln_i[q, i]
    max_x[0] = mx


@numba.njit(parallel=True, cache=True)
def _moment_kernel(px, py, pz, ant, lever, ex, ey, ez, dre, dim, u_offset, inv_dr, u_max, two_over_lambda,
                   block, pulse_block, m_re, m_im, n_re, n_im, max_x):  # pragma: no cover - compiled
    """Pulses in groups of ``pulse_block`` (their samples stay in cache), pixels in parallel blocks."""
    m_total = px.size
    n_blocks = (m_total + block - 1) // block
    per_block = np.zeros(n_blocks)
    for k_start in range(0, ant.shape[0], pulse_block):
        k_stop = min(ant.shape[0], k_start + pulse_block)
        for blk in numba.prange(n_blocks):
            i0 = blk * block
            i1 = min(m_total, i0 + block)
            mx = np.zeros(1)
            mx[0] = per_block[blk]
            _moment_block(px[i0:i1], py[i0:i1], pz[i0:i1], ant, lever, ex, ey, ez, dre, dim, k_start, k_stop,
                          u_offset, inv_dr, u_max, two_over_lambda, m_re[:, i0:i1], m_im[:, i0:i1], n_re[:, i0:i1],
                          n_im[:, i0:i1], mx)
            per_block[blk] = mx[0]
    max_x[0] = per_block.max() if n_blocks > 0 else 0.0


@numba.njit(parallel=True, cache=True)
def _evaluate(coef_m, coef_n, m, n, out):  # pragma: no cover - compiled
    """out[l, p] = sum_q coef_m[l, q] m[q, p] + sum_q coef_n[l, q] n[q + 1, p] (complex128)."""
    n_l, q1 = coef_m.shape
    n_px = m.shape[1]
    chunk = 1024
    for c in numba.prange((n_px + chunk - 1) // chunk):
        p0 = c * chunk
        p1 = min(n_px, p0 + chunk)
        for l in range(n_l):
            for p in range(p0, p1):
                acc = coef_m[l, 0] * m[0, p]
                for q in range(1, q1):
                    acc += coef_m[l, q] * m[q, p] + coef_n[l, q - 1] * n[q, p]
                out[l, p] = acc


def order_for(max_phase: float, tolerance: float = 1e-4) -> int:
    """Smallest expansion order Q with truncation bound ``x^(Q+1) / (Q+1)! <= tolerance`` at ``x = max_phase``."""
    x = abs(float(max_phase))
    q, term = 0, x
    while term > tolerance:
        q += 1
        term *= x / (q + 1)
        if q > 200:
            raise ConfigError("offsets", f"phase lever k |delta| max|tau g| = {x:.3g} rad is too large for "
                              "the expansion; use exact back-projection")
    return q


@dataclass
class OffsetMoments:
    """Moment images of one block of pulses (module docstring) and the facts needed to check their use.

    Attributes
    ----------
    m, n : (Q+1, Ny, Nx) complex128 moment images M_0..M_Q and N_0..N_Q (N_0 is zero, unused).
    wavenumber : k = 4 pi / lambda [rad/m].
    range_spacing : dr [m].
    max_lever : max over pixels and pulses of |tau g| [units of tau].
    max_lever_range : max |tau| [units of tau] (for the range-curvature bound).
    min_range : smallest pixel-to-antenna distance [m].
    """

    m: np.ndarray
    n: np.ndarray
    wavenumber: float
    range_spacing: float
    max_lever: float
    max_lever_range: float
    min_range: float

    @property
    def order(self) -> int:
        return self.m.shape[0] - 1

    def max_error(self, delta: float) -> float:
        """Bound on the phase error [rad] of the image of offset ``delta`` (truncation + range curvature)."""
        x = self.wavenumber * abs(delta) * self.max_lever
        q = self.order
        trunc = x ** (q + 1) / math.factorial(q + 1)
        c = abs(delta) * self.max_lever_range
        return trunc + self.wavenumber * c * c / (2.0 * self.min_range)

    def images(self, deltas, tolerance: float = 1e-3) -> np.ndarray:
        """(L, Ny, Nx) complex images of the block for the offsets ``deltas`` (L,) [m per unit of tau].

        Raises ConfigError (field ``offsets``) when an offset exceeds the expansion's accuracy ``tolerance`` [rad].
        """
        d = np.atleast_1d(np.asarray(deltas, dtype=np.float64))
        if d.ndim != 1 or not np.all(np.isfinite(d)):
            raise InputDataError("offsets", f"must be a finite 1-D array, got shape {d.shape}")
        worst = max(self.max_error(float(v)) for v in d) if d.size else 0.0
        if worst > tolerance:
            raise ConfigError("offsets", f"largest offset {np.max(np.abs(d)):.3g} gives an expansion error bound "
                              f"{worst:.3g} rad > tolerance {tolerance:g} rad; raise the order or use exact BPA")
        q = self.order
        fact = np.array([math.factorial(i) for i in range(q + 1)], dtype=np.float64)
        powers = (1j * self.wavenumber * d[:, None]) ** np.arange(q + 1)[None, :] / fact[None, :]   # (L, Q+1)
        shape = self.m.shape[1:]
        coef_n = np.ascontiguousarray((d[:, None] / self.range_spacing) * powers[:, :q]) if q > 0 \
            else np.zeros((d.size, 1), complex)
        out = np.empty((d.size, int(np.prod(shape))), dtype=np.complex128)
        _evaluate(np.ascontiguousarray(powers), coef_n, self.m.reshape(q + 1, -1), self.n.reshape(q + 1, -1), out)
        return out.reshape((d.size,) + shape)

    def image(self, delta: float, tolerance: float = 1e-3) -> np.ndarray:
        """(Ny, Nx) complex image for one offset."""
        return self.images([delta], tolerance)[0]


def _check_direction(direction) -> np.ndarray:
    e = np.asarray(direction, dtype=np.float64)
    if e.shape != (3,) or not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
        raise InputDataError("direction", f"must be a finite non-zero 3-vector, got {direction!r}")
    return e / np.linalg.norm(e)


def offset_moments(rc: PulseData, grid, base_positions, direction, lever, order: int, *,
                   wavelength: float | None = None, block: int = DEFAULT_BLOCK,
                   pulse_block: int = DEFAULT_PULSE_BLOCK) -> OffsetMoments:
    """Moment images of the pulses of ``rc`` for candidate antenna positions ``base + delta lever e``.

    Parameters
    ----------
    rc : range-compressed pulses of the block (``PulseData``, compressed, uniform ``slant_range``).
    grid : pixel grid (any grid of :mod:`sarnav.imaging.grid` or an ``(Ny, Nx, 3)`` array), NED [m].
    base_positions : (P, 3) float64 base antenna positions, one per pulse of ``rc`` [m].
    direction : (3,) direction e of the offsets (normalised here).
    lever : (P,) float64 lever tau_k of each pulse (offset of candidate delta at pulse k = delta tau_k) [any unit].
    order : expansion order Q >= 0 (:func:`order_for` picks one from the largest phase lever).
    wavelength : carrier wavelength [m]; default ``rc.wavelength``.
    block, pulse_block : pixels per parallel work item and pulses per pass (tuning only).

    Returns
    -------
    OffsetMoments; ``images(deltas)`` gives the block's image for each offset (linear range interpolation,
    the convention of ``backproject(..., interpolation="linear")``).
    """
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 0 <= order <= 64:
        raise ConfigError("order", f"must be an integer in [0, 64], got {order!r}")
    data, rng, pos = check_pulses(rc, base_positions)
    lam = wavelength_of(rc, wavelength)
    tau = np.asarray(lever, dtype=np.float64)
    if tau.shape != (data.shape[0],) or not np.all(np.isfinite(tau)):
        raise InputDataError("lever", f"must be a finite ({data.shape[0]},) array, got shape {tau.shape}")
    e = _check_direction(direction)
    g, pts = grid_points(grid)
    flat = pts.reshape(-1, 3)
    n_samp = data.shape[1]
    dre = np.zeros((data.shape[0], n_samp + 2 * PAD), dtype=np.float32)
    dim = np.zeros_like(dre)
    dre[:, PAD:PAD + n_samp] = data.real
    dim[:, PAD:PAD + n_samp] = data.imag
    dr = float(rng[1] - rng[0])
    q1 = int(order) + 1
    m_re, m_im, n_re, n_im = (np.zeros((q1, flat.shape[0])) for _ in range(4))
    max_x = np.zeros(1)
    _moment_kernel(np.ascontiguousarray(flat[:, 0]), np.ascontiguousarray(flat[:, 1]), np.ascontiguousarray(flat[:, 2]),
                   np.ascontiguousarray(pos), np.ascontiguousarray(tau), e[0], e[1], e[2], dre, dim,
                   float(rng[0]) / dr, 1.0 / dr, float(n_samp - 1), 2.0 / lam, int(block), int(pulse_block), m_re, m_im,
                   n_re, n_im, max_x)
    shape = (q1,) + pts.shape[:-1]
    dmin = _min_distance(flat, pos)
    return OffsetMoments((m_re + 1j * m_im).reshape(shape), (n_re + 1j * n_im).reshape(shape), 4.0 * math.pi / lam,
                         dr, float(max_x[0]), float(np.max(np.abs(tau))) if tau.size else 0.0, dmin)


def _min_distance(points: np.ndarray, antennas: np.ndarray) -> float:
    """Smallest pixel-to-antenna distance, from the corners of the pixel set's bounding box and the track ends
    (a lower bound is enough for the curvature check: use the distance from the antenna track to the box)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    # distance from each antenna position to the box, then the minimum
    d = np.maximum(0.0, np.maximum(lo[None, :] - antennas, antennas - hi[None, :]))
    return float(max(np.min(np.linalg.norm(d, axis=1)), 1e-9))
