"""Array containers that carry their axes, geometry and provenance through image formation.

Contract shared by ``radar`` (echo simulation), ``imaging`` (range compression, RDA, BPA, autofocus,
registration) and ``measurements``. Axis convention: rows (axis 0) are pulses / azimuth, columns
(axis 1) are fast time / range. Distances in metres, times in seconds, geometry float64.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from sarnav.units import C


@dataclass
class PulseData:
    """Pulsed radar data: raw echoes or range-compressed pulses.

    Everything image formation reads is an explicit field, filled by whoever builds the data
    (``radar.echoes.simulate_echoes`` from its ``RadarParams``, ``signal.phase_history``,
    ``io.cphd``); a step that needs a field and finds None raises an error naming it.

    Attributes
    ----------
    data : (P, N) complex, one row per pulse, one column per fast-time sample.
    slant_range : (N,) slant range of each fast-time sample, c * tau / 2 [m].
    pulse_times : (P,) slow time of each pulse [s].
    positions : (P, 3) float64 antenna phase-centre positions [m] the data are *referred to*, in
        any Cartesian frame shared with the image grid: the local NED frame of the simulations, or
        ECEF for spaceborne / CPHD data (only distances ``|p - a_k|`` enter image formation). For
        simulated raw data these are the true positions; image formation may be handed a
        different (estimated) set with :meth:`with_positions`.
    params : the ``RadarParams`` that produced the simulated data (provenance, kept for
        compatibility), or None; no image-formation step reads it.
    compressed : False for raw echoes, True after range compression.
    metadata : free-form provenance (window used, SNR, ...).
    wavelength : carrier (centre-frequency) wavelength lambda = c / f_c [m] the baseband data are
        referred to (RDA, back-projection, autofocus), or None.
    bandwidth : transmitted (chirp) bandwidth B [Hz] (range compression, RDA metadata, the
        back-projection's interpolation choice), or None.
    sample_rate : complex fast-time sampling rate fs [Hz] of raw echoes (range compression), or None.
    pulse_length : chirp duration T [s] of raw echoes (range compression), or None.
    range_window, azimuth_window : the spectral windows the radar description asks for (range
        compression's and the RDA's default; a ``Window`` spec), or None ("none").
    """

    data: np.ndarray
    slant_range: np.ndarray
    pulse_times: np.ndarray
    positions: np.ndarray
    params: "RadarParams | None" = None  # noqa: F821 (radar sits above signal: a name, not an import)
    compressed: bool = False
    metadata: dict = field(default_factory=dict)
    wavelength: float | None = None
    bandwidth: float | None = None
    sample_rate: float | None = None
    pulse_length: float | None = None
    range_window: Any = None
    azimuth_window: Any = None

    @property
    def carrier_wavelength(self) -> float | None:
        """``wavelength`` as a float, or None [m]."""
        return None if self.wavelength is None else float(self.wavelength)

    @property
    def carrier_frequency(self) -> float | None:
        """f_c = c / ``wavelength`` [Hz], or None."""
        return None if self.wavelength is None else C / float(self.wavelength)

    @property
    def chirp_rate(self) -> float | None:
        """K = B / T [Hz/s] (``bandwidth`` / ``pulse_length``), or None when either is missing."""
        if self.bandwidth is None or self.pulse_length is None:
            return None
        return self.bandwidth / self.pulse_length

    @property
    def n_pulses(self) -> int:
        return self.data.shape[0]

    @property
    def range_spacing(self) -> float:
        return float(self.slant_range[1] - self.slant_range[0])

    def with_positions(self, positions: np.ndarray) -> "PulseData":
        """Same data referred to other antenna positions (e.g. the navigation estimate)."""
        from sarnav.errors import InputDataError

        positions = np.asarray(positions, dtype=np.float64)
        if positions.shape != np.shape(self.positions):
            raise InputDataError("positions", f"shape {positions.shape}, expected {np.shape(self.positions)}")
        if not np.all(np.isfinite(positions)):
            raise InputDataError("positions", "contains NaN or inf (a navigation estimate must be finite)")
        return replace(self, positions=positions)


@dataclass
class SarImage:
    """A complex SAR image with both axes in metres.

    Attributes
    ----------
    data : (Ny, Nx) complex; rows along azimuth / the first grid axis, columns along range / the
        second grid axis.
    y : (Ny,) coordinate of each row [m] (along-track distance for RDA; first grid axis for BPA).
    x : (Nx,) coordinate of each column [m] (slant range for RDA; second grid axis for BPA).
    y_name, x_name : what the axes are, e.g. "along_track", "slant_range", "north", "east".
    metadata : carrier, bandwidth, prf, speed, closest-approach range, aperture length, algorithm,
        window, grid origin ... (JSON-serialisable values).
    """

    data: np.ndarray
    y: np.ndarray
    x: np.ndarray
    y_name: str = "along_track"
    x_name: str = "slant_range"
    metadata: dict = field(default_factory=dict)

    @property
    def dy(self) -> float:
        return float(self.y[1] - self.y[0])

    @property
    def dx(self) -> float:
        return float(self.x[1] - self.x[0])

    @property
    def shape(self) -> tuple[int, int]:
        return self.data.shape
