"""Linear-FM (chirp) waveform at complex baseband.

Centred chirp (Cumming & Wong 2005 eq. 3.1; architecture §3):
``p(t) = rect(t / T) exp(j pi K t^2)``, K = B / T, instantaneous frequency K t in [-B/2, B/2]
around the carrier. (The sources' eq. (1) writes the chirp on 0 <= t <= T starting at f_0; centring
it makes f_c the centre frequency, paper gap G8.)
"""

from __future__ import annotations

import numpy as np


def chirp(t: np.ndarray, chirp_rate: float, pulse_length: float) -> np.ndarray:
    """Baseband LFM ``rect(t/T) exp(j pi K t^2)`` at times ``t`` [s] (complex128; 0 outside |t| <= T/2)."""
    t = np.asarray(t, dtype=np.float64)
    inside = np.abs(t) <= 0.5 * pulse_length
    return np.where(inside, np.exp(1j * np.pi * chirp_rate * t * t), 0.0)


def replica(params) -> tuple[np.ndarray, np.ndarray]:
    """Sampled transmit replica of a :class:`~sarnav.radar.params.RadarParams` (:func:`sampled_replica`)."""
    return sampled_replica(params.sample_rate, params.pulse_length, params.chirp_rate)


def sampled_replica(sample_rate: float, pulse_length: float, chirp_rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Sampled transmit replica of the chirp of duration T = ``pulse_length`` and rate K = ``chirp_rate``.

    Returns
    -------
    t : (M,) sample times i / fs for the integers i with |i / fs| <= T/2 [s], centred on 0.
    p : (M,) complex128 chirp samples.
    """
    fs = sample_rate
    half = int(np.floor(0.5 * pulse_length * fs * (1 + 1e-12)))
    t = np.arange(-half, half + 1, dtype=np.float64) / fs
    return t, chirp(t, chirp_rate, pulse_length)
