"""The receiver-noise level of a recording's radar data: raw noise power <-> the power of the range-compressed
pulses.

sarnav's noise model of an image (``measurements.sar_image``) runs unit raw noise through the processor and scales
it by the noise power per raw fast-time sample N (``radar.echoes``: E|n|^2). A recording states N, or the power P of
the noise in its range-compressed pulses (interior range bins, free of echoes), which is N times the noise gain of
sarnav's normalised matched filter (``imaging.range_compression.matched_filter``, unit response to the replica):
g = sum_k |H_k|^2 / nfft, the white-noise power gain of a filter with DFT H (Parseval). Without a range window
g = 1 / M with M = the replica's samples (about fs T): 1/1001 for the nav-paper-sim radar; a Hamming window raises
it 1.37 times.
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft

from sarnav.imaging.range_compression import matched_filter
from sarnav.radar.params import RadarParams
from sarnav.radar.waveform import sampled_replica

__all__ = ["compressed_noise_gain"]


def compressed_noise_gain(radar: RadarParams) -> float:
    """g: the power of range-compressed noise per unit raw noise power, away from the window's edges (module
    docstring)."""
    fs, bw, tp = radar.sample_rate, radar.bandwidth, radar.pulse_length
    m = sampled_replica(fs, tp, bw / tp)[1].size
    nfft = sfft.next_fast_len(radar.n_range_samples + m)
    h = matched_filter(fs, bw, tp, nfft, radar.range_window)
    return float(np.mean(np.abs(h) ** 2))
