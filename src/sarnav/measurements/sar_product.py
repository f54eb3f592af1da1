"""Reference (b): the reference chip *predicted* from a geocoded image product (an orthoimage and a DEM) in the
in-flight image's geometry along the navigator's estimated track (docs/recording.md §6b); and reference (a) over
terrain: a CPHD reference pass's chip taken through a DEM to that geometry (:func:`reference_in_flight_geometry`).

Where the CPHD reference (``ReferencePulses``) is imaged along its trusted track and a chip cut around the target,
a product reference (:class:`ProductReference`) is resampled: every pixel of the chip the in-flight image will be
searched with is taken to the ground point it images, and the product's amplitude read there.

* **Pixel -> (time, range).** RDA: row i is the zero-Doppler time ``times[0] + i / prf`` (circular in the block), column
  j the slant range of the in-flight range axis; BPA: the pixel is a point of the extractor's flat ground grid, whose
  time and range of closest approach to the focusing track give the same pair (a back-projected image puts a
  scatterer where the range history matches: the grid point with its zero-Doppler time and range).
* **(time, range) -> ground.** The point Q on the zero-Doppler plane of the estimated track at that time (the plane
  through the antenna position P normal to the track's direction d), at that range, on the look side, on the product's
  surface: Q = P + a c + b w, c the horizontal unit normal to d toward the look side, w = d x c (downward), a^2 + b^2 =
  r^2, down(Q) = the DEM's down at Q (fixed-point iteration from the anchor's height; a few centimetres of height
  change per iteration for hills of tens of metres, ``GROUND_ITERATIONS``).
* **Anchor.** The reference point's position (where the product puts it) taken through the same geometry: its time
  and range of closest approach to the estimated track give its fractional pixel in the chip.

The product's noise (:func:`product_noise_power`) is estimated from the product itself; its correlation is taken as
the in-flight image's (the same radar's resolution; a product sampled finer or coarser than the in-flight image is
resampled, which keeps the noise's correlation length in metres). Only the chip's amplitude exists: the registration
is by magnitude, as with a CPHD reference, and the predicted 1-sigma's mismatch test (``imaging.registration.
magnitude_shift_precision``) scales it by the residual of the fit when the predicted pattern and the image differ
more than their noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sarnav.errors import InputDataError
from sarnav.signal.data import PulseData

__all__ = ["GeocodedProduct", "ProductReference", "product_noise_power", "ground_points", "closest_approaches",
           "rda_pixels", "track_at", "predicted_amplitude", "reference_in_flight_geometry", "reference_in_flight",
           "GROUND_ITERATIONS"]

#: reference_in_flight_geometry: range samples kept beyond the chip's reach on each side of the segment it FFT-upsamples
#: (the segment's ends ring) and the upsampling factor before the cubic spline
WARP_MARGIN = 24
WARP_UPSAMPLE = 8
#: fixed-point iterations of the ground point on the DEM (each reduces a height error by the slope x grazing ratio)
GROUND_ITERATIONS = 5


class GeocodedProduct(Protocol):
    """An orthoimage and its surface in the navigator's NED frame (``recording.ortho.OrthoProduct``)."""

    noise_power: float | None

    def amplitude(self, points) -> np.ndarray: ...

    def surface_down(self, points) -> np.ndarray: ...

    def values(self) -> np.ndarray: ...


@dataclass(frozen=True)
class ProductReference:
    """Reference (b) of one sub-aperture as the extractor needs it: ``times`` (P,) the in-flight pulse times [s];
    ``product`` the :class:`GeocodedProduct`; ``raw`` a raw-echo template of the in-flight acquisition (its shape,
    range axis and radar fields: the noise model runs unit noise through the in-flight chain); ``amplitude``,
    ``snr_db`` the receiver noise per raw sample (as ``ReferencePulses``); ``seconds`` the source's time."""

    times: np.ndarray
    product: GeocodedProduct
    raw: PulseData
    amplitude: float
    snr_db: float
    seconds: float = 0.0


def product_noise_power(product: GeocodedProduct) -> float:
    """The product's noise power per pixel: stated (``product.noise_power``), else median(|A|^2) / ln 2 over its
    valid pixels: the mean power of complex circular Gaussian noise whose amplitude is Rayleigh (|n|^2 exponential:
    median = N ln 2), the background of a scene whose bright features cover under half of the product. Speckle of
    weak clutter counts as noise: the chip's clutter decorrelates between the passes."""
    if product.noise_power is not None:
        return float(product.noise_power)
    v = np.asarray(product.values(), dtype=np.float64)
    n = float(np.median(v * v)) / math.log(2.0)
    if not n > 0:
        raise InputDataError("reference.image", "has no noise floor (median amplitude 0): state its noise power")
    return n


def _look_axes(direction, look_side: str):
    """(c, w) (..., 3): the horizontal unit normal to ``direction`` toward the look side, and d x c (downward)."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.stack([-d[..., 1], d[..., 0], np.zeros(d.shape[:-1])], axis=-1)
    c = c / np.linalg.norm(c, axis=-1, keepdims=True) * (1.0 if look_side == "right" else -1.0)
    w = np.cross(d, c)
    return c, w * np.sign(w[..., 2:3])


def ground_points(positions, directions, ranges, product: GeocodedProduct, look_side: str, down0) -> np.ndarray:
    """(..., 3) the ground points at slant range ``ranges`` (...) on the zero-Doppler planes of antenna
    ``positions`` (..., 3) moving along ``directions`` (..., 3), on the product's surface (module docstring);
    ``down0``: the starting height (the anchor's down). NaN where the range does not reach the surface."""
    P = np.asarray(positions, dtype=np.float64)
    r = np.asarray(ranges, dtype=np.float64)
    c, w = _look_axes(directions, look_side)
    down = np.full(r.shape, float(down0))
    for _ in range(GROUND_ITERATIONS):
        b = (down - P[..., 2]) / w[..., 2]
        a = np.sqrt(np.maximum(r * r - b * b, 0.0))
        Q = P + a[..., None] * c + b[..., None] * w
        down = product.surface_down(Q)
    b = (down - P[..., 2]) / w[..., 2]
    a = np.sqrt(np.where(r * r >= b * b, r * r - b * b, np.nan))
    return P + a[..., None] * c + b[..., None] * w


def closest_approaches(points, times, track) -> tuple[np.ndarray, np.ndarray]:
    """(time, range) of closest approach of the sampled ``track`` (P, 3) at ``times`` (P,) to each of ``points``
    (..., 3): the parabola through the squared ranges of the three samples around the nearest (exact for constant
    velocity; ``trajectory.sampled.closest_approach``, vectorised), extended beyond the track's ends (the
    estimate's closest approach of a point the radar sees broadside may lie outside the aperture when the estimated
    heading is off)."""
    q = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    t = np.asarray(times, dtype=np.float64)
    r2 = np.sum((track[None, :, :] - q[:, None, :]) ** 2, axis=2)
    k = np.clip(np.argmin(r2, axis=1), 1, t.size - 2)
    i = np.arange(q.shape[0])
    ym, y0, yp = r2[i, k - 1], r2[i, k], r2[i, k + 1]
    dt = 0.5 * (t[k + 1] - t[k - 1])
    a = 0.5 * (yp + ym - 2.0 * y0) / (dt * dt)
    bb = 0.5 * (yp - ym) / dt
    x = np.where(a > 0, -bb / (2.0 * np.where(a > 0, a, 1.0)), 0.0)  # beyond the ends: the end's parabola
    eta = t[k] + x
    rng = np.sqrt(np.maximum(y0 + bb * x + a * x * x, 0.0))
    shape = np.shape(points)[:-1]
    return eta.reshape(shape), rng.reshape(shape)


def track_at(times, track, eta) -> tuple[np.ndarray, np.ndarray]:
    """(positions, unit directions) (..., 3) of the sampled track at the times ``eta`` (...): linear interpolation,
    extrapolated straight beyond the ends (an RDA row's time may lie outside the block: rows wrap, and the estimate's
    zero-Doppler time of a point may too); the direction of the local finite difference."""
    t = np.asarray(times, dtype=np.float64)
    e = np.asarray(eta, dtype=np.float64)
    vel = np.gradient(track, t, axis=0)
    still = np.linalg.norm(vel, axis=1) == 0  # a track held still (interpolation beyond its epochs): its mean heading
    vel[still] = (track[-1] - track[0]) / (t[-1] - t[0])
    pos = np.stack([np.interp(e, t, track[:, i]) for i in range(3)], axis=-1)
    d = np.stack([np.interp(e, t, vel[:, i]) for i in range(3)], axis=-1)
    pos = np.where((e < t[0])[..., None], track[0] + (e - t[0])[..., None] * vel[0], pos)
    pos = np.where((e > t[-1])[..., None], track[-1] + (e - t[-1])[..., None] * vel[-1], pos)
    return pos, d / np.linalg.norm(d, axis=-1, keepdims=True)


def rda_pixels(times, prf: float, slant_range, anchor_eta: float, anchor_range: float, half_rows: int,
               half_cols: int):
    """The RDA chip around an anchor at (``anchor_eta``, ``anchor_range``): (eta (m, n), range (m, n), rows (m,)
    of the block (circular), the anchor's fractional offset from the chip centre (rows, columns))."""
    n_p = len(times)
    fi = (anchor_eta - times[0]) * prf
    fj = (anchor_range - slant_range[0]) / (slant_range[1] - slant_range[0])
    i0, j0 = int(round(fi)), int(round(fj))
    rows = np.arange(i0 - half_rows, i0 + half_rows + 1)
    cols = np.arange(j0 - half_cols, j0 + half_cols + 1)
    if cols[0] < 0 or cols[-1] >= slant_range.size:
        raise InputDataError("sar", "the predicted reference chip leaves the receive window")
    eta = times[0] + rows / prf
    dr = slant_range[1] - slant_range[0]
    rng = slant_range[0] + cols * dr
    return (np.broadcast_to(eta[:, None], (rows.size, cols.size)), np.broadcast_to(rng[None, :], (rows.size, cols.size)),
            rows % n_p, (fi - i0, fj - j0))


def predicted_amplitude(product: GeocodedProduct, times, track, eta, rng, look_side: str, down0) -> np.ndarray:
    """The product's amplitude at the ground points imaged at (eta, rng) (module docstring); InputDataError when the
    product (or its DEM) does not cover the chip."""
    pos, d = track_at(times, track, eta)
    q = ground_points(pos, d, rng, product, look_side, down0)
    amp = product.amplitude(q)
    if not np.all(np.isfinite(amp)):
        raise InputDataError("reference.image", "does not cover the reference chip (NaN or nodata pixels)")
    return amp


def reference_in_flight_geometry(image, rows, cols, target, times, prf: float, track, ref_track, surface,
                                 look_side: str) -> np.ndarray:
    """The chip of :func:`reference_in_flight` alone."""
    return reference_in_flight(image, rows, cols, target, times, prf, track, ref_track, surface, look_side)[0]


def reference_in_flight(image, rows, cols, target, times, prf: float, track, ref_track, surface,
                        look_side: str, wavelength: float | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """(chip, phase turn) of reference (a) over terrain: the chip of the reference pass's RDA ``image`` (rows: the block's pulses, circular;
    columns: slant range ``image.x``) at ``rows`` (m,) x ``cols`` (n,) around ``target``, taken to the in-flight
    image's geometry along the estimated ``track`` (P, 3) through the DEM ``surface`` (``surface_down``).

    From another pass a hill is seen from another look angle: the slant range of a ground point differs between the
    passes by an amount that changes with its height (parallax), so the two images differ by a warp that a rigid
    shift cannot follow (the terrain scene from a pass 30 m aside and 20 m up: along-track error 1.34-1.44 x its
    predicted sigma, 0.89 on flat ground; docs/scenarios/rda-nav.md §6). Each pixel of the chip's lattice, moved to
    where the target falls in the in-flight image (its time and range of closest approach to ``track`` instead of to
    ``ref_track``), is the in-flight (time, range) of a ground point on the DEM (``ground_points``); the point's
    closest approach to the reference pass's ``ref_track`` gives where the reference image saw it, read there by
    cubic splines of the real and imaginary parts. The chip keeps its lattice's anchor and noise model (the same
    pixel spacing; the warp is a small fraction of a pixel per pixel). InputDataError when a ground point is not on
    the surface or falls outside the reference image.

    The warp moves the speckle, but cannot make it the same: each ground scatterer's phase differs between the passes
    by (4 pi / lambda) (r_ref - r_flight), and over relief that difference turns from pixel to pixel (on a slope s
    along track at k_z s, k_z = 4 pi B_perp / (lambda R sin theta): the two passes share only part of their looks;
    docs/scenarios/rda-nav.md §6). With ``wavelength`` [m] the second value is that phase [rad] at each pixel's ground
    point, relative to the lattice's centre pixel (the target's): the turn of the in-flight image's clutter against
    the target (``imaging.registration.magnitude_shift_precision``'s ``phase_turn``); None without it."""
    from scipy import ndimage, signal

    n_p = int(image.shape[0])
    eta0, r0 = (float(x) for x in closest_approaches(target, times, ref_track))
    eta_a, r_a = (float(x) for x in closest_approaches(target, times, track))
    x0, dx = float(image.x[0]), float(image.dx)
    shape = (len(rows), len(cols))  # the chip's lattice: a time per row, a slant range per column
    eta = np.broadcast_to(times[0] + np.asarray(rows, dtype=np.float64)[:, None] / prf + (eta_a - eta0), shape)
    rng = np.broadcast_to(x0 + np.asarray(cols, dtype=np.float64)[None, :] * dx + (r_a - r0), shape)
    pos, d = track_at(times, track, eta)
    q = ground_points(pos, d, rng, surface, look_side, float(target[2]))
    if not np.all(np.isfinite(q)):
        raise InputDataError("sar", "the reference chip's ground points do not reach the surface")
    eta_r, r_r = closest_approaches(q, times, ref_track)
    fi = ((eta_r - times[0]) * prf).reshape(eta.shape)
    fj = ((r_r - x0) / dx).reshape(eta.shape)
    c0, c1 = int(np.floor(fj.min())) - WARP_MARGIN, int(np.ceil(fj.max())) + WARP_MARGIN + 1
    if c0 < 0 or c1 > image.shape[1]:
        raise InputDataError("sar", "the reference chip taken through the DEM leaves the reference image")
    # range is sampled near Nyquist (fs/B ~ 1.2): a cubic spline of the complex samples would add a -17 dB error
    # (docs/backprojection.md); FFT-upsampled by WARP_UPSAMPLE first (band-limited), the spline's error is ~-56 dB
    seg = signal.resample(np.asarray(image.data)[:, c0:c1], WARP_UPSAMPLE * (c1 - c0), axis=1)
    at = [np.mod(fi, n_p), (fj - c0) * WARP_UPSAMPLE]
    chip = (ndimage.map_coordinates(seg.real, at, order=3, mode="grid-wrap")
            + 1j * ndimage.map_coordinates(seg.imag, at, order=3, mode="grid-wrap"))
    if wavelength is None:
        return chip, None
    phase = (4.0 * np.pi / float(wavelength)) * (r_r - closest_approaches(q, times, track)[1]).reshape(eta.shape)
    return chip, phase - phase[len(rows) // 2, len(cols) // 2]
