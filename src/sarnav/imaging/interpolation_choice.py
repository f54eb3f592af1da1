"""Which range interpolation "auto" and "precise" back-projection use (issue 28): accuracy first, speed second.

From the data's oversampling fs/B (:func:`data_oversampling`) and the flat-band error model of
:mod:`sarnav.imaging.interpolation_error`, :func:`resolve_interpolation` finds each kernel's smallest FFT upsampling
that meets the mode's predicted error, then, for "auto", the one of least predicted time for the image's pixel count
(the gathers' measured cost per pixel-pulse against the upsampling's FFTs). docs/backprojection.md gives the measured
errors of each choice.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft as sfft

from sarnav.errors import ConfigError
from sarnav.imaging.interpolation_error import interpolation_error, summed_interpolation_error
from sarnav.imaging.kernels import RANGE_KERNEL, UPSAMPLED
from sarnav.signal.data import PulseData

__all__ = ["AUTO_MAX_ERROR", "PRECISE_MAX_ERROR", "data_oversampling", "resolve_interpolation", "resolve_ffbp_range",
           "range_error", "auto_cost"]

#: "auto" picks the cheapest of linear / upsample x2..x8 / lagrange / upsample-lagrange x2..x32 whose predicted error
#: (flat band at fs/B * factor, per-sample error of the kernel: sarnav.imaging.interpolation_error) is at most this:
#: -65 dB for the -60 dB contract, the margin "precise" keeps over its goal (the images' measured errors run 1-4 dB
#: above the per-sample prediction: linear x6 on the peer's collect at fs/B 4, -61.5 dB at 1024^2 and -59.6 dB at
#: 2048^2 against -63.1 dB predicted; docs/backprojection.md)
AUTO_MAX_ERROR = 10 ** -6.5
#: "precise" picks the smallest upsampling whose predicted Lagrange error is at most this (-80 dB: <= -75 dB measured
#: with margin, docs/backprojection.md)
PRECISE_MAX_ERROR = 1e-8
#: largest FFT upsampling "auto" and "precise" choose
_MAX_FACTOR = 32
#: largest FFT upsampling "auto" puts under linear interpolation (linear reaches AUTO_MAX_ERROR at fs/B >~ 28, so x8
#: serves data with fs/B >= 3.5; the flat-band error model was checked for linear up to x8 at fs/B 1.25-4 and x16 at
#: fs/B 2, docs/backprojection.md; where linear needs more, Lagrange reaches the same error on a quarter of the
#: samples or fewer, and the upsampled pulses' memory grows with the factor)
_MAX_LINEAR_FACTOR = 8
#: cost per pixel-pulse of the compiled gathers relative to linear (bench_bpa and the peer's collect, 2 cores,
#: 2026-12-05: linear 1.1-1.2e9, Lagrange 7.2e8 pixel-pulses/s, on plain and on upsampled pulses alike)
_GATHER_COST = {"linear": 1.0, "lagrange": 1.6}
#: cost of FFT-upsampling per output sample in linear pixel-pulses (906 pulses x 3267 samples, 2 threads: x2 in
#: 0.048 s, x8 in 0.26 s, 9-13 pixel-pulses of 8.7e-10 s each per output sample)
_FFT_COST = 12.0

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


def resolve_interpolation(rc: PulseData, interpolation: str, upsample: int, bandwidth: float | None = None,
                          pixels: int | None = None):
    """(mode, upsample) actually used. "auto": accuracy first, speed second: of linear on the pulses or on pulses
    FFT-upsampled x2..x8 ("upsample") and Lagrange on them or upsampled x2..x32 ("upsample-lagrange"), each with
    the smallest factor whose predicted error (:func:`sarnav.imaging.interpolation_error`) is <= ``AUTO_MAX_ERROR``,
    the one of least predicted time for ``pixels`` pixels (:func:`_auto_cost`; ``pixels=None``: an image large
    against the pulses, the upsampling's FFTs not counted). fs/B = 1 -> upsample-lagrange x6, 1.2 -> x5, 2 -> x3
    (linear would need x14), 4 -> upsample x7 on a large image, upsample-lagrange x2 on a small one, >~ 28 ->
    linear.
    "precise": Lagrange only, for ``PRECISE_MAX_ERROR`` (fs/B = 1 -> x9, 2 -> x5, >= 12: Lagrange alone)."""
    if interpolation not in ("auto", "precise"):
        return interpolation, upsample
    os_ = data_oversampling(rc, bandwidth)
    if interpolation == "precise":
        factor = _smallest_factor("lagrange", os_, PRECISE_MAX_ERROR, _MAX_FACTOR)
        factor = _MAX_FACTOR if factor is None else factor
        return ("lagrange", upsample) if factor == 1 else ("upsample-lagrange", factor)
    n_samples = int(np.shape(rc.data)[1]) if np.ndim(rc.data) == 2 else 1
    return _cheapest(os_, AUTO_MAX_ERROR, n_samples, pixels, upsample, interpolation_error)


def resolve_ffbp_range(rc: PulseData, bandwidth: float | None, limit: float, points: int) -> tuple[str, int]:
    """(mode, upsample) of FFBP's "auto" level-0 range interpolation: as back-projection's "auto", but each kernel's
    smallest upsampling is the one whose *summed* error (:func:`summed_interpolation_error`: the part that survives
    the sum over pulses, what FFBP's error model adds) is <= ``limit``, and the time is weighed for ``points`` polar
    samples per pulse. Pulses oversampled enough for Lagrange alone (fs/B >= 4 at -56 dB) are not upsampled at all:
    the FFTs of x8 upsampling took half of FFBP's time on the peer's collect (fs/B 4, 2048^2, docs/backprojection.md)."""
    n_samples = int(np.shape(rc.data)[1]) if np.ndim(rc.data) == 2 else 1
    return _cheapest(data_oversampling(rc, bandwidth), limit, n_samples, points, 8, summed_interpolation_error)


def range_error(rc: PulseData, mode: str, factor: int, bandwidth: float | None) -> float:
    """Predicted error (linear) of a resolved range interpolation ``mode`` (FFT upsampling ``factor``) of the pulses
    that survives the sum over pulses (:func:`summed_interpolation_error`; "upsample": linear at fs/B x factor,
    "upsample-lagrange": Lagrange): what FFBP's error model adds for its level 0."""
    os_data = data_oversampling(rc, bandwidth)
    if mode in UPSAMPLED:
        return summed_interpolation_error(RANGE_KERNEL[mode], os_data * factor)
    return summed_interpolation_error(RANGE_KERNEL[mode], os_data)


def auto_cost(rc: PulseData, bandwidth: float | None, pixels: int) -> float:
    """Predicted time of back-projecting ``rc`` onto ``pixels`` pixels under "auto" [linear pixel-pulses]: the pulses
    times :func:`_auto_cost` of the mode "auto" resolves to (what ``imaging.collect_image.auto_image`` weighs FFBP's plan
    against)."""
    mode, factor = resolve_interpolation(rc, "auto", 4, bandwidth, pixels)
    n_samples = int(np.shape(rc.data)[1]) if np.ndim(rc.data) == 2 else 1
    per = _auto_cost(RANGE_KERNEL[mode], factor if mode in UPSAMPLED else 1, n_samples, pixels)[0]
    return float(np.shape(rc.data)[0]) * per


def _cheapest(os_: float, limit: float, n_samples: int, pixels: int | None, upsample: int, error) -> tuple[str, int]:
    """Of linear (FFT upsampling x1..x8) and Lagrange (x1..x32), each with its smallest factor whose ``error(kernel,
    fs/B x factor)`` is <= ``limit``, the (mode, upsample) of least :func:`_auto_cost`; none: Lagrange on x32."""
    best = None
    for kernel, top in (("linear", _MAX_LINEAR_FACTOR), ("lagrange", _MAX_FACTOR)):
        factor = next((f for f in range(1, top + 1) if error(kernel, os_ * f) <= limit), None)
        if factor is not None:
            cost = _auto_cost(kernel, factor, n_samples, pixels)
            if best is None or cost < best[0]:
                best = (cost, kernel, factor)
    if best is None:
        return "upsample-lagrange", _MAX_FACTOR
    _, kernel, factor = best
    if factor == 1:
        return kernel, upsample
    return ("upsample" if kernel == "linear" else "upsample-lagrange"), factor


def _smallest_factor(kernel: str, os_: float, limit: float, top: int) -> int | None:
    """The smallest FFT upsampling in 1..top (1: none) at which ``kernel`` interpolates data oversampled ``os_``
    within ``limit`` (predicted mean-square error), else None."""
    return next((f for f in range(1, top + 1) if interpolation_error(kernel, os_ * f) <= limit), None)


def _auto_cost(kernel: str, factor: int, n_samples: int, pixels: int | None) -> tuple[float, float]:
    """Predicted time per pulse of back-projecting with ``kernel`` on pulses upsampled by ``factor``, in linear
    pixel-pulses: pixels x the gather's cost (:data:`_GATHER_COST`) plus, upsampled, the output samples x
    :data:`_FFT_COST`. ``pixels=None``: (gather cost, FFT cost) compared in that order."""
    fft = _FFT_COST * n_samples * factor if factor > 1 else 0.0
    if pixels is None:
        return _GATHER_COST[kernel], fft
    return pixels * _GATHER_COST[kernel] + fft, 0.0
