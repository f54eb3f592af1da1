"""FFBP's polar images on the image's plane: exact for any track, not only a straight one.

``ffbp``'s polar image of a subaperture (centre c, track direction v) holds at (r, u) the pulses' sum at one point
q(r, u) with |q - c| = r and (q - c).v = r u. On the half-plane through c towards the scene centre (``ffbp`` module
doc) that point is c + r (u v + sqrt(1 - u^2) w); a pixel with the same (r, u) off that half-plane has the same range
to every pulse only if the subaperture is straight, else each pulse is off by about its offset across the
half-plane times the pixel's rotation out of it (``ffbp_plan.track_error``: -43 dB for 1 cm over 128 pulses on the
192^2 test scene). Here q(r, u) is instead the point of the *image's plane* with those coordinates:
q = c + r (u v + s (cos(phi) w + sin(phi) b)), s = sqrt(1 - u^2), b = v x w, phi the rotation about v that puts q
on the plane n.(q - o) = 0:

    n.(c - o) + r u n.v + r s (cos(phi) n.w + sin(phi) n.b) = 0
    -> cos(phi - psi) = K / rho,  K = -(n.(c - o) + r u n.v) / (r s),  rho e^{j psi} = n.w + j n.b,

the root nearer phi = 0 (the half-plane's side). A pixel of a plane grid *is* the point with its (r, u), so the final
evaluation reads each subaperture's exact sum, and a merge evaluates a child at a point of the same plane, which is
again the child's own point: nothing assumes a straight track. The demodulated image stays band-limited: the pulses'
offsets d_k add -d_k.e(r, u) to the ranges, a smooth function that widens the u band by about |d_k| / l of itself.
For a straight track the image is the half-plane's (the value depends on (r, u) only), so ``ffbp`` keeps the
half-plane where the track's error is negligible.

Merges: 2-D (:func:`merge_2d_plane`) or in two 1-D passes (:func:`merge_two_pass_plane`, as ``ffbp_merge``'s but on
the plane): a parent row (range r) is a curve of the plane along which the child's direction cosine mu runs
monotonically; pass 1 finds, for each child column mu'_k, the row's point x* with that mu (rho* and the phase by cubic
Lagrange in mu over the row's own samples; beyond them a chord-Newton step on the parent's u) and interpolates the child down its column at rho* = |x* - c_C|, times
exp(j 4 pi (rho* - r + d.e*) / lambda) (d = c_C - c_P, e* = (x* - c_P) / r: rho - r = -d.e + O(|d|^2 / r), so what is
left is band-limited like the child); pass 2 interpolates that row at each parent point's mu, times
exp(-j 4 pi d.e / lambda). The same point's value as the 2-D merge's, with N + N / merge taps a point.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sarnav.imaging.kernels import cis32, polar_tap, taps_2d, taps_along, taps_down

__all__ = ["surface_constants", "plane_points", "merge_2d_plane", "merge_two_pass_plane"]


def surface_constants(centre, v, w, origin, normal) -> np.ndarray:
    """(n.(c - o), n.v, cos psi, sin psi, rho, b_x, b_y, b_z) of a polar grid about ``centre`` (directions v, w;
    b = v x w) on the plane through ``origin`` with unit ``normal`` (module doc): what :func:`plane_point` reads; the
    signs of cos psi and sin psi folded in so that the root of larger cos(phi) is plane_point's one formula."""
    b = np.cross(v, w)
    nw, nb = float(np.dot(normal, w)), float(np.dot(normal, b))
    rho = math.hypot(nw, nb)
    cos_psi, sin_psi = (nw / rho, nb / rho) if rho > 0 else (1.0, 0.0)
    sg = 1.0 if sin_psi >= 0 else -1.0
    return np.array([float(np.dot(normal, centre - origin)), float(np.dot(normal, v)), cos_psi, sin_psi,
                     max(rho, 1e-300), *b, sg * cos_psi, sg * sin_psi])


@numba.njit(fastmath=True, cache=True, inline="always")
def plane_point(c, v, w, sc, r, u):  # pragma: no cover - compiled
    """The point of the plane with range ``r`` from ``c`` and direction cosine ``u`` against ``v`` (module doc;
    ``sc``: :func:`surface_constants`), on the side of the half-plane towards ``w``: of the roots phi = psi -+ a
    (cos a = t = K / rho) the one of larger cos(phi), in closed form and without a branch (it vectorises):
    cos(phi) = t cos(psi) + sg sin(psi) sqrt(1 - t^2), sin(phi) = t sin(psi) - sg cos(psi) sqrt(1 - t^2), sg = the
    sign of sin(psi)."""
    s = math.sqrt(max(1.0 - u * u, 0.0))
    t = min(max(-(sc[0] + r * u * sc[1]) / max(r * s * sc[4], 1e-300), -1.0), 1.0)
    q = math.sqrt(1.0 - t * t)
    cp = s * (sc[2] * t + sc[9] * q)
    sp = s * (sc[3] * t - sc[8] * q)
    return (c[0] + r * (u * v[0] + cp * w[0] + sp * sc[5]), c[1] + r * (u * v[1] + cp * w[1] + sp * sc[6]),
            c[2] + r * (u * v[2] + cp * w[2] + sp * sc[7]))


@numba.njit(fastmath=True, cache=True)
def _columns(sc, u0, du, nu):  # pragma: no cover - compiled
    """Per column u_j of a polar grid: (u_j, s_j = sqrt(1 - u_j^2), A_j, B_j) with plane_point's t = A_j / r + B_j, so
    that a row's points cost one square root each (:func:`_row_point`)."""
    cols = np.empty((4, nu))
    for j in range(nu):
        u = u0 + j * du
        s = math.sqrt(max(1.0 - u * u, 0.0))
        den = max(s * sc[4], 1e-300)
        cols[0, j] = u
        cols[1, j] = s
        cols[2, j] = -sc[0] / den
        cols[3, j] = -u * sc[1] / den
    return cols


@numba.njit(fastmath=True, cache=True, inline="always")
def _row_point(c, v, w, sc, cols, j, r, inv_r):  # pragma: no cover - compiled
    """:func:`plane_point` of (r, column j) from the column's constants (:func:`_columns`)."""
    u = cols[0, j]
    s = cols[1, j]
    t = min(max(cols[2, j] * inv_r + cols[3, j], -1.0), 1.0)
    q = math.sqrt(1.0 - t * t)
    cp = s * (sc[2] * t + sc[9] * q)
    sp = s * (sc[3] * t - sc[8] * q)
    return (c[0] + r * (u * v[0] + cp * w[0] + sp * sc[5]), c[1] + r * (u * v[1] + cp * w[1] + sp * sc[6]),
            c[2] + r * (u * v[2] + cp * w[2] + sp * sc[7]))


@numba.njit(parallel=True, fastmath=True, cache=True)
def plane_points(c, v, w, sc, r0, dr, nr, u0, du, nu, px, py, pz):  # pragma: no cover - compiled
    """The polar grid's points on the plane, line by line of constant u (index j nr + i: u0 + j du, r0 + i dr), into
    px, py, pz: the level-0 points (``ffbp._Former``)."""
    for j in numba.prange(nu):
        u = u0 + j * du
        for i in range(nr):
            px[j * nr + i], py[j * nr + i], pz[j * nr + i] = plane_point(c, v, w, sc, r0 + i * dr, u)


#: parent rows per parallel work item
_ROWS = 8


@numba.njit(parallel=True, fastmath=True, cache=True)
def merge_2d_plane(pc, pv, pw, sc, pr0, pdr, pu0, pdu, cc, cr0, inv_cdr, cu0, inv_cdu, img, two_over_lambda, ktab,
                   out):  # pragma: no cover - compiled
    """``ffbp_merge.merge_2d`` with the parent's grid points on the plane (:func:`plane_point`; ``sc``: the parent's
    :func:`surface_constants`): out (Nr, Nu) complex64 += the child image at them, remodulated."""
    nr, nu = out.shape
    cnr, cnu = img.shape
    flat = img.ravel()
    nt = ktab.shape[1]
    half = nt // 2
    pairs = out.ravel().view(np.float32)
    ore = pairs[0::2]
    oim = pairs[1::2]
    cols = _columns(sc, pu0, pdu, nu)
    for blk in numba.prange((nr + _ROWS - 1) // _ROWS):
        base = np.empty(nu, np.uint32)
        wr = np.empty(nu, np.float32)
        wu = np.empty(nu, np.float32)
        f = np.empty(nu, np.float32)
        for i in range(blk * _ROWS, min(nr, (blk + 1) * _ROWS)):
            r = pr0 + i * pdr
            inv_r = 1.0 / r
            for j in range(nu):
                qx, qy, qz = _row_point(pc, pv, pw, sc, cols, j, r, inv_r)
                base[j], wr[j], wu[j], f[j] = polar_tap(qx, qy, qz, r, cc, pv, cr0, inv_cdr, cu0, inv_cdu, cnr, cnu,
                                                        two_over_lambda, half)
            taps_2d(flat, cnu, nu, base, wr, wu, f, ktab, ore, oim, i * nu)


@numba.njit(cache=True, inline="always")
def _child_cosine(q, cc, v):  # pragma: no cover - compiled
    dx = q[0] - cc[0]
    dy = q[1] - cc[1]
    dz = q[2] - cc[2]
    return (dx * v[0] + dy * v[1] + dz * v[2]) / math.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(parallel=True, fastmath=True, cache=True)
def merge_two_pass_plane(pc, pv, pw, sc, pr0, pdr, pu0, pdu, cc, cr0, inv_cdr, cu0, inv_cdu, img, two_over_lambda,
                         ktab, out):  # pragma: no cover - compiled
    """``ffbp_merge.merge_two_pass`` with the parent's grid points on the plane (module doc; ``sc``: the parent's
    :func:`surface_constants`): out (Nr, Nu) complex64 += the child image at them, remodulated; points whose support
    leaves the child image add nothing."""
    nr, nu = out.shape
    cnr, cnu = img.shape
    flat = img.ravel()
    nt = ktab.shape[1]
    half = nt // 2
    lo = half - 1
    scale = np.float32(ktab.shape[0] - 1)
    d = cc - pc
    cols = _columns(sc, pu0, pdu, nu)
    for blk in numba.prange((nr + _ROWS - 1) // _ROWS):
        q = np.empty(3)
        mu_j = np.empty(nu)                   # the row's points' child direction cosines (increasing or decreasing)
        off = np.empty(nu)                    # and d.e there
        rho_j = np.empty(nu)                  # and the child range
        base1 = np.empty(cnu, np.int64)
        w1 = np.empty(cnu, np.float32)
        c1 = np.empty(cnu, np.float32)
        s1 = np.empty(cnu, np.float32)
        jre = np.empty(cnu, np.float32)
        jim = np.empty(cnu, np.float32)
        base2 = np.empty(nu, np.int64)
        w2 = np.empty(nu, np.float32)
        c2 = np.empty(nu, np.float32)
        s2 = np.empty(nu, np.float32)
        are = np.empty(nu, np.float32)
        aim = np.empty(nu, np.float32)
        for i in range(blk * _ROWS, min(nr, (blk + 1) * _ROWS)):
            r = pr0 + i * pdr
            inv_r = 1.0 / r
            for j in range(nu):               # scalars only: the loop vectorises
                qx, qy, qz = _row_point(pc, pv, pw, sc, cols, j, r, inv_r)
                dx = qx - cc[0]
                dy = qy - cc[1]
                dz = qz - cc[2]
                rho_j[j] = math.sqrt(dx * dx + dy * dy + dz * dz)
                mu_j[j] = (dx * pv[0] + dy * pv[1] + dz * pv[2]) / rho_j[j]
                off[j] = (d[0] * (qx - pc[0]) + d[1] * (qy - pc[1]) + d[2] * (qz - pc[2])) * inv_r
            sgn = 1.0 if mu_j[nu - 1] >= mu_j[0] else -1.0
            j = 0
            for k in range(cnu):              # pass 1: the row's point on child column k
                mu = cu0 + k / inv_cdu
                if sgn > 0.0:                 # the row's sample interval [j, j + 1] holding mu (or the nearest end)
                    while j < nu - 2 and mu_j[j + 1] < mu:
                        j += 1
                else:
                    j, hi = 0, nu - 2
                    while j < hi:
                        mid = (j + hi + 1) // 2
                        if mu_j[mid] >= mu:
                            j = mid
                        else:
                            hi = mid - 1
                if sgn > 0.0 and 1 <= j <= nu - 3 and mu_j[j] <= mu <= mu_j[j + 1]:
                    # inside the row: rho* and rho* - r + d.e* by cubic Lagrange in mu over the row's own samples
                    # (spacing ~du: error ~du^4 r, 1e-12 m at X band)
                    rho = 0.0
                    ph = 0.0
                    for m in range(j - 1, j + 3):
                        lw = 1.0
                        for m2 in range(j - 1, j + 3):
                            if m2 != m:
                                lw *= (mu - mu_j[m2]) / (mu_j[m] - mu_j[m2])
                        rho += lw * rho_j[m]
                        ph += lw * (rho_j[m] + off[m])
                    ph -= r
                else:                         # beyond the row's samples: its point by a chord-Newton step
                    slope = (mu_j[j + 1] - mu_j[j]) / pdu
                    u = pu0 + j * pdu + (mu - mu_j[j]) / slope
                    q[0], q[1], q[2] = plane_point(pc, pv, pw, sc, r, u)
                    u -= (_child_cosine(q, cc, pv) - mu) / slope   # the chord's slope is within du mu''/mu' of the
                    q[0], q[1], q[2] = plane_point(pc, pv, pw, sc, r, u)   # tangent's
                    dx = q[0] - cc[0]
                    dy = q[1] - cc[1]
                    dz = q[2] - cc[2]
                    rho = math.sqrt(dx * dx + dy * dy + dz * dz)
                    ph = rho - r + (d[0] * (q[0] - pc[0]) + d[1] * (q[1] - pc[1]) + d[2] * (q[2] - pc[2])) / r
                fr = (rho - cr0) * inv_cdr
                ir = np.floor(fr)
                valid = (ir >= lo) & (ir <= cnr - 1.0 - half)
                irc = min(max(ir, float(lo)), cnr - 1.0 - half)
                base1[k] = np.int64(np.int32(irc - lo)) * cnu + k
                w1[k] = np.float32(fr - ir)
                cyc = ph * two_over_lambda
                c1[k], s1[k] = cis32(np.float32(cyc - np.floor(cyc + 0.5)) if valid else np.float32(2.0))
            if nt == 6:                       # the tap loops unrolled for the kernels' literal sizes
                taps_down(flat, cnu, base1, w1, c1, s1, ktab, 6, scale, jre, jim)
            else:
                taps_down(flat, cnu, base1, w1, c1, s1, ktab, nt, scale, jre, jim)
            for j2 in range(nu):              # pass 2: each parent point's child direction cosine
                fu = (mu_j[j2] - cu0) * inv_cdu
                iu = np.floor(fu)
                ok = (iu >= lo) & (iu <= cnu - 1.0 - half)
                iuc = min(max(iu, float(lo)), cnu - 1.0 - half)
                base2[j2] = np.int64(np.int32(iuc - lo))
                w2[j2] = np.float32(fu - iu)
                cyc = -off[j2] * two_over_lambda
                c2[j2], s2[j2] = cis32(np.float32(cyc - np.floor(cyc + 0.5)) if ok else np.float32(2.0))
            if nt == 6:
                taps_along(jre, jim, base2, w2, c2, s2, ktab, 6, scale, are, aim)
            else:
                taps_along(jre, jim, base2, w2, c2, s2, ktab, nt, scale, are, aim)
            for j2 in range(nu):
                out[i, j2] += np.complex64(complex(are[j2], aim[j2]))
