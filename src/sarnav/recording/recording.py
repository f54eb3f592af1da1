"""A flight recording read from its folder (docs/recording.md): the manifest, the logs, the reference points and
the apertures as a source of pulses for the image extractor.

``read_recording(folder)`` reads and checks everything but the radar data (each aperture's CPHD is read when the
extractor asks for it, ``RecordedApertures``); every bad input is one line naming the file, the line or key and the
field. ``Recording.imager(settings)`` is the extractor of image-derived measurements on the recording's pulses.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from sarnav.errors import InputDataError
from sarnav.measurements.sar_aperture import ImagingSettings
from sarnav.measurements.sar_image import SubApertureImager
from sarnav.recording.apertures import RecordedApertures
from sarnav.recording.fields import MANIFEST
from sarnav.recording.logs import (AltimeterLog, GnssLog, ImuLog, ReferencePoints, TruthLog, read_altimeter, read_gnss,
                                   read_imu, read_points, read_sar_offsets, read_truth)
from sarnav.recording.manifest import Manifest, read_manifest

__all__ = ["Recording", "read_recording", "DEFAULT_NOISE_MODEL_SEED"]

#: seed of the extractor's noise model when the recording states none (``[simulation] noise_model_seed``)
DEFAULT_NOISE_MODEL_SEED = 0


@dataclass(frozen=True)
class Recording:
    """A recording (module docstring). ``manifest``: ``flight.toml`` parsed; ``imu``, ``altimeter``, ``gnss``,
    ``truth``: the logs (None when absent); ``points``: the reference points (None without apertures);
    ``sar_offsets`` (U, T, 2) [m]: an exported recording's offsets of the image-derived range and cross-range (its
    world's truth biases and added noise; None otherwise); ``scenario_text``: an exported recording's scenario."""

    folder: Path
    manifest: Manifest
    imu: ImuLog
    altimeter: AltimeterLog | None
    gnss: GnssLog | None
    truth: TruthLog | None
    points: ReferencePoints | None
    sar_offsets: np.ndarray | None
    scenario_text: str | None

    @property
    def radar(self):
        return self.manifest.radar

    @property
    def noise_model_seed(self) -> int:
        """The seed of the extractor's noise model: the exported campaign's (``reference_seed``), else 0."""
        sim = self.manifest.simulation
        return DEFAULT_NOISE_MODEL_SEED if sim is None else sim.noise_model_seed

    def source(self, runs: int = 1) -> RecordedApertures:
        """The apertures' pulses (``ApertureSource``); ``runs`` copies of the one flight."""
        m = self.manifest
        if m.radar is None or not m.apertures:
            raise InputDataError(MANIFEST, "has no apertures (no [radar] and [[aperture]] tables)")
        return RecordedApertures(self.folder, m.apertures, m.radar, m.frame.origin, m.noise_power,
                                 m.time.radar_clock_offset, runs, product=self.reference_products())

    def reference_products(self):
        """Reference (b): aperture u -> its ``recording.ortho.OrthoProduct`` (each file read once); None for (a)."""
        m = self.manifest
        if m.reference is None or m.reference.kind != "orthoimage":
            return None
        from sarnav.recording.ortho import OrthoProduct, read_raster

        ref, cache = m.reference, {}
        dem = None if ref.dem is None else read_raster(self.folder / ref.dem, f"{MANIFEST}:reference.dem")

        def product(u: int) -> OrthoProduct:
            ap = m.apertures[u]
            rel = ap.reference or ref.image
            if rel not in cache:
                key = f"{MANIFEST}:aperture[{u}].reference" if ap.reference else f"{MANIFEST}:reference.image"
                cache.clear()
                cache[rel] = OrthoProduct(read_raster(self.folder / rel, key), dem, m.frame.origin, ref.noise_power)
            return cache[rel]
        return product

    def imager(self, settings: ImagingSettings | None = None, runs: int = 1,
               capture_aperture: int | None = None) -> SubApertureImager:
        """The image extractor on the recording's pulses, its chips cut at the reference points' anchors."""
        return SubApertureImager(self.manifest.radar, self.points.anchors if self.points is not None else None,
                                 self.source(runs), self.noise_model_seed,
                                 ImagingSettings() if settings is None else settings, capture_aperture)


def _product_points(folder: Path, m: Manifest, points: ReferencePoints) -> ReferencePoints:
    """Reference (b): its files exist, and the product's geolocation 1-sigma joins each point's map 1-sigma (root
    sum of squares: independent errors; both enter R)."""
    ref = m.reference
    if ref.kind != "orthoimage":
        return points
    for key, rel in (("image", ref.image), ("dem", ref.dem)):
        if rel is not None and not (folder / rel).is_file():
            raise InputDataError(f"{MANIFEST}:reference.{key}", f"{rel!r} is not a file of the recording")
    return replace(points, map_sigma=np.hypot(points.map_sigma, ref.geolocation_sigma))


def read_recording(folder) -> Recording:
    """Read the recording in ``folder`` (module docstring)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputDataError(str(folder), "is not a folder (a recording is a folder holding flight.toml)")
    m = read_manifest(folder / MANIFEST)
    imu = read_imu(folder / m.imu.file, m.imu.file, m.imu.samples, m.time.imu_clock_offset, m.imu.rate_hz,
                   m.imu.body_axes, m.imu.topic)
    alt = None if m.altimeter is None else read_altimeter(folder / m.altimeter.file, m.altimeter.file,
                                                          float(m.frame.origin[2]))
    gnss = None if m.gnss_file is None else read_gnss(folder / m.gnss_file, m.gnss_file, m.frame.origin)
    truth = None if m.truth_file is None else read_truth(folder / m.truth_file, m.truth_file)
    points = offsets = text = None
    if m.apertures:
        for i, ap in enumerate(m.apertures):
            for key, rel in (("file", ap.file), ("reference", ap.reference)):
                if rel is not None and not (folder / rel).is_file():
                    raise InputDataError(f"{MANIFEST}:aperture[{i}].{key}", f"{rel!r} is not a file of the recording")
        points = read_points(folder / m.reference.points, m.reference.points, len(m.apertures))
        points = _product_points(folder, m, points)
    sim = m.simulation
    if sim is not None:
        if sim.sar_offsets is not None and points is not None:
            offsets = read_sar_offsets(folder / sim.sar_offsets, sim.sar_offsets, len(m.apertures),
                                       points.anchors.shape[1])
        path = folder / sim.scenario_file
        if not path.is_file():
            raise InputDataError(f"{MANIFEST}:simulation.scenario_file", f"{sim.scenario_file!r} is not a file of the "
                                 "recording")
        text = path.read_text(encoding="utf-8")
    if m.initial.gnss_until is not None and gnss.time[0] > m.initial.gnss_until:
        raise InputDataError(f"{MANIFEST}:initial.gnss_until_s", f"{m.initial.gnss_until!r} s is before the first "
                             f"GNSS fix ({gnss.time[0]!r} s, {m.gnss_file})")
    return Recording(folder, m, imu, alt, gnss, truth, points, offsets, text)
