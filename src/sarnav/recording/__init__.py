"""Recorded flights (issue 26; docs/recording.md): the recording format's reader, and the recorded radar data as a
source of pulses for the image extractor.

A recording is a folder: ``flight.toml`` (the manifest), ``imu.csv``, optional ``altimeter.csv``, ``gnss.csv`` and
``truth.csv``, one CPHD per aperture and per aperture's reference pass, ``reference/points.csv``.
``read_recording(folder) -> Recording``; ``Recording.source()`` is a ``RecordedApertures`` (the
``measurements.sar_aperture.ApertureSource`` of the recording), ``Recording.imager(settings)`` the extractor on it.
"""

from sarnav.recording.apertures import RecordedApertures
from sarnav.recording.manifest import FORMAT, FORMAT_VERSION, Manifest, read_manifest
from sarnav.recording.recording import Recording, read_recording

__all__ = ["read_recording", "Recording", "RecordedApertures", "read_manifest", "Manifest", "FORMAT", "FORMAT_VERSION"]
