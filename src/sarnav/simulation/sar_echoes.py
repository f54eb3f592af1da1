"""The simulated world as a source of sub-aperture pulses (``measurements.sar_image.ApertureSource``).

Per sub-aperture u (one second of pulses of the radar's clock from t = u) the scene of the aperture
(``scene_for(u, clutter_seed) -> AperturePasses``) is imaged twice by noise-free echoes (``radar.echoes``): the
*in-flight pass* along the true track (``truth``) and the *reference pass* along ``reference_truth`` (by default the
same track; another pass has its own offset track and its own, partly decorrelated, clutter). Each acquisition adds
its own receiver noise (``snr_db``: per-sample SNR of a scatterer of amplitude ``reflector_amplitude``,
``radar.echoes.add_receiver_noise``) and is range compressed. The reference pass is handed on with its true track
(the trusted positions of a reference product); the extractor never sees the in-flight truth.

Seeds (keys of ``SeedSequence``): clutter drawn per run (``clutter_seeds`` given) or once for all runs
(``reference_seed``; the noise-free echoes and the reference acquisition are then cached); reference-pass noise
``[clutter seed or reference_seed, 3, u]``; in-flight noise ``[noise_seeds[r], 4, u]``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from sarnav.errors import InputDataError
from sarnav.imaging.range_compression import range_compress
from sarnav.measurements.sar_image import AperturePasses, ImagingSettings, ReferencePulses, SubApertureImager
from sarnav.radar.echoes import add_receiver_noise, simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.trajectory.base import Trajectory

__all__ = ["SimulatedApertures", "simulated_imager"]


@dataclass
class SimulatedApertures:
    """Echoes of each sub-aperture's scene along the true tracks, with receiver noise per acquisition (module
    docstring). ``runs`` = len(``noise_seeds``)."""

    radar: RadarParams
    truth: Trajectory
    scene_for: Callable[[int, int | None], AperturePasses]
    reflector_amplitude: float
    snr_db: float
    reference_seed: int
    noise_seeds: list
    clutter_seeds: list | None = None
    reference_truth: Trajectory | None = None
    surface: object = None  # the scene's DEM given with the reference (ReferencePulses.surface), or None
    _cache: dict = field(default_factory=dict, repr=False)
    _last: tuple | None = field(default=None, repr=False)

    def __post_init__(self):
        self.noise_seeds = [int(s) for s in self.noise_seeds]
        self.clutter_seeds = None if self.clutter_seeds is None else [int(s) for s in self.clutter_seeds]
        if self.clutter_seeds is not None and len(self.clutter_seeds) != len(self.noise_seeds):
            raise InputDataError("clutter_seeds", f"need one per run: {len(self.clutter_seeds)} for "
                                 f"{len(self.noise_seeds)} runs")
        if self.reference_truth is None:
            self.reference_truth = self.truth
        self.n_pulses = int(round(self.radar.prf))

    @property
    def runs(self) -> int:
        return len(self.noise_seeds)

    def _noisy(self, raw, key):
        """Range-compressed copy of the noise-free echoes ``raw`` with receiver noise from ``key``: one acquisition."""
        rng = np.random.default_rng(np.random.SeedSequence(key))
        return range_compress(add_receiver_noise(raw, self.reflector_amplitude, self.snr_db, rng))

    def _aperture(self, u: int, run: int) -> dict:
        """The noise-free in-flight echoes and the reference pass of sub-aperture u (cached when the scene is shared)."""
        clutter_seed = None if self.clutter_seeds is None else self.clutter_seeds[run]
        if (u, clutter_seed) in self._cache:
            return self._cache[(u, clutter_seed)]
        if self._last is not None and self._last[0] == (u, run):  # the reference, then the flight of one run
            return self._last[1]
        t0 = time.perf_counter()
        times = self.radar.pulse_times(self.n_pulses, u)
        truth = self.truth.state(times)
        passes = self.scene_for(u, clutter_seed)
        raw = simulate_echoes(self.radar, truth.position, times, passes.flight)
        same_pass = passes.reference is passes.flight and self.reference_truth is self.truth
        ref_truth = truth if self.reference_truth is self.truth else self.reference_truth.state(times)
        raw_ref = raw if same_pass else simulate_echoes(self.radar, ref_truth.position, times, passes.reference)
        key = [self.reference_seed, 3, u] if clutter_seed is None else [clutter_seed, 3, u]
        ref = ReferencePulses(times, self._noisy(raw_ref, key), ref_truth.position, ref_truth.velocity, raw_ref,
                              self.reflector_amplitude, self.snr_db, key=None if clutter_seed is not None else ("shared", u),
                              seconds=time.perf_counter() - t0, surface=self.surface)
        entry = {"raw": raw, "reference": ref}
        if clutter_seed is None:  # a shared scene: kept for every run
            self._cache[(u, clutter_seed)] = entry
        else:  # a per-run scene: kept only until the run's flight acquisition is made
            self._last = ((u, run), entry)
        return entry

    def reference(self, u: int, run: int) -> ReferencePulses:
        """The reference pass of sub-aperture u as run ``run`` sees it (one for every run when the scene is shared)."""
        return self._aperture(u, run)["reference"]

    def flight(self, u: int, run: int):
        """(range-compressed in-flight acquisition of run ``run``, seconds): the run's own receiver noise."""
        raw = self._aperture(u, run)["raw"]
        t0 = time.perf_counter()
        rc = self._noisy(raw, [self.noise_seeds[run], 4, u])
        return rc, time.perf_counter() - t0


def simulated_imager(radar: RadarParams, truth: Trajectory, targets, scene_for, reflector_amplitude: float,
                     snr_db: float, reference_seed: int, noise_seeds, clutter_seeds=None, reference_truth=None,
                     settings: ImagingSettings | None = None, capture_aperture: int | None = None,
                     surface=None) -> SubApertureImager:
    """A :class:`~sarnav.measurements.sar_image.SubApertureImager` on the echoes of the simulated world
    (:class:`SimulatedApertures`); ``targets`` (U, T, 3) the reference targets (the product's geolocation is the
    truth here; the map's own error is the navigator's business); ``surface``: the DEM given with the reference."""
    source = SimulatedApertures(radar, truth, scene_for, reflector_amplitude, snr_db, reference_seed, noise_seeds,
                                clutter_seeds, reference_truth, surface)
    return SubApertureImager(radar, targets, source, reference_seed,
                             ImagingSettings() if settings is None else settings, capture_aperture)
