"""Array containers that carry their axes, geometry and provenance through image formation.

Contract shared by ``radar`` (echo simulation), ``imaging`` (range compression, RDA, BPA, autofocus,
registration) and ``measurements``. Axis convention: rows (axis 0) are pulses / azimuth, columns
(axis 1) are fast time / range. Distances in metres, times in seconds, geometry float64.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np


@dataclass
class PulseData:
    """Pulsed radar data: raw echoes or range-compressed pulses.

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
    params : the ``RadarParams`` that produced the data, or None (data read from a file): range
        compression needs it, back-projection needs only ``slant_range`` and the wavelength.
    compressed : False for raw echoes, True after range compression.
    metadata : free-form provenance (window used, SNR, ...).
    wavelength : carrier (centre-frequency) wavelength lambda = c / f_c [m] the baseband data are
        referred to; None falls back to ``params.wavelength`` (see :attr:`carrier_wavelength`).
    """

    data: np.ndarray
    slant_range: np.ndarray
    pulse_times: np.ndarray
    positions: np.ndarray
    params: Any = None
    compressed: bool = False
    metadata: dict = field(default_factory=dict)
    wavelength: float | None = None

    @property
    def carrier_wavelength(self) -> float | None:
        """``wavelength`` if given, else ``params.wavelength``, else None [m]."""
        if self.wavelength is not None:
            return float(self.wavelength)
        lam = getattr(self.params, "wavelength", None)
        return None if lam is None else float(lam)

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
