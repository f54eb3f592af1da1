"""``radar.waveform``: the centred LFM pulse against its definition (Cumming & Wong 2005 §3.2): instantaneous
frequency K t over |t| <= T/2 (so the band is [-B/2, B/2]) and, for a large time-bandwidth product, a compressed
pulse whose -3 dB width is 0.886 / B (the sinc of the rectangular spectrum, eq. 3.40)."""

import numpy as np
import pytest

from sarnav.radar.presets import nav_paper_sim
from sarnav.radar.waveform import chirp, replica


def test_instantaneous_frequency_is_k_t_and_zero_outside_the_pulse():
    K, T, fs = 5e14, 1e-6, 4e9
    t = np.arange(-0.6e-6, 0.6e-6, 1 / fs)
    p = chirp(t, K, T)
    inside = np.abs(t) <= T / 2
    assert np.all(p[~inside] == 0) and np.allclose(np.abs(p[inside]), 1.0)
    f = np.diff(np.unwrap(np.angle(p[inside]))) * fs / (2 * np.pi)  # frequency between samples
    tm = 0.5 * (t[inside][1:] + t[inside][:-1])
    np.testing.assert_allclose(f, K * tm, rtol=0, atol=1e-6 * K * T)


def test_replica_of_a_preset_is_centred_spans_the_band_and_compresses_to_0886_over_b():
    radar = nav_paper_sim()  # B = 500 MHz, T = 1 us, fs = 1 GHz: TB = 500
    t, p = replica(radar)
    assert t[0] == -t[-1] and abs(t[-1]) <= radar.pulse_length / 2 and t.size == 1001
    spec = np.abs(np.fft.fftshift(np.fft.fft(p, 8 * p.size))) ** 2
    f = np.fft.fftshift(np.fft.fftfreq(8 * p.size, 1 / radar.sample_rate))
    in_band = np.abs(f) <= radar.bandwidth / 2
    assert spec[in_band].sum() / spec.sum() > 0.98  # Fresnel ripples put ~1 % outside
    up = 32  # the matched-filter output |p * p|, upsampled 32 x by zero-padding its spectrum
    P = np.fft.fft(p, 2 * p.size)
    mf = np.abs(np.fft.ifft(np.fft.ifftshift(np.pad(np.fft.fftshift(P * np.conj(P)), (up - 1) * p.size))))
    width = np.sum(mf >= mf.max() / np.sqrt(2)) / (radar.sample_rate * up)  # samples above -3 dB x spacing
    assert width == pytest.approx(0.886 / radar.bandwidth, rel=0.05)
