"""The image of a collect: range-compressed pulses at their own antenna positions (such as a CPHD file read by
``io.cphd.read_collect``) formed on a plane grid, and the figures that describe the collect and the image.

Formation: back-projection (``imaging.backprojection.backproject``, ``"bpa"``), fast factorised back-projection
(``imaging.ffbp.ffbp``, ``"ffbp"``) or the faster of the two within -60 dB of exact (:func:`auto_image`,
``"auto"``: FFBP planned for :data:`AUTO_ERROR_DB` where the track allows it and it costs less), an optional azimuth window weighting the pulses in slow time. The collect's
figures are read from the data alone: the signal's band from its range spectrum
(``backprojection.data_oversampling``: fs / B with fs = c / 2 dr), the PRF from the pulse times, the speed from the
mean spacing of the antenna positions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging import quality
from sarnav.imaging.backprojection import backproject, data_oversampling
from sarnav.imaging.ffbp import ffbp, form_ffbp, plan_ffbp
from sarnav.imaging.ffbp_inputs import FfbpInputs
from sarnav.imaging.interpolation_choice import auto_cost
from sarnav.signal.data import PulseData, SarImage
from sarnav.signal.windows import as_window
from sarnav.units import C

__all__ = ["ALGORITHMS", "AUTO_ERROR_DB", "CollectFigures", "auto_image", "collect_figures", "form_collect_image",
           "collect_image_metrics", "run_collect_image"]

ALGORITHMS = ("auto", "bpa", "ffbp")


@dataclass(frozen=True)
class CollectFigures:
    """A collect's radar figures, read from its pulses (the ``image.npz`` fields of ``report.image_files``)."""

    carrier_frequency: float  # c / wavelength [Hz]
    bandwidth: float  # the signal's band [Hz], from its range spectrum
    wavelength: float  # [m]
    prf: float  # mean pulse rate [Hz]
    speed: float  # mean antenna speed [m/s]


def collect_figures(rc: PulseData) -> CollectFigures:
    """The :class:`CollectFigures` of ``rc`` (module docstring)."""
    fs = C / (2.0 * float(rc.slant_range[1] - rc.slant_range[0]))
    bandwidth = fs / data_oversampling(rc)                  # the signal's band, from its spectrum
    prf = (rc.n_pulses - 1) / float(np.ptp(rc.pulse_times))
    speed = float(np.mean(np.sqrt(np.sum(np.diff(rc.positions, axis=0) ** 2, axis=1))) * prf)
    lam = rc.carrier_wavelength
    return CollectFigures(C / lam, bandwidth, lam, prf, speed)


#: the predicted error [dB] (the whole image's, ``ffbp_error_model`` plus the track's) :func:`auto_image` plans FFBP
#: for: the -60 dB of back-projection's "auto" contract on a uniform pixel sample (issue 28) less 15 dB. 10 dB of it:
#: the uniform sample's error ran 6-10 dB above the whole image's on the peer's point-target collect (mostly dim
#: pixels between the targets, where an error spread evenly weighs most: FFBP at -75 dB read -67.8 / -64.9 dB there at
#: 1024^2 / 2048^2); 5 dB: the margin back-projection's "auto" keeps (interpolation_choice.AUTO_MAX_ERROR)
AUTO_ERROR_DB = -75.0


def auto_image(rc: PulseData, grid, positions=None, *, wavelength: float | None = None,
               bandwidth: float | None = None, error_db: float = AUTO_ERROR_DB) -> SarImage:
    """The image of ``rc`` on ``grid`` by the faster of FFBP planned for ``error_db`` (``ffbp.ffbp``, the track's own
    error counted: ``ffbp_plan.track_error``) and exact back-projection under "auto" (``backproject``), each by its
    predicted cost (``ffbp_plan.plan_cost``, ``interpolation_choice.auto_cost``, both in back-projected pixel-pulses);
    back-projection where no FFBP plan reaches ``error_db`` (a track too far off its line, a target under the
    kernels' reach) or FFBP cannot run (one pulse). ``metadata["algorithm"]`` says which formed it and
    ``metadata["algorithm_choice"]`` why."""
    if isinstance(error_db, bool) or not isinstance(error_db, (int, float)) or not (math.isfinite(error_db)
                                                                                     and error_db < 0):
        raise ConfigError("error_db", f"must be a finite number of dB below 0, got {error_db!r}")
    try:
        inputs = FfbpInputs(rc, grid, positions, wavelength, bandwidth)
        planned = plan_ffbp(rc, inputs, error_db=float(error_db))
    except (ConfigError, InputDataError) as err:     # back-projection names a bad input, or forms what FFBP cannot
        if isinstance(err, ConfigError) and err.field not in ("error_db", "bandwidth"):
            raise
        why = f"no FFBP plan reaches {error_db:g} dB: {err.message}" if err.field == "error_db" else \
            f"FFBP: {err.field}: {err.message}"
    else:
        exact = auto_cost(rc, bandwidth, inputs.n_pix)
        if planned.cost < exact:
            img = form_ffbp(rc, inputs, planned)
            img.metadata["algorithm_choice"] = f"ffbp: predicted {planned.plan.predicted_error_db:.1f} dB at " \
                                               f"{planned.cost / exact:.2g} x exact back-projection's cost"
            return img
        why = f"FFBP's plan for {error_db:g} dB costs {planned.cost / exact:.2g} x exact back-projection"
    img = backproject(rc, grid, positions, wavelength=wavelength, bandwidth=bandwidth)
    img.metadata["algorithm_choice"] = f"bpa: {why}"
    return img


def form_collect_image(rc: PulseData, grid, algorithm: str = "bpa", window=None, *,
                       window_field: str = "window") -> SarImage:
    """The image of ``rc`` on ``grid`` (a plane or point grid, ``imaging.grid``) by ``algorithm`` (one of
    :data:`ALGORITHMS`), the pulses weighted by the azimuth ``window`` (None: none; errors name ``window_field``);
    the window's label is recorded in the image metadata."""
    if algorithm not in ALGORITHMS:
        raise ConfigError("algorithm", f"must be one of {ALGORITHMS}, got {algorithm!r}")
    w = as_window(window or "none", window_field)
    if w.name != "none":
        rc = rc.__class__(**{**rc.__dict__, "data": rc.data * w.samples(rc.n_pulses)[:, None]})
    # ffbp's default band is the signal's (the pulses' spectrum), as backproject's "auto" and collect_figures use: a
    # file's stored band can be twice the signal's (guard bands), which made the polar grids twice as fine as needed
    img = backproject(rc, grid) if algorithm == "bpa" else ffbp(rc, grid) if algorithm == "ffbp" else auto_image(rc, grid)
    img.metadata["window"] = w.label
    return img


def collect_image_metrics(rc: PulseData, img: SarImage, algorithm: str, bandwidth: float) -> dict:
    """The figures of an image of a collect (``metrics.json`` of ``sarnav image FILE.cphd``): the collect's size,
    carrier and band, the image's size and spacing, its quality (``quality.quality_summary``) and, for FFBP, the
    factorisation's figures (``ffbp_*`` metadata, among them its predicted error); under "auto" the algorithm that
    formed it (``formed_by``) and why (``algorithm_choice``)."""
    md = img.metadata
    formed = md.get("algorithm", algorithm)
    report = {"algorithm": algorithm, "n_pulses": int(rc.n_pulses),
              "n_range_samples": int(rc.data.shape[1]), "image_shape": list(img.shape),
              "pixel_spacing_m": {img.y_name: img.dy, img.x_name: img.dx},
              "carrier_frequency_hz": C / rc.carrier_wavelength, "bandwidth_hz": bandwidth,
              "interpolation": md.get("interpolation"),
              "quality": quality.quality_summary(img.data)}
    if algorithm == "auto":
        report.update(formed_by=formed, algorithm_choice=md.get("algorithm_choice"))
    if formed == "ffbp":
        report["ffbp"] = {k[5:]: md[k] for k in md if k.startswith("ffbp_")}
    return report


def run_collect_image(rc: PulseData, grid, algorithm: str = "bpa", window=None, *,
                      window_field: str = "window") -> tuple[SarImage, CollectFigures, dict]:
    """What ``sarnav image FILE.cphd`` computes: the image of ``rc`` on ``grid`` (:func:`form_collect_image`), the
    collect's figures (:func:`collect_figures`) and the image's metrics (:func:`collect_image_metrics`)."""
    img = form_collect_image(rc, grid, algorithm, window, window_field=window_field)
    figures = collect_figures(rc)
    return img, figures, collect_image_metrics(rc, img, algorithm, figures.bandwidth)
