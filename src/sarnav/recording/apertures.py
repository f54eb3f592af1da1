"""A recording's radar data as a source of sub-aperture pulses (``measurements.sar_aperture.ApertureSource``).

Per aperture u the in-flight CPHD and the reference pass's CPHD (docs/recording.md §5) are read with
``io.cphd.read_collect`` on the radar's own range axis (``RadarParams.slant_range_axis`` of the manifest), their
antenna positions taken from WGS-84 ECEF to the recording's NED frame (``io.frames``). The pulse times are the
manifest's ``start_s`` plus each vector's TxTime plus the radar clock's offset; the reference pass is handed to the
extractor on the in-flight pulses' times (its k-th pulse with the k-th in flight: the extractor's convention) with
its own trusted positions and velocities (the PVPs TxPos/RcvPos, TxVel/RcvVel). The image-formation fields of the
pulses (wavelength, bandwidth, sampling, pulse length, windows) are the manifest radar's; the file's carrier and PRF
must agree with it. The receiver noise is the manifest's ``radar.noise_power`` per raw sample (``ReferencePulses``:
amplitude sqrt(N), 0 dB). One recording is one run: every run index gets the same pulses.

The extractor reads ``read_ahead`` apertures ahead, each on a thread of its own (``measurements.read_ahead``): the
source keeps the apertures it has loaded in a small table under a lock (each thread loads its own aperture; a
reference product is looked up under the lock), so several threads may read at once.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np
import sarkit.cphd as skcphd

from sarnav.errors import InputDataError
from sarnav.io.cphd import read_collect
from sarnav.io.frames import ecef_to_ned, ned_basis
from sarnav.measurements.sar_aperture import ReferencePulses
from sarnav.measurements.sar_product import ProductReference
from sarnav.radar.params import RadarParams
from sarnav.recording.manifest import ApertureInfo
from sarnav.signal.data import PulseData

__all__ = ["RecordedApertures", "CARRIER_TOLERANCE", "PRF_TOLERANCE"]

#: largest relative difference between a file's carrier (c / FxC) or mean PRF and the manifest radar's
CARRIER_TOLERANCE = 1e-6
PRF_TOLERANCE = 1e-6


class RecordedApertures:
    """The pulses of a recording's apertures (module docstring).

    root : the recording's folder; apertures : its ``ApertureInfo`` list; radar : the manifest's radar; origin :
    (lat deg, lon deg, height m) of the NED frame; noise_power : receiver noise power per raw sample;
    radar_clock_offset : recording time minus radar clock [s]; runs : how many runs the extractor forms (each the
    same data).
    """

    #: apertures the extractor may prepare ahead, each on its own thread (measurements.read_ahead; 0: none). Two on
    #: two cores: the reading (~116 ms an aperture) then overlaps itself and the navigator's own work (~36 ms)
    read_ahead = 2

    def __init__(self, root, apertures: Sequence[ApertureInfo], radar: RadarParams, origin, noise_power: float,
                 radar_clock_offset: float = 0.0, runs: int = 1, product=None):
        self.root, self.apertures, self.radar = Path(root), tuple(apertures), radar
        self.origin = np.asarray(origin, dtype=np.float64)
        self.noise_power, self.clock_offset = float(noise_power), float(radar_clock_offset)
        if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
            raise InputDataError("runs", f"must be an integer >= 1, got {runs!r}")
        self._runs = runs
        self.n_pulses = int(round(radar.prf))
        self._loaded: dict[int, tuple] = {}  # aperture -> what _load returns, the last few (read-ahead threads)
        self._lock = threading.Lock()
        self.product = product  # reference (b): product(u) -> the aperture's GeocodedProduct (recording.ortho)

    @property
    def runs(self) -> int:
        return self._runs

    def reference(self, u: int, run: int) -> ReferencePulses | ProductReference:
        """The reference pass of aperture u (the same for every run), or its geocoded product (reference (b))."""
        return self._load(u, run)[1]

    def reference_pass(self, u: int) -> PulseData:
        """The reference pass's pulses of aperture u alone (reference (a); positions NED, the file's own pulse times):
        for pictures of the reference, without reading the in-flight file."""
        ap = self.apertures[u]
        if self.product is not None or ap.reference is None:
            raise InputDataError(f"aperture[{u}].reference", "the reference is a geocoded product (reference (b)), "
                                 "not a pass of pulses")
        return self._read(ap.reference)[0]

    def flight(self, u: int, run: int) -> tuple[PulseData, float]:
        """(the in-flight pulses of aperture u, seconds spent reading them)."""
        _, _, rc, seconds = self._load(u, run)
        return rc, seconds

    # ------------------------------------------------------------------------------------------
    def _load(self, u: int, run: int):
        if not 0 <= run < self._runs:
            raise InputDataError("run", f"must be in [0, {self._runs - 1}], got {run!r}")
        if not 0 <= u < len(self.apertures):
            raise InputDataError("aperture", f"must be in [0, {len(self.apertures) - 1}], got {u!r}")
        with self._lock:
            if u in self._loaded:
                return self._loaded[u]
        loaded = self._read_aperture(u)
        with self._lock:
            self._loaded[u] = loaded
            while len(self._loaded) > max(int(self.read_ahead), 0) + 2:  # the oldest goes: at most one per thread
                del self._loaded[next(iter(self._loaded))]
        return loaded

    def _read_aperture(self, u: int):
        ap = self.apertures[u]
        t0 = time.perf_counter()
        rc, tx_time = self._read(ap.file)
        times = ap.start + tx_time + self.clock_offset
        self._check_clock(ap, tx_time)
        rc = replace(rc, pulse_times=times)
        t1 = time.perf_counter()
        if self.product is not None:  # reference (b): the product, and the in-flight shape for the noise model
            raw = PulseData(np.broadcast_to(np.zeros((), np.complex128), rc.data.shape), rc.slant_range, times,
                            rc.positions, params=self.radar, compressed=False, **self.radar.pulse_data_fields())
            with self._lock:  # the product table is shared
                product = self.product(u)
            ref = ProductReference(times, product, raw, math.sqrt(self.noise_power), 0.0,
                                   seconds=time.perf_counter() - t1)
            return (u, ref, rc, t1 - t0)
        ref_rc, ref_tx = self._read(ap.reference)
        if ref_rc.n_pulses != rc.n_pulses:
            raise InputDataError(ap.reference, f"has {ref_rc.n_pulses} pulses, its aperture {ap.file} {rc.n_pulses}: "
                                 "a reference pass pairs its pulses one to one with the aperture's")
        ref_rc = replace(ref_rc, pulse_times=times)
        raw = PulseData(np.broadcast_to(np.zeros((), np.complex128), ref_rc.data.shape), ref_rc.slant_range, times,
                        ref_rc.positions, params=self.radar, compressed=False, **self.radar.pulse_data_fields())
        ref = ReferencePulses(times, ref_rc, ref_rc.positions, self._velocities(ap.reference, ref_rc, ref_tx), raw,
                              math.sqrt(self.noise_power), 0.0, key=("recording", u),
                              seconds=time.perf_counter() - t1)
        return (u, ref, rc, t1 - t0)

    def _read(self, rel: str) -> tuple[PulseData, np.ndarray]:
        """(pulses on the radar's range axis, NED positions, the radar's fields; the vectors' TxTime [s])."""
        path = self.root / rel
        if not path.is_file():
            raise InputDataError(rel, "missing file (named in flight.toml)")
        try:
            rc, _ = read_collect(path, self.radar.slant_range_axis)
        except InputDataError as err:
            raise InputDataError(f"{rel}:{err.field}", err.message) from None
        if rc.n_pulses != self.n_pulses:
            raise InputDataError(rel, f"has {rc.n_pulses} pulses; an aperture is one second of the radar's pulses, "
                                 f"round(radar.prf_hz) = {self.n_pulses}")
        lam = self.radar.wavelength
        if not abs(rc.wavelength - lam) <= CARRIER_TOLERANCE * lam:
            raise InputDataError(f"{rel}:Channel.Parameters.FxC", f"carrier {rc.carrier_frequency:.9g} Hz, the "
                                 f"manifest's radar.carrier_ghz {self.radar.carrier_frequency / 1e9:.9g} GHz")
        tx_time = np.asarray(rc.pulse_times, dtype=np.float64)
        prf = (tx_time.size - 1) / (tx_time[-1] - tx_time[0])
        if not abs(prf - self.radar.prf) <= PRF_TOLERANCE * self.radar.prf:
            raise InputDataError(f"{rel}:PVP.TxTime", f"mean PRF {prf:.9g} Hz, the manifest's radar.prf_hz "
                                 f"{self.radar.prf:.9g} Hz")
        pos = ecef_to_ned(rc.positions, self.origin)
        return replace(rc, positions=pos, params=self.radar, **self.radar.pulse_data_fields()), tx_time

    def _check_clock(self, ap: ApertureInfo, tx_time) -> None:
        last = ap.start + float(tx_time[-1])
        if abs(last - ap.end) > 0.5 / self.radar.prf:
            raise InputDataError(ap.file, f"its last pulse is at {last!r} s (start_s + TxTime) on the radar clock, "
                                 f"the manifest's end_s {ap.end!r} s")

    def _velocities(self, rel: str, rc: PulseData, tx_time) -> np.ndarray:
        """(P, 3) NED velocities of the reference pass: the PVPs (TxVel + RcvVel) / 2, else the positions' gradient."""
        try:
            with open(self.root / rel, "rb") as f, skcphd.Reader(f) as r:
                ch = r.metadata.xmltree.find("./{*}Data/{*}Channel/{*}Identifier").text
                pvp = r.read_pvps(ch)
            vel = 0.5 * (np.asarray(pvp["TxVel"], dtype=np.float64) + np.asarray(pvp["RcvVel"], dtype=np.float64))
        except (KeyError, ValueError, AttributeError):
            return np.gradient(rc.positions, tx_time, axis=0)
        if vel.shape != rc.positions.shape or not np.all(np.isfinite(vel)):
            raise InputDataError(f"{rel}:cphd.PVP.TxVel", "must be finite, one per vector")
        return vel @ ned_basis(self.origin)[1]
