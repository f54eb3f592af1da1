"""What the sub-aperture imager (``measurements.sar_image``) takes and gives: its settings, the pulses of one
sub-aperture as a source hands them (:class:`ReferencePulses`, the :class:`ApertureSource` protocol the simulated
world and a recorded flight implement) and its measurements (:class:`ApertureMeasurements`). Containers only."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sarnav.errors import ConfigError
from sarnav.radar.scene import Scene
from sarnav.signal.data import PulseData

__all__ = ["STAGES", "FAILURES", "ALGORITHMS", "FOCUS", "ImagingSettings", "AperturePasses", "ReferencePulses",
           "ApertureSource", "ApertureMeasurements"]

#: stages timed per image (seconds per run and aperture, ``ApertureMeasurements.seconds``); "rda": image formation
STAGES = ("echoes", "rda", "autofocus", "registration")
ALGORITHMS = ("rda", "bpa")
FOCUS = ("estimate", "mapdrift")
#: why an image gave no measurement (``ApertureMeasurements.status``; 0 = measured)
FAILURES = ("", "image formation or autofocus failed", "registration failed", "weak match (correlation)",
            "ambiguous match")


@dataclass(frozen=True)
class ImagingSettings:
    """Chip, search window, image formation, autofocus and registration settings (docs/scenarios/rda-nav.md §1).

    chip_half_az_cells : chip half-size along track in azimuth resolution cells (lambda R / (2 V T)), at most a
        quarter of the block.
    chip_half_range_m : chip half-size in slant range [m].
    search_half_range_m : slant-range half-window of the in-flight image around the predicted range [m].
    search_half_along_m : BPA: the in-flight grid spans the chip, this margin [m] and 3 filter sigmas of the target's
        along-track position on either side of the predicted target.
    algorithm : "rda" (straight tracks; the paper's processor) or "bpa" (back-projection along the estimated track
        on a ground grid: any track).
    focus : ``"estimate"`` (default): the image used is focused with the estimated trajectory, and the measurement
        model carries the along-track shift this focusing makes, measured by refocusing (docs §2); ``"mapdrift"``:
        the paper's choice (RDA only), the mapdrift-refocused image (within the gate below) with no model of the shift.
    autofocus : run mapdrift (RDA; its correction is recorded as ``autofocus_dk``, and used with focus="mapdrift").
    mapdrift_iterations : look correlations of mapdrift (the paper's single pass, G12).
    mapdrift_gate_sigma, mapdrift_gate_floor : a mapdrift correction implying a speed change beyond this many
        filter sigmas of the forward speed (or the floor [m/s]) is rejected and the image focused with the
        estimated speed is used.
    subpixel : sub-pixel method of the correlation peak ("parabola"), then refined by least squares
        (``imaging.registration.refine_shift``).
    range_lattices : BPA: the chip is formed again on this many lattices offset across track by 1 / N of a
        ground-range pixel and the registered points are averaged (cancels the bias a magnitude shift has with the
        target's place between two nodes when ground range is sampled near Nyquist; 1: one lattice, as before
        2026-12-06; docs/scenarios/rda-nav.md §6).
    terrain_correction : RDA with a CPHD reference whose source gives the scene's surface
        (``ReferencePulses.surface``): the reference chip is taken through the DEM to the in-flight image's lattice
        along the estimated track (``measurements.sar_product.reference_in_flight``), so that the terrain's
        parallax between the two passes is not left to a rigid shift, and the registration sigma counts the phase the
        clutter turned between the passes (``magnitude_shift_precision``'s ``phase_turn``; docs/scenarios/rda-nav.md
        §6). False: the chip as the reference pass saw it, sigma without the turn (before 2026-12-06).
    min_correlation, max_ambiguity : a match is refused (``quality`` < min_correlation: the chip is not in the
        image; ``ambiguity`` > max_ambiguity: another place matches nearly as well) and the update skipped.
    """

    chip_half_az_cells: float = 1.5
    chip_half_range_m: float = 4.0
    search_half_range_m: float = 12.0
    search_half_along_m: float = 6.0
    algorithm: str = "rda"
    focus: str = "estimate"
    autofocus: bool = True
    mapdrift_iterations: int = 1
    mapdrift_gate_sigma: float = 3.0
    mapdrift_gate_floor: float = 0.02
    subpixel: str = "parabola"
    min_correlation: float = 0.5
    max_ambiguity: float = 0.9
    range_lattices: int = 2
    terrain_correction: bool = True

    def __post_init__(self):
        if self.algorithm not in ALGORITHMS:
            raise ConfigError("sar.algorithm", f"must be one of {ALGORITHMS}, got {self.algorithm!r}")
        if self.focus not in FOCUS:
            raise ConfigError("sar.focus", f"must be one of {FOCUS}, got {self.focus!r}")
        if self.algorithm == "bpa" and self.focus == "mapdrift":
            raise ConfigError("sar.focus", "'mapdrift' refocuses an RDA image; with sar.algorithm = 'bpa' use 'estimate'")
        n = self.range_lattices
        if isinstance(n, bool) or not (isinstance(n, int) and 1 <= n <= 8):
            raise ConfigError("range_lattices", f"must be an integer in [1, 8], got {self.range_lattices!r}")
        if not isinstance(self.terrain_correction, bool):
            raise ConfigError("terrain_correction", f"must be true or false, got {self.terrain_correction!r}")


@dataclass(frozen=True)
class AperturePasses:
    """The scene of one sub-aperture as each pass sees it: ``flight`` (the in-flight pass) and ``reference`` (the pass
    the reference product was made from; the same object when nothing changed between the passes)."""

    flight: Scene
    reference: Scene


@dataclass(frozen=True)
class ReferencePulses:
    """The reference pass of one sub-aperture as the extractor needs it.

    times : (P,) pulse times [s] (the in-flight acquisition has the same); pulses : the range-compressed reference
    acquisition; positions, velocities : (P, 3) its trusted antenna track; raw : a raw-echo block of the
    acquisition's shape and radar fields (the noise model runs unit noise through the chain); amplitude, snr_db :
    the receiver noise per raw sample as ``radar.echoes`` defines it, the per-sample SNR of a scatterer of this
    amplitude (noise power amplitude^2 / 10^(snr_db / 10); a recording with a measured noise power N gives
    sqrt(N), 0 dB); key : the chips are cached under it (None: a scene used once); seconds : the source's time;
    surface : the scene's DEM as the reference product gives it (an object with ``surface_down(points)``, NED), or
    None (``ImagingSettings.terrain_correction``).
    """

    times: np.ndarray
    pulses: PulseData
    positions: np.ndarray
    velocities: np.ndarray
    raw: PulseData
    amplitude: float
    snr_db: float
    key: object = None
    seconds: float = 0.0
    surface: object = None


class ApertureSource(Protocol):
    """Where :class:`SubApertureImager` gets the pulses of sub-aperture ``u`` for run ``run``: the reference pass and
    the in-flight acquisition (range-compressed, with the seconds it took)."""

    def reference(self, u: int, run: int) -> ReferencePulses: ...

    def flight(self, u: int, run: int) -> tuple[PulseData, float]: ...


@dataclass
class ApertureMeasurements:
    """What one sub-aperture gives for R runs and T reference targets.

    toc : (R, T) measured time of closest approach [s]; range : (R, T) measured range of closest approach [m];
    sigma : (R, T, 2) predicted 1-sigma of the range and along-track (speed x TOC) registration [m], from the image;
    quality : (R, T) normalised correlation of the match; ambiguity : (R, T) height of the best other match relative
    to it; lever : (R, T) TOC minus the aperture centre [s];
    sensitivity, focus_offset : (R, T) the along-track registration's dependence on the focusing speed, measured by
    refocusing the same data (``focus = "estimate"``; NaN otherwise): registration =
    ``sensitivity [s] x (speed - V) + focus_offset [m]`` (``SubApertureImager._focus_sensitivity``), the spread of
    that statistical linearisation included in ``sigma``;
    status : (R, T) 0 = measured, else the index of the reason in :data:`FAILURES`;
    autofocus_dk : (R,) mapdrift FM-rate correction [Hz/s]; speed : (R,) the speed the images were focused with [m/s];
    seconds : (R, len(STAGES)) time per stage; capture : images of the first run when asked; images : with
    ``SubApertureImager.keep_images``, per target k of the first run whose in-flight image was formed (``keep``),
    the image registered (``image``: RDA a ``SarImage``, rows = pulses, columns = slant range; BPA the complex
    array on ``grid``, the NED ground grid with ``centre``, ``along``, ``across``, ``da``, ``dg``, ``shape``), the
    range-compressed pulses it was formed from (``pulses``) and the estimated focusing track (``positions`` (P, 3)
    NED: the pulses' own positions for RDA).
    """

    toc: np.ndarray
    range: np.ndarray
    sigma: np.ndarray
    quality: np.ndarray
    ambiguity: np.ndarray
    lever: np.ndarray
    sensitivity: np.ndarray
    focus_offset: np.ndarray
    status: np.ndarray
    autofocus_dk: np.ndarray
    speed: np.ndarray
    seconds: np.ndarray
    capture: dict | None = None
    images: dict | None = None

    def keep(self, on: bool, k: int, image, pulses, grid=None, positions=None) -> None:
        """With ``on``, keep target k's in-flight image in ``images`` (class docstring; references, no copy)."""
        if on:
            self.images = {**(self.images or {}), k: {"image": image, "pulses": pulses, "grid": grid,
                                                      "positions": pulses.positions if positions is None else positions}}

    @classmethod
    def empty(cls, runs: int, targets: int) -> "ApertureMeasurements":
        nan = lambda *s: np.full(s, np.nan)  # noqa: E731
        return cls(nan(runs, targets), nan(runs, targets), nan(runs, targets, 2), nan(runs, targets),
                   nan(runs, targets), nan(runs, targets), nan(runs, targets), nan(runs, targets),
                   np.zeros((runs, targets), dtype=np.int64), nan(runs), nan(runs), np.zeros((runs, len(STAGES))))
