"""Reading the next sub-apertures while the navigator works on this one.

What the extractor needs of a sub-aperture before it sees the navigator's estimate (``SubApertureImager._prepare``:
the reference pass's pulses, its chips and their receiver-noise model, the in-flight pulses) depends on the
recording and the radar only, never on the estimate. For a source that reads a recording
(``recording.apertures.RecordedApertures``, ``read_ahead = 2``) the extractor prepares apertures u + 1 and u + 2,
each on a thread of its own, while it measures aperture u and the navigator updates and propagates: on two cores
the reading of the CPHD files and the noise model (~70 % of an update's CPU) overlaps itself and the navigator
(depth 1 left the reading the bottleneck: 6.7 s against 4.7 s for the 50-s recording). Each aperture's numbers are
made by the same calls with the same seeds as without it, on one thread per aperture: the results are the same bit
for bit (``tests/measurements/test_read_ahead.py``).
"""

from __future__ import annotations

import threading

__all__ = ["ReadAhead"]


class ReadAhead(threading.Thread):
    """``prepare(u, run)`` run on a daemon thread (an interrupted navigation does not wait for it); :meth:`take`
    hands its value over, or raises its error in the caller's thread, where the error would have been raised without
    reading ahead."""

    def __init__(self, prepare, u: int, run: int):
        super().__init__(daemon=True, name=f"sarnav-read-ahead-{u}")
        self.key = (u, run)
        self._prepare = prepare
        self._value = self._error = None
        self.start()

    def run(self) -> None:
        try:
            self._value = self._prepare(*self.key)
        except BaseException as err:  # noqa: BLE001 - handed to the caller by take()
            self._error = err

    def take(self):
        """The prepared value (waits for the thread); the thread's error re-raised."""
        self.join()
        if self._error is not None:
            err, self._error = self._error, None
            raise err
        return self._value
