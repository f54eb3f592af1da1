"""``sarnav.recording.noise.compressed_noise_gain``: the power of range-compressed noise per unit raw noise power.

Checked against the module docstring's closed forms, computed here with numpy only: without a range window the
normalised matched filter h = conj(p[::-1]) / sum |p|^2 of the unit-amplitude chirp's M samples (|i / fs| <= T/2)
has white-noise power gain sum |h|^2 = 1 / M; a spectral window W over the band raises it by about
mean(W^2) / mean(W)^2 (Hamming: 1.36, the docstring's "1.37 times").
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarnav.radar.params import RadarParams
from sarnav.radar.presets import nav_paper_sim
from sarnav.recording.noise import compressed_noise_gain


def radar(**kw) -> RadarParams:
    base = dict(carrier_frequency=9.6e9, bandwidth=100e6, sample_rate=120e6, pulse_length=1e-6, prf=400.0,
                antenna_length=1.0, near_range=1950.0, n_range_samples=300)
    base.update(kw)
    return RadarParams(**base)


def replica_samples(fs: float, t_p: float) -> int:
    """M: the integers i with |i / fs| <= T / 2."""
    return 2 * int(math.floor(0.5 * t_p * fs * (1 + 1e-12))) + 1


@pytest.mark.parametrize("fs, bw, t_p", [(120e6, 100e6, 1e-6), (1e9, 500e6, 1e-6), (187.5e6, 150e6, 0.5e-6),
                                         (50e6, 40e6, 3.3e-6)])
def test_unwindowed_gain_is_one_over_the_replicas_samples(fs, bw, t_p):
    g = compressed_noise_gain(radar(sample_rate=fs, bandwidth=bw, pulse_length=t_p, range_window="none",
                                    n_range_samples=int(4 * fs * t_p)))
    assert g * replica_samples(fs, t_p) == pytest.approx(1.0, rel=1e-10)


def test_nav_paper_radar_gain_is_the_documented_one_over_1001():
    """The docstring's example: 1/1001 for the nav-paper-sim radar without a window."""
    assert compressed_noise_gain(nav_paper_sim(range_window="none")) == pytest.approx(1 / 1001, rel=1e-10)


def test_gain_equals_the_time_domain_filters_noise_gain():
    """Parseval: the mean of |H|^2 over the FFT equals the time-domain sum |h|^2 of the normalised matched filter."""
    fs, bw, t_p = 120e6, 100e6, 1e-6
    m = replica_samples(fs, t_p)
    t = (np.arange(m) - m // 2) / fs
    p = np.exp(1j * math.pi * (bw / t_p) * t * t)
    h = np.conj(p[::-1]) / np.sum(np.abs(p) ** 2)
    assert np.sum(h * p[::-1]) == pytest.approx(1.0)  # unit response to the replica
    g = compressed_noise_gain(radar(sample_rate=fs, bandwidth=bw, pulse_length=t_p))
    assert g == pytest.approx(float(np.sum(np.abs(h) ** 2)), rel=1e-10)


def test_gain_is_the_measured_power_of_compressed_white_noise():
    """Unit complex white noise filtered in the time domain by the normalised matched filter has power g."""
    fs, bw, t_p = 120e6, 100e6, 1e-6
    m = replica_samples(fs, t_p)
    t = (np.arange(m) - m // 2) / fs
    p = np.exp(1j * math.pi * (bw / t_p) * t * t)
    h = np.conj(p[::-1]) / np.sum(np.abs(p) ** 2)
    rng = np.random.default_rng(3)
    n = (rng.standard_normal(200_000) + 1j * rng.standard_normal(200_000)) / math.sqrt(2)
    out = np.convolve(n, h, mode="valid")
    g = compressed_noise_gain(radar(sample_rate=fs, bandwidth=bw, pulse_length=t_p))
    assert np.mean(np.abs(out) ** 2) == pytest.approx(g, rel=0.02)


def test_hamming_window_raises_the_gain_by_its_power_ratio():
    """W = 0.54 + 0.46 cos(2 pi f / B) over the band: mean(W^2) / mean(W)^2 = 1.3628 (docstring: 1.37 times)."""
    plain = compressed_noise_gain(nav_paper_sim(range_window="none"))
    hamming = compressed_noise_gain(nav_paper_sim(range_window="hamming"))
    ratio = (0.54**2 + 0.46**2 / 2) / 0.54**2
    assert hamming / plain == pytest.approx(ratio, rel=0.02)
    assert hamming / plain == pytest.approx(1.37, abs=0.01)


def test_gain_does_not_depend_on_the_receive_window_length():
    """The gain is the filter's (interior range bins): the receive window only sets the FFT length."""
    gains = [compressed_noise_gain(radar(n_range_samples=n, range_window="none")) for n in (200, 301, 1000, 4096)]
    np.testing.assert_allclose(gains, gains[0], rtol=1e-10)
    gains = [compressed_noise_gain(radar(n_range_samples=n, range_window="hamming")) for n in (200, 1000, 4096)]
    np.testing.assert_allclose(gains, gains[0], rtol=2e-3)
