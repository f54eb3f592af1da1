"""Fast factorised back-projection (FFBP) on polar subimages, float64 geometry, numba kernels.

Algorithm (Ulander, Hellsten & Stenstrom, IEEE TAES 39(3) 2003, "fast factorized back-projection",
§III; here with 3-D pixels and any trajectory):

1. The pulses are split into subapertures of ``base_pulses`` consecutive pulses. Subaperture J has
   a centre c_J (mean antenna position), the track direction v (unit, whole aperture) and a
   *polar grid*: range r from c_J and direction cosine u = (q - c_J).v / r, on the points
   ``q(r, u) = c_J + r (u v + sqrt(1 - u^2) w_J)`` (w_J: unit vector perpendicular to v towards the
   scene centre). For a straight subaperture every point with the same (r, u) has the same range to
   every pulse of J, so the polar image holds the subaperture's whole contribution to any pixel.
2. Level 0: each polar image is formed by exact back-projection of its pulses onto its grid points,
   line by line of constant u (``backprojection.backproject_fan``: the range is quadratic along a line), and
   *demodulated*: ``I_J(r, u) = sum_k s_k(R_k) e^{j4pi(R_k - r)/lambda}``,
   a band-limited function of (r, u): |f_r| <= B/c, |f_u| <= l_J (1 + B / 2 f_c) / lambda (l_J the
   subaperture length along v).
3. Each merge groups ``merge`` consecutive subapertures into a parent with a ``merge`` times finer u
   sampling: ``I_P(q) = sum_children I_j(r_j(q), u_j(q)) e^{j4pi(r_j(q) - r_P(q))/lambda}`` (in two 1-D passes,
   ``ffbp_merge.merge_two_pass``, where the band is narrow enough: ``ffbp_merge.two_pass_applies``; else separable 2-D
   interpolation of each child at the parent's grid points with ``kernel``: the 6-tap Kaiser-windowed sinc
   "kaiser6" or 4-tap Keys "cubic", both tabulated; float64 geometry). Compiled kernels: per block of points a
   vectorised float64 pass locates each point on the child (``polar_tap``), a scalar pass reads the two kernel
   table rows, gathers the N x N complex64 taps and remodulates (``taps_2d``); formed polar images are stored as
   complex64 (rounding ~-140 dB).
4. The pixels finally take ``A(p) = sum_J I_J(r_J(p), u_J(p)) e^{j4pi r_J(p)/lambda}``.

Sampling: Delta_r = c / (2 B os), Delta_u = lambda / (2 (l_J + dx)(1 + B / 2 f_c) os) with ``os`` the
``oversample`` argument (dx the mean pulse spacing; B = ``bandwidth``, default the data's sample
rate c / (2 dr)).

Error model (:func:`ffbp_error_model`): every interpolation stage (each merge and the final
evaluation) adds the kernel's 2-D error of a flat band at oversampling ``os`` in both dimensions
(:mod:`sarnav.imaging.interpolation_error`); the subaperture images occupy disjoint Doppler bands,
so their energies (and their errors') add; the level-0 range interpolation of the pulses adds the part of its
error that survives the sum over pulses (``summed_interpolation_error``): predicted
``eps = n_stages * eps_2d(os, os) + eps_data``, against an ideal (band-limited) back-projection; under "auto" the
range interpolation is the cheapest with eps_data <= ``_RANGE_SHARE`` (a third) of the stages' error. The
"tile" of this factorisation is the subaperture (``base_pulses`` x ``merge^levels`` pulses) and
its polar cell (Delta_r, Delta_u). A subaperture that is not straight (navigation errors,
manoeuvres) adds, on the half-planes of step 1, the track's own error (``ffbp_plan.track_error``, in every
prediction); on a plane grid the polar grids' points lie instead on the grid's plane where the track is not straight
(``ffbp_surface``: exact for any track, 2-D merges; ``surface``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData, SarImage
from sarnav.imaging.backprojection import (DEFAULT_BLOCK, DEFAULT_PULSE_BLOCK, backproject_points, bpa_fan_kernel,
                                           bpa_point_kernel,
                                           check_interpolation, check_pulses, grid_points,
                                           resolve_interpolation, sar_image, wavelength_of)
from sarnav.imaging.interpolation_error import kernel_values
from sarnav.imaging.kernels import (GATHER_MODE, UPSAMPLED, cis64, demodulate_parts, polar_tap,
                                    padded_pulses, tabulate, taps_2d)
from sarnav.imaging.ffbp_merge import TWO_PASS_MAX_WIDENING, child_widening, merge_2d, merge_two_pass, two_pass_applies
from sarnav.imaging.interpolation_choice import range_error, resolve_ffbp_range
from sarnav.imaging.ffbp_inputs import FfbpInputs, hull_points
from sarnav.imaging.ffbp_surface import merge_2d_plane, merge_two_pass_plane, plane_points, surface_constants
from sarnav.imaging.ffbp_plan import (BASE_CHOICES, FFBP_KERNELS, POLAR_MARGIN, TABLE_STEPS, FfbpPlan,  # noqa: F401
                                      check_kernel, child_margin, ffbp_error_model, ffbp_plan, plan_cost,
                                      plan_for_error, polar_margins)

__all__ = ["ffbp", "ffbp_plan", "ffbp_error_model", "FfbpPlan", "FFBP_KERNELS", "BASE_CHOICES", "polar_image",
           "kernel_table", "FfbpInputs", "PlannedFfbp", "plan_ffbp", "form_ffbp"]

_C = 299792458.0
#: the level-0 range interpolation's share of the error under "auto": at most this times the polar stages' predicted
#: error (-4.8 dB: the sum within 1.25 dB of the stages'). A third, not a quarter: on the peer's collect (fs/B 4)
#: Lagrange on the pulses as they are (-56.6 dB) then serves kaiser6 up to os 2.5 with 2-3 merges; with a quarter, os
#: 2.4-2.5 needed x2 FFT upsampling for 0.1-0.4 dB, which cost up to half the time again (docs/backprojection.md)
_RANGE_SHARE = 1 / 3


def kernel_table(kernel: str, oversample: float) -> np.ndarray:
    """(F + 1, N) float32: the N tap weights of ``kernel`` for a point at fraction w = i / F past sample floor:
    tap t sits at offset t - (N/2 - 1), at distance w - t + N/2 - 1 (``kernels.tabulate``; the kernel at ``oversample``:
    ``interpolation_error.kernel_values``; F = ``ffbp_plan.TABLE_STEPS[kernel]``: a point reads the nearest row, whose
    rounding the error model counts, ``ffbp_plan.table_error``)."""
    table = tabulate(lambda x: kernel_values(kernel, x, oversample), FFBP_KERNELS[kernel], TABLE_STEPS[kernel])
    return np.ascontiguousarray(table, dtype=np.float32)


# ---------------------------------------------------------------------------------------------
# compiled kernel: evaluate a demodulated polar image at 3-D points, remodulate, accumulate

@numba.njit(parallel=True, fastmath=True, cache=True)
def _polar_eval(pts, ref_r, centre, v, r0, inv_dr, u0, inv_du, img, two_over_lambda, ktab, block,
                out_re, out_im):  # pragma: no cover - compiled
    """out += polar image ``img`` ((nr, nu) complex64) at the points, remodulated by
    exp(j 4 pi (r(q) - ref_r) / lambda) (ref_r: (M,) parent ranges, 0 for the final pixels). Blocks of points
    in parallel; per block a vectorised float64 pass (``polar_tap``) and a scalar pass that reads the kernel table,
    gathers the N x N taps and remodulates (``taps_2d``)."""
    nr, nu = img.shape
    flat = img.ravel()
    nt = ktab.shape[1]
    half = nt // 2
    m = pts.shape[0]
    for blk in numba.prange((m + block - 1) // block):
        i0 = blk * block
        n = min(m, i0 + block) - i0
        base = np.empty(n, np.uint32)
        wr = np.empty(n, np.float32)
        wu = np.empty(n, np.float32)
        f = np.empty(n, np.float32)
        for i in range(n):
            base[i], wr[i], wu[i], f[i] = polar_tap(pts[i0 + i, 0], pts[i0 + i, 1], pts[i0 + i, 2], ref_r[i0 + i],
                                                    centre, v, r0, inv_dr, u0, inv_du, nr, nu, two_over_lambda, half)
        taps_2d(flat, nu, n, base, wr, wu, f, ktab, out_re, out_im, i0)


@numba.njit(parallel=True, fastmath=True, cache=True)
def _polar_eval_plane(origin, e_row, e_col, ny, nx, tile, centre, v, r0, inv_dr, u0, inv_du, img, two_over_lambda,
                      ktab, out, last, wide):  # pragma: no cover - compiled
    """out (ny * nx) complex64 += polar image ``img`` at the pixels origin + i e_row + j e_col of a plane grid,
    generated tile by tile (``tile`` x ``tile`` pixels: their polar footprint stays in cache), remodulated by
    exp(j 4 pi r(q) / lambda); as ``_polar_eval`` without reading pixel coordinates, summed in float32 (a few tens
    of subimages: rounding ~-140 dB). ``last``: the sum goes to ``wide`` (complex128) instead (no separate widening
    pass over the image)."""
    nr, nu = img.shape
    flat = img.ravel()
    nt = ktab.shape[1]
    half = nt // 2
    nty = (ny + tile - 1) // tile
    ntx = (nx + tile - 1) // tile
    for ty in numba.prange(nty):                  # a row of tiles per work item: work arrays allocated once for it
        iy0 = ty * tile
        my = min(ny, iy0 + tile) - iy0
        base = np.empty(tile * tile, np.uint32)
        wr = np.empty(tile * tile, np.float32)
        wu = np.empty(tile * tile, np.float32)
        f = np.empty(tile * tile, np.float32)
        acc_re = np.empty(tile * tile, np.float32)
        acc_im = np.empty(tile * tile, np.float32)
        for tx in range(ntx):
            ix0 = tx * tile
            mx = min(nx, ix0 + tile) - ix0
            n = my * mx
            for a in range(my):
                for b in range(mx):
                    i = a * mx + b
                    qx = origin[0] + (iy0 + a) * e_row[0] + (ix0 + b) * e_col[0]
                    qy = origin[1] + (iy0 + a) * e_row[1] + (ix0 + b) * e_col[1]
                    qz = origin[2] + (iy0 + a) * e_row[2] + (ix0 + b) * e_col[2]
                    base[i], wr[i], wu[i], f[i] = polar_tap(qx, qy, qz, 0.0, centre, v, r0, inv_dr, u0, inv_du, nr,
                                                            nu, two_over_lambda, half)
                    acc_re[i] = 0.0
                    acc_im[i] = 0.0
            taps_2d(flat, nu, n, base, wr, wu, f, ktab, acc_re, acc_im, 0)
            for a in range(my):
                o = (iy0 + a) * nx + ix0
                for b in range(mx):
                    i = a * mx + b
                    if last:
                        wide[o + b] = np.complex128(out[o + b]) + complex(acc_re[i], acc_im[i])
                    else:
                        out[o + b] += np.complex64(complex(acc_re[i], acc_im[i]))


@numba.njit(fastmath=True, cache=True)
def _demodulate_lines(out_re, out_im, r0, dr, two_over_lambda, img):  # pragma: no cover - compiled
    """img (nr, nu) complex64 = the level-0 sums (nu lines of nr ranges, line-major float64 parts) times
    exp(-j 4 pi r / lambda), r = r0 + i dr (the phase reduced to its fractional cycle in float64, ``cis64``): the
    demodulation and the transpose in one pass."""
    nr, nu = img.shape
    for i in range(nr):
        cyc = (r0 + i * dr) * two_over_lambda
        c, s_ = cis64(-(cyc - np.floor(cyc + 0.5)))
        for j in range(nu):
            re = out_re[j * nr + i]
            im = out_im[j * nr + i]
            img[i, j] = np.complex64(complex(re * c - im * s_, re * s_ + im * c))


# ---------------------------------------------------------------------------------------------
# polar grids

@dataclass
class _Polar:
    centre: np.ndarray
    w: np.ndarray
    r0: float
    dr: float
    nr: int
    u0: float
    du: float
    nu: int
    img: np.ndarray | None = None          # (nr, nu) complex64, once formed
    sc: np.ndarray | None = None           # on the image's plane: ffbp_surface.surface_constants; else the half-plane

    def directions(self, v: np.ndarray) -> np.ndarray:
        """(nu, 3) unit vectors e(u) = u v + sqrt(1 - u^2) w: the grid's points are q(r, u) = centre + r e(u)."""
        u = self.u0 + np.arange(self.nu) * self.du
        return u[:, None] * v + np.sqrt(np.clip(1.0 - u * u, 0.0, None))[:, None] * self.w

    def points(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = self.r0 + np.arange(self.nr) * self.dr
        q = self.centre + r[:, None, None] * self.directions(v)[None]   # (nr, nu, 3)
        return q.reshape(-1, 3), np.broadcast_to(r[:, None], (self.nr, self.nu)).reshape(-1)


def _polar_grid(pos: np.ndarray, v: np.ndarray, hull: np.ndarray, scene_centre: np.ndarray, dr: float,
                spacing: float, lam_eff: float, os: float,
                margin: tuple[int, int] = (POLAR_MARGIN, POLAR_MARGIN), plane=None) -> _Polar:
    c = pos.mean(axis=0)
    off = scene_centre - c
    w = off - np.dot(off, v) * v
    nw = np.linalg.norm(w)
    if nw == 0:
        raise InputDataError("grid", "scene centre lies on the track line: polar grid undefined")
    w /= nw
    d = hull - c
    r = np.linalg.norm(d, axis=1)
    u = d @ v / r
    length = float(np.ptp((pos - c) @ v)) + spacing
    du = lam_eff / (2.0 * length * os)
    m_r, m_u = margin                          # samples beyond the pixels' extent (ffbp_plan.polar_margins)
    r0 = float(r.min()) - m_r * dr
    u0 = float(u.min()) - m_u * du
    nr = int(math.ceil((float(r.max()) + m_r * dr - r0) / dr)) + 1
    nu = int(math.ceil((float(u.max()) + m_u * du - u0) / du)) + 1
    if nr * nu >= 2**31:  # kernels.polar_tap's flat index is int32 (16 GiB of complex64 per polar image before that)
        raise ConfigError("grid", f"a polar image of {nr} x {nu} samples: at most 2^31 - 1; form the image in tiles")
    return _Polar(c, w, r0, dr, nr, u0, du, nu, None, None if plane is None else surface_constants(c, v, w, *plane))


def _tile_order(shape, tile: int = 32) -> np.ndarray:
    """Flat pixel indices of a (Ny, Nx) (or any) grid visited tile by tile."""
    if len(shape) != 2:
        return np.arange(int(np.prod(shape)))
    ny, nx = shape
    iy = np.arange(ny)[:, None]
    ix = np.arange(nx)[None, :]
    key = ((iy // tile) * ((nx + tile - 1) // tile) + ix // tile) * (tile * tile) + (iy % tile) * tile + ix % tile
    slots = np.full(int(key.max()) + 1, -1, dtype=np.int64)          # keys are distinct: a scatter sorts them
    slots[key.ravel()] = np.arange(ny * nx)
    return slots[slots >= 0]


def _demodulate(values: np.ndarray, r: np.ndarray, lam: float) -> np.ndarray:
    re, im = demodulate_parts(values, r, lam)
    return (re + 1j * im).reshape(values.shape)


class _Former:
    """Builds polar images recursively (depth first: memory of one branch only)."""

    def __init__(self, rc, pos, lam, v, hull, centre, dr, spacing, lam_eff, plan, interpolation, upsample, two_pass,
                 plane=None):
        self.rc, self.pos, self.lam, self.v, self.two_pass, self.plane = rc, pos, lam, v, two_pass, plane
        self.b_over_fc = 2.0 * (lam / lam_eff - 1.0)      # lam_eff = lam / (1 + B / (2 f_c))
        self.wide_children = 0                             # children merged with the 2-D kernel in a two-pass plan
        self.hull, self.centre, self.dr, self.spacing, self.lam_eff = hull, centre, dr, spacing, lam_eff
        self.plan, self.interpolation, self.upsample = plan, interpolation, upsample
        self.ktab = kernel_table(plan.kernel, plan.oversample)
        self.margins = polar_margins(plan.kernel, plan.merge, plan.levels)
        self.half = FFBP_KERNELS[plan.kernel] // 2
        self._pulses = None                     # (k0, k1, padded samples, kernel constants) of the current top block

    def _prepare(self, k0: int, k1: int) -> None:
        """Pulses k0..k1 (one top-level subimage) ready for the range kernel: FFT-upsampled (complex64), zero-padded."""
        padded, rng, n = padded_pulses(self.rc.data[k0:k1], self.rc.slant_range,
                                       self.upsample if self.interpolation in UPSAMPLED else 1, np.complex64)
        d = float(rng[1] - rng[0])
        self._pulses = (k0, k1, padded, (float(rng[0]) / d, 1.0 / d, float(n - 1), 2.0 / self.lam,
                                         GATHER_MODE[self.interpolation], DEFAULT_BLOCK, DEFAULT_PULSE_BLOCK))

    def _level0(self, grid: _Polar, k0: int, k1: int) -> np.ndarray:
        """Exact back-projection of pulses k0..k1 along the grid's lines of constant u (range quadratic along each
        line: ``backprojection.bpa_fan_kernel``), demodulated by exp(-j 4 pi r / lambda) (a function of the line's
        range only): the (nr, nu) complex64 polar image."""
        if self._pulses is None or not (self._pulses[0] <= k0 and k1 <= self._pulses[1]):
            self._prepare(k0, k1)
        b0, _, padded, common = self._pulses
        out_re = np.zeros(grid.nu * grid.nr)
        out_im = np.zeros(grid.nu * grid.nr)
        ant = np.ascontiguousarray(self.pos[k0:k1])
        if grid.sc is not None:                      # on the image's plane: the points of each line (ffbp_surface)
            pts = np.empty((3, grid.nu * grid.nr))
            plane_points(grid.centre, self.v, grid.w, grid.sc, grid.r0, grid.dr, grid.nr, grid.u0, grid.du, grid.nu,
                         *pts)
            bpa_point_kernel(*pts, ant, padded[k0 - b0:k1 - b0], *common, out_re, out_im)
        else:
            e = grid.directions(self.v)
            bpa_fan_kernel(np.ascontiguousarray(grid.centre + grid.r0 * e), np.ascontiguousarray(grid.dr * e), grid.nr,
                           ant, padded[k0 - b0:k1 - b0], *common, out_re, out_im)
        img = np.empty((grid.nr, grid.nu), np.complex64)
        _demodulate_lines(out_re, out_im, grid.r0, grid.dr, 2.0 / self.lam, img)
        return img

    def build(self, k0: int, k1: int, level: int, margin: tuple[int, int] | None = None) -> _Polar:
        """The polar image of pulses k0..k1 at ``level`` with ``margin`` (range, angle) samples beyond the pixels' extent
        (default: the final image's; each child's from its parent's, ``ffbp_plan.child_margin``)."""
        margin = self.margins[-1] if margin is None else margin
        if level > 0 and level == self.plan.levels:
            self._prepare(k0, k1)
        step = self.plan.base_pulses * self.plan.merge ** (level - 1) if level > 0 else 0
        if level > 0 and k1 - k0 <= step:    # one child (the aperture's last, short block): the parent's grid is the
            return self.build(k0, k1, level - 1, margin)  # child's (the same pulses), so it is the image as it is
        grid = _polar_grid(self.pos[k0:k1], self.v, self.hull, self.centre, self.dr, self.spacing, self.lam_eff,
                           self.plan.oversample, margin, self.plane)
        if level == 0:
            grid.img = self._level0(grid, k0, k1)
            return grid
        acc = np.zeros((grid.nr, grid.nu), np.complex64)
        for j0 in range(k0, k1, step):
            j1 = min(k1, j0 + step)
            child = self.build(j0, j1, level - 1, child_margin(margin, k1 - k0, j1 - j0, self.half))
            two = self.two_pass and child_widening(float(np.dot(child.centre - grid.centre, self.v)),
                                                   (j1 - j0) * self.spacing, self.b_over_fc) <= TWO_PASS_MAX_WIDENING
            self.wide_children += self.two_pass and not two
            at = (grid.r0, grid.dr, grid.u0, grid.du, child.centre, child.r0, 1.0 / child.dr, child.u0, 1.0 / child.du,
                  child.img, 2.0 / self.lam, self.ktab, acc)
            if grid.sc is not None:
                (merge_two_pass_plane if two else merge_2d_plane)(grid.centre, self.v, grid.w, grid.sc, *at)
            else:
                (merge_two_pass if two else merge_2d)(grid.centre, self.v, grid.w, *at)
        grid.img = acc
        return grid


#: points per parallel work item of the final evaluation (a 16 x 16 tile of pixels: their polar footprint is small)
_EVAL_BLOCK = 256
#: side of the pixel tiles of the plane-grid final evaluation
_EVAL_TILE = 16


def _evaluate(g: _Polar, q, ref_r, v, lam, ktab, out_re, out_im):
    _polar_eval(q, ref_r, g.centre, v, g.r0, 1.0 / g.dr, g.u0, 1.0 / g.du, g.img, 2.0 / lam, ktab, _EVAL_BLOCK, out_re,
                out_im)


def _plan_range(rc, p, kw, interpolation, upsample, pos, v, hull, centre, spacing, lam_eff):
    """(plan, range interpolation, upsample): "auto" -> ``resolve_ffbp_range`` for eps_data <= ``_RANGE_SHARE`` x the
    polar stages' predicted error (for the level-0 grid's points per pulse); "precise" as ``backproject``'s."""
    bw = kw["bandwidth"]
    if interpolation == "auto":
        polar = ffbp_plan(p, **kw)
        g0 = _polar_grid(pos[:polar.base_pulses], v, hull, centre, _C / (2 * bw * polar.oversample), spacing, lam_eff,
                         polar.oversample, polar_margins(polar.kernel, polar.merge, polar.levels)[0])
        interpolation, upsample = resolve_ffbp_range(rc, bw, _RANGE_SHARE * 10 ** (polar.predicted_error_db / 10),
                                                     g0.nr * g0.nu)
    interpolation, upsample = resolve_interpolation(rc, interpolation, upsample, bw)
    return ffbp_plan(p, **kw, data_error=range_error(rc, interpolation, upsample, bw)), interpolation, upsample


def _for_error(error_db, oversample, rc, p, base_pulses, merge, levels, kernel, interpolation, upsample, bw, cost_at,
               track):
    """(oversample, base_pulses, levels, kernel) of the cheapest plan predicted within ``error_db`` (``plan_for_error``; under
    "auto" the range interpolation's share is ``_RANGE_SHARE``, else its error is known in advance)."""
    if oversample is not None:
        raise ConfigError("error_db", f"give error_db or oversample, not both (error_db chooses the oversampling; "
                                      f"oversample={oversample!r})")
    if interpolation == "auto":
        share, fixed = _RANGE_SHARE, 0.0
    else:
        share, fixed = 0.0, range_error(rc, *resolve_interpolation(rc, interpolation, upsample, bw), bw)
    return plan_for_error(error_db, p, cost_at, base_pulses=base_pulses, merge=merge, levels=levels, kernel=kernel,
                          data_share=share, data_error=fixed, track=track)


def _plan(rc, p, n_pix, pos, v, hull, centre, spacing, lam_eff, bw, fc, fact, oversample, kernel, error_db,
          interpolation, upsample):
    """(plan, range interpolation, upsample, two-pass merges) for ``ffbp``'s arguments (``fact``: base_pulses, merge,
    levels as given): with ``error_db`` the cheapest (os, base, levels, kernel) predicted within it."""
    base_pulses, merge, levels, track = fact["base_pulses"], fact["merge"], fact["levels"], fact["track"]
    if kernel is not None:
        check_kernel(kernel)
    check_interpolation(interpolation, upsample)

    two_pass = isinstance(merge, (int, np.integer)) and merge >= 2 and two_pass_applies(int(merge), bw, fc)
    if error_db is not None:
        oversample, base_pulses, levels, kernel = _for_error(
            error_db, oversample, rc, p, base_pulses, merge, levels, kernel, interpolation, upsample, bw,
            lambda o, kern: plan_cost(p, n_pix, pos, v, hull, bw, o, spacing, lam_eff, merge, FFBP_KERNELS[kern],
                                      two_pass), track)
    kernel = "kaiser6" if kernel is None else kernel
    taps = FFBP_KERNELS[kernel]
    oversample = 2.0 if oversample is None else oversample
    os_ = float(oversample) if isinstance(oversample, (int, float)) else oversample
    cost = plan_cost(p, n_pix, pos, v, hull, bw, os_, spacing, lam_eff, merge, taps, two_pass) \
        if isinstance(os_, float) and os_ >= 1.5 and isinstance(merge, int) and merge >= 2 else None
    kw = dict(base_pulses=base_pulses, merge=merge, levels=levels, oversample=oversample, bandwidth=bw, cost=cost,
              kernel=kernel, track=track)
    return (*_plan_range(rc, p, kw, interpolation, upsample, pos, v, hull, centre, spacing, lam_eff), two_pass)


def ffbp(rc: PulseData, grid, positions=None, *, wavelength: float | None = None, bandwidth: float | None = None,
         base_pulses: int | None = None, merge: int = 4, levels: int | None = None, oversample: float | None = None,
         kernel: str | None = None, interpolation: str = "auto", upsample: int = 8,
         error_db: float | None = None, surface: str | None = None) -> SarImage:
    """Form an image by fast factorised back-projection (module doc); same conventions as ``backproject``.

    Parameters
    ----------
    rc, grid, positions, wavelength : as :func:`sarnav.imaging.backprojection.backproject` (pixel and
        antenna positions in one Cartesian frame, float64).
    bandwidth : signal bandwidth B [Hz] (sets the polar range sampling); default the band ``backproject``'s "auto"
        uses: ``rc.bandwidth``, else the width of the pulses' mean spectrum above 1 % of its peak
        (``interpolation_choice.data_oversampling``), at most the sample rate c / (2 dr).
    base_pulses, merge, levels : factorisation: subapertures of ``base_pulses`` pulses formed exactly, then ``levels``
        merges of ``merge`` children each (default: the (base, levels) of least operation count, ``ffbp_plan``).
    oversample : polar samples per Nyquist sample in range and angle (>= 1.5; error model in
        :func:`ffbp_error_model`); default 2, or chosen by ``error_db``.
    kernel : polar-image interpolation, one of :data:`FFBP_KERNELS`: "kaiser6" (6 x 6 taps, Kaiser-windowed
        sinc; -50.6 dB a stage at os 2; the default), "kaiser8" / "kaiser10" (8 x 8 / 10 x 10 taps: -73.3 / -90.6 dB
        a stage at os 2.5) or "cubic" (4 x 4 Keys;
        -47.5 dB a stage at os 4). With ``error_db`` and no kernel, the cheapest of kaiser6, kaiser8 and kaiser10.
    interpolation, upsample : range interpolation of the pulses in the level-0 formation, as ``backproject``'s; "auto"
        (default): the cheapest whose predicted error is a third of the polar stages' (``resolve_ffbp_range``: at
        fs / B = 4 Lagrange on the pulses as they are; at 2 FFT-upsampled pulses, Lagrange x2 or linear x5-x6 as the
        level-0 grid's points per pulse weigh against the FFTs).
    error_db : a target for the predicted error [dB] instead of ``oversample``: the plan of least operation count
        (``ffbp_plan.plan_for_error``: os 1.6-4.0 in 0.1 steps and, unless given, the subaperture length and levels)
        whose prediction, the range interpolation's included, is within it.
    surface : where the polar images lie: "half-plane" (through each subaperture's centre towards the scene centre:
        exact for a straight subaperture, the track's error ``ffbp_plan.track_error`` counted in the prediction),
        "plane" (a plane grid's own plane, ``ffbp_surface``: exact for any track; 2-D merges), or None (default): the
        plane for a plane grid whose track is not straight (its error over -100 dB), else the half-plane.

    Returns
    -------
    SarImage (complex128), ``metadata["algorithm"] = "ffbp"`` plus the plan and its predicted error against an ideal
    (band-limited) back-projection: the polar stages' plus the level-0 range interpolation's, the band B it
    assumed (``ffbp_bandwidth_hz``) and how the merges interpolated (``ffbp_merge_passes``: 2 for two 1-D passes, 1
    for the 2-D kernel; ``ffbp_wide_children``: the children of a two-pass plan whose own band widening,
    ``ffbp_merge.child_widening``, was too wide, merged with the 2-D kernel).
    """
    s = FfbpInputs(rc, grid, positions, wavelength, bandwidth)
    return form_ffbp(rc, s, plan_ffbp(rc, s, base_pulses=base_pulses, merge=merge, levels=levels, oversample=oversample,
                                      kernel=kernel, error_db=error_db, interpolation=interpolation, upsample=upsample,
                                      surface=surface))


@dataclass(frozen=True)
class PlannedFfbp:
    """An FFBP image's plan (:func:`plan_ffbp`): the factorisation, the level-0 range interpolation, whether merges
    take two 1-D passes, and the predicted cost [back-projected pixel-pulses, ``ffbp_plan.plan_cost``]."""

    plan: FfbpPlan
    interpolation: str
    upsample: int
    two_pass: bool
    cost: float
    plane: tuple | None = None       # (origin, unit normal) of the polar images' plane (ffbp_surface); None: half-planes


#: the half-planes' track error (linear, ``ffbp_plan.track_error`` with the whole aperture as one subaperture) above
#: which a plane grid's polar images lie on its plane (``ffbp_surface``): -100 dB, under the least error a plan
#: predicts (kaiser10 at os 4, -98.7 dB), so a straight track keeps the half-planes and their two-pass merges
_TRACK_NEGLIGIBLE = 1e-10


def plan_ffbp(rc: PulseData, s: FfbpInputs, *, base_pulses=None, merge=4, levels=None, oversample=None, kernel=None,
              error_db=None, interpolation="auto", upsample=8, surface=None) -> PlannedFfbp:
    """:func:`ffbp`'s plan for its arguments on the inputs ``s`` (a ConfigError naming ``error_db`` where no plan
    reaches it)."""
    plane = _surface_plane(s, surface)
    plan, interpolation, upsample, two_pass = _plan(
        rc, s.p, s.n_pix, s.pos, s.v, s.hull, s.centre, s.spacing, s.lam_eff, s.bw, s.fc,
        dict(base_pulses=base_pulses, merge=merge, levels=levels, track=None if plane else s.track), oversample, kernel,
        error_db, interpolation, upsample)
    cost = plan_cost(s.p, s.n_pix, s.pos, s.v, s.hull, s.bw, plan.oversample, s.spacing, s.lam_eff, plan.merge,
                     FFBP_KERNELS[plan.kernel], two_pass)(plan.base_pulses, plan.levels)
    return PlannedFfbp(plan, interpolation, upsample, two_pass, float(cost), plane)


def _surface_plane(s: FfbpInputs, surface):
    """(origin, unit normal) of the plane the polar images lie on, or None for the half-planes: ``surface`` "plane"
    (a plane grid only), "half-plane", or None: the plane where the grid is one and the track is not straight
    (:data:`_TRACK_NEGLIGIBLE`)."""
    if surface not in (None, "plane", "half-plane"):
        raise ConfigError("surface", f"must be 'plane', 'half-plane' or None, got {surface!r}")
    if s.plane is None or surface == "half-plane":
        if surface == "plane":
            raise ConfigError("surface", "'plane' puts the polar images on a plane grid's plane: this grid is a list "
                                         "of points")
        return None
    if surface is None and s.track(s.p) <= _TRACK_NEGLIGIBLE:
        return None
    origin, e_row, e_col = s.plane[:3]
    n = np.cross(e_row, e_col)
    return origin, n / np.linalg.norm(n)


def form_ffbp(rc: PulseData, s: FfbpInputs, planned: PlannedFfbp) -> SarImage:
    """The image of ``planned`` (:func:`ffbp` steps 2-4) on the inputs ``s``, with its metadata."""
    plan, interpolation, upsample, two_pass = planned.plan, planned.interpolation, planned.upsample, planned.two_pass
    dr = _C / (2.0 * s.bw * plan.oversample)
    rc_c = PulseData(s.data, s.rng, np.asarray(rc.pulse_times), s.pos, None, compressed=True, wavelength=s.lam)
    former = _Former(rc_c, s.pos, s.lam, s.v, s.hull, s.centre, dr, s.spacing, s.lam_eff, plan, interpolation,
                     upsample, two_pass, planned.plane)
    step, p, v, lam = plan.final_pulses, s.p, s.v, s.lam
    if s.plane is not None:                      # pixels generated tile by tile (no coordinates read)
        origin, e_row, e_col, ny, nx = s.plane
        acc = np.zeros(ny * nx, np.complex64)
        values = np.empty(ny * nx, np.complex128)
        starts = range(0, p, step)
        for k0 in starts:
            sb = former.build(k0, min(p, k0 + step), plan.levels)
            _polar_eval_plane(origin, e_row, e_col, ny, nx, _EVAL_TILE, sb.centre, v, sb.r0, 1.0 / sb.dr, sb.u0,
                              1.0 / sb.du, sb.img, 2.0 / lam, former.ktab, acc, k0 == starts[-1], values)
    else:
        order = _tile_order(s.shape)    # pixels in 32 x 32 tiles: polar footprint stays in cache
        tiled = np.ascontiguousarray(s.flat[order])
        out_re = np.zeros(s.n_pix)
        out_im = np.zeros(s.n_pix)
        zero = np.zeros(s.n_pix)
        for k0 in range(0, p, step):
            sub = former.build(k0, min(p, k0 + step), plan.levels)
            _evaluate(sub, tiled, zero, v, lam, former.ktab, out_re, out_im)
        values = np.empty(s.n_pix, dtype=np.complex128)
        values[order] = out_re + 1j * out_im
    img = sar_image(s.grid, values.reshape(s.shape), rc, lam, interpolation, upsample, "ffbp")
    img.metadata.update({"ffbp_base_pulses": plan.base_pulses, "ffbp_merge": plan.merge, "ffbp_levels": plan.levels,
                         "ffbp_oversample": plan.oversample, "ffbp_kernel": plan.kernel,
                         "ffbp_predicted_error_db": plan.predicted_error_db, "ffbp_bandwidth_hz": s.bw,
                         "ffbp_track_error_db": plan.track_error_db,
                         "ffbp_surface": "half-plane" if planned.plane is None else "plane",
                         "ffbp_merge_passes": 2 if two_pass else 1, "ffbp_wide_children": former.wide_children})
    return img


def polar_image(rc: PulseData, grid, positions=None, *, wavelength: float | None = None,
                bandwidth: float | None = None, oversample: float = 1.0, interpolation: str = "upsample",
                upsample: int = 4):
    """The demodulated full-aperture polar image ``I(r, u)`` covering ``grid`` (exact back-projection).

    ``I(r, u) = sum_k s_k(R_k(q)) exp(j 4 pi (R_k(q) - r) / lambda)`` at ``q(r, u)`` (module doc, step 1;
    r from the aperture centre c, u = direction cosine against the track direction v). Along u it
    is a sum of tones ``exp(-j 4 pi s_k u / lambda)``, one per pulse (s_k = (a_k - c).v): the
    back-projected image with its spherical wavefront removed, the domain of phase autofocus.

    Returns
    -------
    (values (Nr, Nu) complex128, r (Nr,) [m], u (Nu,), s (P,) pulse offsets along v [m], lambda [m])
    """
    g, pts = grid_points(grid)
    data, rng, pos = check_pulses(rc, positions)
    lam = wavelength_of(rc, wavelength)
    bw = _C / (2.0 * float(rng[1] - rng[0])) if bandwidth is None else float(bandwidth)
    track = pos[-1] - pos[0]
    if data.shape[0] < 2 or np.linalg.norm(track) == 0:
        raise InputDataError("positions", "need >= 2 pulses on a moving track to define the polar image")
    v = track / np.linalg.norm(track)
    flat = pts.reshape(-1, 3)
    lam_eff = lam / (1.0 + bw / (2.0 * _C / lam))
    spacing = float(np.linalg.norm(track)) / (data.shape[0] - 1)
    pg = _polar_grid(pos, v, hull_points(pts), flat.mean(axis=0), _C / (2.0 * bw * oversample), spacing, lam_eff,
                     oversample)
    q, rq = pg.points(v)
    sub = PulseData(data, rng, np.asarray(rc.pulse_times), pos, None, compressed=True, wavelength=lam)
    vals = _demodulate(backproject_points(sub, q, interpolation=interpolation, upsample=upsample), rq, lam)
    r = pg.r0 + np.arange(pg.nr) * pg.dr
    u = pg.u0 + np.arange(pg.nu) * pg.du
    return vals.reshape(pg.nr, pg.nu), r, u, (pos - pg.centre) @ v, lam
