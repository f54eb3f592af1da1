"""The image of a CPHD collect formed block by block, its memory bounded by a budget whatever the file's size.

Back-projection is a sum over pulses (thesis (4.27)), and the FFBP image of a set of pulses is the sum of the FFBP
images of its blocks (each block an exact back-projection up to its own factorisation's error): the vectors are read
``block`` at a time (:meth:`io.cphd_read.CphdCollect.phase_history`: only those bytes are read), turned into pulses
on the one range axis of the whole selection (``signal.phase_history.default_range_axis`` of the header: the same
axis for every block), imaged and added. The block size is the largest whose estimated peak fits the budget
(:func:`stream_plan`: the fixed part, i.e. PVPs and the image, plus ``block`` times the bytes of one vector's read,
conversion and imaging); the blocks are then balanced. The interpolation of back-projection is chosen once for all
blocks, from the band of 8 vectors in the middle of the selection, so that the image does not depend on the
budget (only the float64 summation order does).
"""

from __future__ import annotations

import math

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import backproject, data_oversampling, resolve_interpolation
from sarnav.imaging.collect_image import ALGORITHMS, AUTO_ERROR_DB, CollectFigures, auto_image, collect_image_metrics
from sarnav.imaging.ffbp import ffbp
from sarnav.imaging.kernels import UPSAMPLED
from sarnav.io.cphd_read import DEFAULT_BUDGET, CphdCollect, conversion_bytes
from sarnav.signal.data import PulseData, SarImage
from sarnav.signal.phase_history import DEFAULT_OVERSAMPLE, default_range_axis, phase_history_to_pulses
from sarnav.signal.windows import as_window

__all__ = ["image_collect", "run_image_collect", "stream_plan", "StreamPlan", "DEFAULT_BUDGET", "read_sicd_geometry",
           "read_budget_flag", "read_pulses_flag", "read_error_db_flag"]

_C = 299792458.0
_FFBP_UPSAMPLE = 8                 # bound on ffbp's "auto" level-0 range upsampling (x5 at fs/B 1, none at 4)
_PIXEL_BYTES = {"bpa": 64, "ffbp": 192}   # accumulator, the former's outputs (and FFBP's polar images) per pixel
_FIXED_BYTES = 2**20               # small arrays, slack
_BAND_VECTORS = 8                  # vectors in the middle of the selection whose spectrum gives the band


class StreamPlan:
    """Block size and memory of an image formed in blocks (:func:`stream_plan`)."""

    def __init__(self, pulses_per_block: int, n_blocks: int, vector_bytes: int, fixed_bytes: int, budget: float):
        self.pulses_per_block = pulses_per_block
        self.n_blocks = n_blocks
        self.vector_bytes = vector_bytes
        self.fixed_bytes = fixed_bytes
        self.budget = budget

    @property
    def peak_bytes(self) -> int:
        """Estimated peak [bytes]: fixed part + one block."""
        return self.fixed_bytes + self.pulses_per_block * self.vector_bytes

    def as_dict(self) -> dict:
        return {"pulses_per_block": self.pulses_per_block, "blocks": self.n_blocks, "budget_bytes": float(self.budget),
                "estimated_peak_bytes": self.peak_bytes}


def read_error_db_flag(value, algorithm: str, field: str = "error_db"):
    """FFBP's target error as a float (None when not given): a finite number of dB below 0, only with ``algorithm``
    "ffbp" or "auto"; a ConfigError naming ``field`` otherwise."""
    if value is None:
        return None
    if algorithm not in ("ffbp", "auto"):
        raise ConfigError(field, f"plans an FFBP image: give it with --algorithm ffbp or auto, not {algorithm!r}")
    try:
        db = float(value)
    except (TypeError, ValueError):
        raise ConfigError(field, f"must be a number of dB, e.g. -70, got {value!r}") from None
    if not (math.isfinite(db) and db < 0):
        raise ConfigError(field, f"must be a finite number of dB below 0, e.g. -70, got {value!r}")
    return db


def _check_budget(budget, field: str) -> float:
    try:
        b = float(budget)
    except (TypeError, ValueError):
        raise ConfigError(field, f"must be a number of bytes > 0, got {budget!r}") from None
    if not (math.isfinite(b) and b > 0):
        raise ConfigError(field, f"must be finite and > 0 bytes, got {budget!r}")
    return b


def stream_plan(c: CphdCollect, m: int, pixels: int, algorithm: str, upsample: int | None,
                budget: float = DEFAULT_BUDGET, *, budget_field: str = "budget") -> StreamPlan:
    """How many vectors of ``c`` to image at a time on ``m`` range samples and ``pixels`` pixels within ``budget``
    [bytes] (``upsample``: back-projection's FFT upsampling factor, None when it interpolates the samples directly).
    ConfigError naming ``budget_field`` when not even the smallest block fits."""
    budget = _check_budget(budget, budget_field)
    per, fixed = _costs(c, m, pixels, algorithm, upsample)
    least = 2 if algorithm == "ffbp" else 1
    fit = int((budget - fixed) // per)
    if fit < min(least, c.n_pulses):
        raise ConfigError(budget_field, f"{budget / 2**20:.4g} MiB cannot hold the image ({pixels} pixels) and "
                          f"{least} vector(s) of {c.n_samples} samples on {m} range samples: needs at least "
                          f"{(fixed + least * per) / 2**20:.4g} MiB")
    n_blocks = math.ceil(c.n_pulses / max(fit, least))
    block = math.ceil(c.n_pulses / n_blocks)
    return StreamPlan(block, n_blocks, per, fixed, budget)


def _costs(c: CphdCollect, m: int, pixels: int, algorithm: str, upsample: int | None) -> tuple[int, int]:
    """(bytes per vector of a block, bytes fixed whatever the block) of imaging ``c`` on ``m`` range samples."""
    up = _FFBP_UPSAMPLE if algorithm == "ffbp" else (upsample or 0)
    # the block's pulses (M complex128) stay while the next stage runs: the read and conversion, then the former's
    # complex64 copy, its FFT upsampling (spectrum, up x M, in place) and its padded copy (up x M)
    per = 16 * m + max(conversion_bytes(c.n_samples, m, c.raw_itemsize), 32 * m + 24 * up * m)
    return per, _FIXED_BYTES + _PIXEL_BYTES[algorithm] * pixels + 8 * c.pvp.nbytes


def band_vectors(c: CphdCollect, m: int, pixels: int, algorithm: str, budget: float) -> int:
    """How many middle vectors the band is estimated from: :data:`_BAND_VECTORS`, fewer when the budget cannot hold
    them with the image (their read is a block of its own, before the plan is known)."""
    per, fixed = _costs(c, m, pixels, algorithm, None)
    return int(max(1, min(_BAND_VECTORS, c.n_pulses, (budget - fixed) // per)))


def _check_aperture(c: CphdCollect) -> None:
    pos = c.positions
    span = float(np.max(np.linalg.norm(pos - pos[0], axis=1)))
    lam = _C / c.fxc
    if not span >= lam:
        raise InputDataError("cphd.PVP.TxPos", f"the {c.n_pulses} vectors span {span:.3g} m of track: no synthetic "
                             f"aperture (at least one wavelength, {lam:.3g} m, is needed)")


def _pulses(c: CphdCollect, k0: int, k1: int, axis: np.ndarray, filt) -> PulseData:
    ph = c.phase_history(k0, k1)
    return phase_history_to_pulses(ph, axis, wavelength=_C / c.fxc, filter=filt,
                                   metadata={"source": "cphd", "file": str(c.path), "channel": c.channel})


def _figures(c: CphdCollect, mid: PulseData) -> CollectFigures:
    """``collect_image.collect_figures`` of the whole selection: the band from the middle vectors' spectrum."""
    fs = _C / (2.0 * float(mid.slant_range[1] - mid.slant_range[0]))
    bandwidth = fs / data_oversampling(mid)
    t = np.asarray(c.pvp["TxTime"], np.float64)
    prf = (c.n_pulses - 1) / float(np.ptp(t)) if c.n_pulses > 1 and np.ptp(t) > 0 else float("nan")
    pos = c.positions
    speed = float(np.mean(np.sqrt(np.sum(np.diff(pos, axis=0) ** 2, axis=1))) * prf) if c.n_pulses > 1 else 0.0
    return CollectFigures(c.fxc, bandwidth, _C / c.fxc, prf, speed)


def image_collect(c: CphdCollect, grid, algorithm: str = "auto", *, window=None, window_field: str = "window",
                  filter=None, range_axis=None, oversample: float = DEFAULT_OVERSAMPLE, budget: float = DEFAULT_BUDGET,
                  budget_field: str = "budget", error_db: float | None = None,
                  error_db_field: str = "error_db") -> tuple[SarImage, CollectFigures, dict]:
    """The image of the selected vectors of ``c`` (``io.cphd_read.open_collect``) on ``grid`` by ``algorithm``
    ("auto", "bpa" or "ffbp"), formed in blocks within ``budget`` bytes (module doc); the azimuth ``window`` over all
    the selected pulses, ``filter`` the frequency samples' weights, ``error_db`` FFBP's target error
    (``imaging.ffbp.ffbp``; under "auto" instead of ``collect_image.AUTO_ERROR_DB``: ``imaging.collect_image.auto_image``, block by
    block). Returns what ``imaging.collect_image.run_collect_image`` returns for the whole collect read into memory
    (image, figures, metrics), the metrics with ``stream`` (blocks, pulses per block, budget, estimated peak) and under
    "auto" ``auto_blocks`` (how many blocks each algorithm formed)."""
    if algorithm not in ALGORITHMS:
        raise ConfigError("algorithm", f"must be one of {ALGORITHMS}, got {algorithm!r}")
    if error_db is not None and algorithm == "bpa":
        raise ConfigError(error_db_field, "plans an FFBP image: applies to algorithm 'ffbp' or 'auto', not 'bpa'")
    memory = "bpa" if algorithm == "bpa" else "ffbp"          # "auto" is planned for the larger of the two
    _check_aperture(c)
    axis = default_range_axis(c.header(), oversample) if range_axis is None else np.asarray(range_axis, np.float64)
    p = c.n_pulses
    pixels = int(np.prod(grid.shape))
    n_band = band_vectors(c, axis.size, pixels, memory, _check_budget(budget, budget_field))
    k0 = max(0, p // 2 - n_band // 2)
    mid = _pulses(c, k0, min(p, k0 + n_band), axis, filter)        # the band, once for all blocks
    figures = _figures(c, mid)
    mode, up = ("upsample", _FFBP_UPSAMPLE) if memory == "ffbp" else \
        resolve_interpolation(mid, "auto", 4, figures.bandwidth, pixels)
    del mid
    plan = stream_plan(c, axis.size, pixels, memory, up if mode in UPSAMPLED else None, budget,
                       budget_field=budget_field)
    w = as_window(window or "none", window_field)
    weights = w.samples(p) if w.name != "none" else None
    acc, img, formed = None, None, {}
    for a in range(0, p, plan.pulses_per_block):
        b = min(p, a + plan.pulses_per_block)
        rc = _pulses(c, a, b, axis, filter)
        if weights is not None:
            rc.data *= weights[a:b, None]
        img = backproject(rc, grid, interpolation=mode, upsample=up, bandwidth=figures.bandwidth) \
            if algorithm == "bpa" else _ffbp(rc, grid, figures.bandwidth, error_db, error_db_field, algorithm)
        acc = img.data if acc is None else acc + img.data
        formed[img.metadata["algorithm"]] = formed.get(img.metadata["algorithm"], 0) + 1
        del rc
    img.data = acc
    img.metadata.update({"n_pulses": p, "window": w.label})
    metrics = collect_image_metrics(_Shape(p, axis.size, _C / c.fxc), img, algorithm, figures.bandwidth)
    metrics["stream"] = plan.as_dict()
    if algorithm == "auto":
        metrics["auto_blocks"] = formed
    return img, figures, metrics


def _ffbp(rc, grid, bandwidth, error_db, field, algorithm):
    try:
        if algorithm == "auto":
            return auto_image(rc, grid, bandwidth=bandwidth, error_db=AUTO_ERROR_DB if error_db is None else error_db)
        return ffbp(rc, grid, bandwidth=bandwidth, error_db=error_db)
    except ConfigError as err:            # a target no plan reaches, named as the caller's key
        if err.field == "error_db":
            raise ConfigError(field, err.message) from None
        raise


class _Shape:
    """What ``collect_image_metrics`` reads of the collect: its pulse count, range samples and wavelength."""

    def __init__(self, n_pulses: int, n_range: int, wavelength: float):
        self.n_pulses = n_pulses
        self.data = np.broadcast_to(np.zeros((), np.complex64), (n_pulses, n_range))
        self.carrier_wavelength = wavelength


#: :func:`image_collect` under an entry point's name (``sarnav image FILE.cphd`` wires it: tests/test_structure.py)
run_image_collect = image_collect


def read_sicd_geometry(c, grid):
    """The SICD geometry (``io.sicd.SicdGeometry``) of the collect ``c`` (``open_collect``) on ``grid`` before the
    image is formed: its carrier and band from 8 vectors in the middle (``imaging.collect_image.collect_figures``)."""
    from sarnav.imaging.collect_image import collect_figures
    from sarnav.io.sicd import SicdGeometry
    from sarnav.signal.phase_history import phase_history_to_pulses

    mid = c.n_pulses // 2
    rc = phase_history_to_pulses(c.phase_history(max(mid - 4, 0), min(mid + 4, c.n_pulses)))
    return SicdGeometry(grid, c.positions, c.pulse_times, rc.wavelength, collect_figures(rc).bandwidth)


_UNITS = {"": 1, "B": 1, "K": 2**10, "KB": 2**10, "KIB": 2**10, "M": 2**20, "MB": 2**20, "MIB": 2**20,
          "G": 2**30, "GB": 2**30, "GIB": 2**30}


def read_pulses_flag(value, field: str = "pulses"):
    """``--pulses START:STOP`` (vector indices, STOP exclusive; either may be empty) -> (start, stop) or None."""
    if value is None:
        return None
    parts = str(value).split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        start = int(parts[0]) if parts[0].strip() else 0
        stop = int(parts[1]) if parts[1].strip() else None
    except ValueError:
        raise ConfigError(field, f"must be START:STOP vector indices (STOP exclusive), got {value!r}") from None
    return start, stop


def read_budget_flag(value, field: str = "budget") -> float:
    """``--budget SIZE``: bytes, or a number with K, M, G (binary: MiB, GiB); default :data:`DEFAULT_BUDGET`."""
    if value is None:
        return float(DEFAULT_BUDGET)
    text = str(value).strip().upper()
    num = text.rstrip("KMGIB")
    try:
        v = float(num) * _UNITS[text[len(num):]]
    except (ValueError, KeyError):
        raise ConfigError(field, f"must be a size such as 1.5G, 512M or 1e9 (bytes), got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ConfigError(field, f"must be finite and > 0, got {value!r}")
    return v
