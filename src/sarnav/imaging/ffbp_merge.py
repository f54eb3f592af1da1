"""FFBP's merge in two 1-D passes: a child polar image onto its parent's grid, N + N / merge taps a point, not N^2.

The child image I_C(rho, mu) (range rho from its centre c_C, direction cosine mu against the track direction v) is
wanted at the parent's grid points q(r, u) = c_P + r (u v + sqrt(1 - u^2) w_P), remodulated by
exp(j 4 pi (rho(q) - r) / lambda) (``ffbp`` module doc, step 3). The 2-D kernel of ``merge_2d`` reads N x N taps
at each point. A parent row (fixed r) is a circle in the parent's half-plane, and along it the point's child
coordinate mu(q) runs monotonically; so, per parent row r_i (the classic two-pass warp, Catmull & Smith 1980;
FFBP's factorisation is Ulander et al. 2003):

1. **Along range**: for every child column mu'_k, the point of the circle r_i whose child direction cosine is mu'_k
   lies at child range rho*(r_i, mu'_k) (closed form for a child centre in the parent's half-plane, two Newton steps
   for one off it); an N-tap interpolation down child column k gives
   ``J_i(k) = I_C(rho*, mu'_k) exp(j 4 pi (rho* - r_i + a mu'_k + b sqrt(1 - mu'_k^2)) / lambda)``, with (a, b) the
   child centre's offset from the parent's along v and w_P. The last two terms are the remodulation's first order in
   the offset (rho - r ~ -(a mu + b sqrt(1 - mu^2))): taking them out leaves J_i band-limited to the child's own band
   (the a-term is the child's Doppler offset within the parent's band; without the b-term a child 2 m off the line
   lost 15 dB, tests/imaging/test_ffbp_merge.py), so J_i is sampled as finely as the child is.
2. **Along the circle**: at each parent point q(r_i, u_j), an N-tap interpolation of J_i at mu(q), times
   exp(-j 4 pi (a mu(q) + b sqrt(1 - mu(q)^2)) / lambda).

Per parent point N taps (pass 2) plus N / merge (pass 1: the child has ``merge`` times fewer columns) instead of N^2.
Error: each pass is a 1-D interpolation at the polar oversampling ``os``, so a merge adds the two 1-D errors, which is
what the separable 2-D kernel's error (``interpolation_error_2d(kernel, os, os)``) is to first order; the range
coupling widens J's band along mu by |a| B / c (a fraction (|a| / l_C)(B / f_c) of the child's band, l_C its
length: 1.5 x B / f_c for the outer children of a merge of 4, 4.7 % at X band with 300 MHz).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarnav.imaging.kernels import cis32, polar_tap, taps_2d, taps_along, taps_down

__all__ = ["TWO_PASS_MAX_WIDENING", "merge_two_pass", "merge_2d", "two_pass_applies", "child_widening"]

#: the largest band widening (|a| / l_C)(B / f_c) of the outermost child at which ``ffbp`` merges in two passes (else
#: with the 2-D kernel): measured on the 192^2 test scene, merge 4, os 2 and 3, the two-pass image error against the 2-D
#: merge's: +0.1 dB at B / f_c = 0.05 (widening 0.075), +0.2-0.4 dB at 0.10 (0.15), +0.3-0.8 dB at 0.15, +0.6-1.5 dB
#: at 0.20, +4 dB at 0.30, +13 dB at 0.60 (docs/backprojection.md)
TWO_PASS_MAX_WIDENING = 0.15


def two_pass_applies(merge: int, bandwidth: float, carrier: float) -> bool:
    """Whether a merge of ``merge`` children widens the pass-1 band by at most :data:`TWO_PASS_MAX_WIDENING`: the
    outermost child sits (merge - 1) / 2 child lengths from the parent's centre (module doc); a shorter last child is
    judged on its own (:func:`child_widening`)."""
    return 0.5 * (merge - 1) * bandwidth / carrier <= TWO_PASS_MAX_WIDENING


def child_widening(offset: float, length: float, bandwidth_over_carrier: float) -> float:
    """The pass-1 band widening of one child, (|a| / l_C)(B / f_c) (module doc): ``offset`` a [m] of its centre from the
    parent's along the track, ``length`` l_C [m] of its aperture. For equal children of a merge of 4 at most
    1.5 B / f_c (:func:`two_pass_applies`); a short last child far from its parent's centre has much more (10 pulses at
    192 pulses from the centre: 19 B / f_c, 0.6 at X band with 300 MHz), and ``ffbp`` merges it with the 2-D kernel."""
    return abs(offset) / length * bandwidth_over_carrier


#: parent rows per parallel work item
_ROWS = 8


@numba.njit(fastmath=True, cache=True, inline="always")
def _newton(rho, r, mu, a, b, c2, s):  # pragma: no cover - compiled
    """rho > 0 with (a + rho mu)^2 + (b + sqrt(rho^2 s^2 - c2))^2 = r^2 (s = sqrt(1 - mu^2)), two Newton steps from
    ``rho`` (the root for c = 0): the child range of the point of the parent's half-plane at parent range r whose
    child direction cosine is mu, for a child centre offset (a, b, c) along (v, w_P, v x w_P) from the parent's."""
    for _ in range(2):
        sq = math.sqrt(max(rho * rho * s * s - c2, 1e-30))
        x = a + rho * mu
        y = b + sq
        rho -= (x * x + y * y - r * r) / (2.0 * x * mu + 2.0 * y * rho * s * s / sq)
    return rho


@numba.njit(parallel=True, fastmath=True, cache=True)
def merge_two_pass(pc, pv, pw, pr0, pdr, pu0, pdu, cc, cr0, inv_cdr, cu0, inv_cdu, img, two_over_lambda, ktab,
                   out):  # pragma: no cover - compiled
    """out (Nr, Nu) complex64 += child image ``img`` ((cnr, cnu) complex64; rows: range r0 + i / inv_dr, columns:
    direction cosine u0 + j / inv_du, about the child centre ``cc``) at the parent's grid points, remodulated (module
    doc); ``ktab``: the kernel table (F + 1, N) of ``ffbp.kernel_table``; points whose support leaves the child
    image add nothing (as in ``merge_2d``)."""
    nr, nu = out.shape
    cnr, cnu = img.shape
    flat = img.ravel()
    nt = ktab.shape[1]
    half = nt // 2
    lo = half - 1
    scale = np.float32(ktab.shape[0] - 1)
    pn = np.array([pv[1] * pw[2] - pv[2] * pw[1], pv[2] * pw[0] - pv[0] * pw[2], pv[0] * pw[1] - pv[1] * pw[0]])
    dlt = cc - pc
    a = dlt[0] * pv[0] + dlt[1] * pv[1] + dlt[2] * pv[2]
    b = dlt[0] * pw[0] + dlt[1] * pw[1] + dlt[2] * pw[2]
    c = dlt[0] * pn[0] + dlt[1] * pn[1] + dlt[2] * pn[2]
    c2 = c * c if abs(c) > 1e-9 else 0.0
    uj = np.empty(nu)                         # the parent's directions e_j = u_j v + sqrt(1 - u_j^2) w_P: their
    gj = np.empty(nu)                         # direction cosine u_j and g_j = (c_C - c_P).e_j, shared by its rows
    for j in range(nu):
        uj[j] = pu0 + j * pdu
        gj[j] = a * uj[j] + b * math.sqrt(max(1.0 - uj[j] * uj[j], 0.0))
    d2 = a * a + b * b + c * c
    mus = np.empty(cnu)
    sns = np.empty(cnu)
    for k in range(cnu):
        mus[k] = cu0 + k / inv_cdu
        sns[k] = math.sqrt(max(1.0 - mus[k] * mus[k], 0.0))
    for blk in numba.prange((nr + _ROWS - 1) // _ROWS):
        rhos = np.empty(cnu)
        base1 = np.empty(cnu, np.int64)
        w1 = np.empty(cnu, np.float32)
        c1 = np.empty(cnu, np.float32)
        s1 = np.empty(cnu, np.float32)
        jre = np.empty(cnu, np.float32)
        jim = np.empty(cnu, np.float32)
        base2 = np.empty(nu, np.int64)
        w2 = np.empty(nu, np.float32)
        c2_ = np.empty(nu, np.float32)
        ok2 = np.empty(nu, np.bool_)
        off = np.empty(nu)
        mu2 = np.empty(nu)
        s2 = np.empty(nu, np.float32)
        are = np.empty(nu, np.float32)
        aim = np.empty(nu, np.float32)
        for i in range(blk * _ROWS, min(nr, (blk + 1) * _ROWS)):
            r = pr0 + i * pdr
            for k in range(cnu):              # pass 1 geometry: the circle's point on child column k
                p = a * mus[k] + b * sns[k]
                rhos[k] = -p + math.sqrt(max(p * p - (a * a + b * b - r * r), 0.0))
            if c2 > 0.0:                      # a child centre off the parent's half-plane
                for k in range(cnu):
                    rhos[k] = _newton(rhos[k], r, mus[k], a, b, c2, sns[k])
            for k in range(cnu):
                fr = (rhos[k] - cr0) * inv_cdr
                ir = np.floor(fr)
                valid = (ir >= lo) & (ir <= cnr - 1.0 - half)
                irc = min(max(ir, float(lo)), cnr - 1.0 - half)
                base1[k] = np.int64(np.int32(irc - lo)) * cnu + k
                w1[k] = np.float32(fr - ir)
                cyc = (rhos[k] - r + a * mus[k] + b * sns[k]) * two_over_lambda
                c1[k], s1[k] = cis32(np.float32(cyc - np.floor(cyc + 0.5)) if valid else np.float32(2.0))
            if nt == 6:                       # the tap loops unrolled for the kernels' literal sizes
                taps_down(flat, cnu, base1, w1, c1, s1, ktab, 6, scale, jre, jim)
            elif nt == 4:
                taps_down(flat, cnu, base1, w1, c1, s1, ktab, 4, scale, jre, jim)
            else:
                taps_down(flat, cnu, base1, w1, c1, s1, ktab, nt, scale, jre, jim)
            for j in range(nu):               # pass 2 geometry: each parent point's child direction cosine
                # q - c_C = r e_j - (c_C - c_P): (q - c_C).v = r u_j - a, |q - c_C|^2 = r^2 - 2 r g_j + |c_C - c_P|^2
                mu = (r * uj[j] - a) / math.sqrt(r * r - 2.0 * r * gj[j] + d2)
                fu = (mu - cu0) * inv_cdu
                iu = np.floor(fu)
                ok2[j] = (iu >= lo) & (iu <= cnu - 1.0 - half)
                iuc = min(max(iu, float(lo)), cnu - 1.0 - half)
                base2[j] = np.int64(np.int32(iuc - lo))
                w2[j] = np.float32(fu - iu)
                off[j] = a * mu
                mu2[j] = mu
            if b != 0.0:                      # a child centre off the track line: the b term (module doc)
                for j in range(nu):
                    off[j] += b * math.sqrt(max(1.0 - mu2[j] * mu2[j], 0.0))
            for j in range(nu):
                cyc = -off[j] * two_over_lambda
                c2_[j], s2[j] = cis32(np.float32(cyc - np.floor(cyc + 0.5)) if ok2[j] else np.float32(2.0))
            if nt == 6:
                taps_along(jre, jim, base2, w2, c2_, s2, ktab, 6, scale, are, aim)
            elif nt == 4:
                taps_along(jre, jim, base2, w2, c2_, s2, ktab, 4, scale, are, aim)
            else:
                taps_along(jre, jim, base2, w2, c2_, s2, ktab, nt, scale, are, aim)
            for j in range(nu):
                out[i, j] += np.complex64(complex(are[j], aim[j]))


#: parent rows per parallel work item of a 2-D merge
_MERGE_ROWS = 8


@numba.njit(parallel=True, fastmath=True, cache=True)
def merge_2d(pc, pv, pw, pr0, pdr, pu0, pdu, cc, cr0, inv_cdr, cu0, inv_cdu, img, two_over_lambda, ktab,
           out):  # pragma: no cover - compiled
    """out (Nr, Nu) complex64 += child image ``img`` (complex64) at the parent's polar grid points q(r, u), generated
    on the fly row by row (float64), interpolated as in ``_polar_eval`` (a parent sums ``merge`` children in float32:
    rounding ~-140 dB)."""
    nr, nu = out.shape
    cnr, cnu = img.shape
    flat = img.ravel()
    nt = ktab.shape[1]
    half = nt // 2
    pairs = out.ravel().view(np.float32)     # complex64 as interleaved float32 (re, im): taps_2d adds into both
    ore = pairs[0::2]
    oim = pairs[1::2]
    ex = np.empty(nu)                         # the parent's directions e(u) = u v + sqrt(1 - u^2) w, shared by its rows
    ey = np.empty(nu)
    ez = np.empty(nu)
    for j in range(nu):
        u = pu0 + j * pdu
        sw = math.sqrt(max(1.0 - u * u, 0.0))
        ex[j] = u * pv[0] + sw * pw[0]
        ey[j] = u * pv[1] + sw * pw[1]
        ez[j] = u * pv[2] + sw * pw[2]
    chunk = _MERGE_ROWS
    for blk in numba.prange((nr + chunk - 1) // chunk):
        base = np.empty(nu, np.uint32)        # work arrays once per block of rows
        wr = np.empty(nu, np.float32)
        wu = np.empty(nu, np.float32)
        f = np.empty(nu, np.float32)
        for i in range(blk * chunk, min(nr, (blk + 1) * chunk)):
            r = pr0 + i * pdr
            for j in range(nu):
                base[j], wr[j], wu[j], f[j] = polar_tap(pc[0] + r * ex[j], pc[1] + r * ey[j], pc[2] + r * ez[j], r,
                                                        cc, pv, cr0, inv_cdr, cu0, inv_cdu, cnr, cnu, two_over_lambda,
                                                        half)
            taps_2d(flat, cnu, nu, base, wr, wu, f, ktab, ore, oim, i * nu)
