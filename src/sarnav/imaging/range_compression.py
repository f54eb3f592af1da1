"""Range compression: frequency-domain matched filter (thesis (5.3), paper eq. (3)).

``s_rc = IFFT{ S_rx(f) conj(P(f)) W(f) } / g``, P the FFT of the centred replica
(:func:`sarnav.radar.waveform.replica`) laid with its t = 0 sample at index 0, so the output is a
correlation with zero lag at sample 0: the peak of a target at range R falls at the sample whose
slant range is R (``raw.slant_range`` is kept). Zero padding to ``scipy.fft.next_fast_len(N + M)``
avoids circular wrap. W is the spectral window (:func:`sarnav.signal.windows.frequency_weights`).
The gain ``g = sum_f W(f) |P(f)|^2 / nfft`` (the filter's response to the replica itself at zero
lag) normalises the output so that a scatterer of amplitude a has compressed peak a exp(-j4piR/lambda)
for any window.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.fft as sfft

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData
from sarnav.signal.windows import as_window, frequency_weights
from sarnav.radar.waveform import sampled_replica


FILTER_MODES = ("matched", "equalized")


def matched_filter(sample_rate: float, bandwidth: float, pulse_length: float, nfft: int, window="none",
                   mode: str = "matched") -> np.ndarray:
    """(nfft,) normalised range-compression filter H(f) / g of the centred chirp of bandwidth B =
    ``bandwidth`` [Hz] and duration T = ``pulse_length`` [s] sampled at fs = ``sample_rate`` [Hz].

    ``mode="matched"``: H = conj(P(f)) W(f), the matched filter (thesis (5.3)); its output spectrum
    W |P|^2 carries the Fresnel ripple of the finite time-bandwidth chirp, so weighted sidelobes
    come out somewhat above the ideal-window values (docs/radar.md).
    ``mode="equalized"``: H = W(f) / P(f) on the band |f| <= B/2 (0 outside), with W = 1 for
    "none": the output spectrum is exactly the window, so the IRF is the window's theoretical one.
    g = sum_f H(f) P(f) / nfft, the zero-lag response to the replica.
    """
    if mode not in FILTER_MODES:
        raise ConfigError("mode", f"must be one of {FILTER_MODES}, got {mode!r}")
    t, p = sampled_replica(sample_rate, pulse_length, bandwidth / pulse_length)
    ref = np.zeros(nfft, dtype=np.complex128)
    half = (p.size - 1) // 2
    ref[: half + 1] = p[half:]  # t >= 0
    ref[nfft - half:] = p[:half]  # t < 0 wrapped to the end
    spec = sfft.fft(ref)
    freqs = sfft.fftfreq(nfft, d=1.0 / sample_rate)
    w = frequency_weights(window, freqs, bandwidth)
    if mode == "matched":
        h = np.conj(spec) * w
    else:
        in_band = np.abs(freqs) <= 0.5 * bandwidth * (1 + 1e-12)
        if as_window(window).name == "none":
            w = in_band.astype(np.float64)
        h = np.where(in_band, w / np.where(in_band, spec, 1.0), 0.0)
    gain = float(np.real(np.sum(h * spec)) / nfft)
    return h / gain


def range_compress(raw: PulseData, window=None, mode: str = "matched", workers: int | None = None,
                   columns: tuple[int, int] | None = None) -> PulseData:
    """Range-compress raw echoes with the normalised matched filter.

    Parameters
    ----------
    raw : PulseData with ``compressed=False`` and its ``sample_rate``, ``bandwidth`` and
        ``pulse_length`` (``simulate_echoes`` fills them from the radar).
    window : spectral window (name, tuple, dict, Window); None uses ``raw.range_window`` ("none"
        when that is None).
    mode : "matched" (default, matched filter) or "equalized" (spectrum equalised to the window);
        see :func:`matched_filter`.
    workers : scipy.fft worker threads (None = scipy default).
    columns : (a, b): only the output samples a .. b-1 (``slant_range[a:b]``). The output is a correlation with the
        centred replica, so sample j needs the input samples j - h .. j + h (h its half length): those alone are
        transformed, with a shorter FFT; the values are the full compression's to FFT rounding (~1e-16 relative).
        The receiver-noise model of the extractor compresses unit noise for a chip's range window only this way.

    Returns
    -------
    PulseData, ``compressed=True``, same ``slant_range``/``pulse_times``/``positions`` and radar
    fields; complex128 (complex64 input gives complex64); ``metadata`` gains ``range_window``.
    """
    if not isinstance(raw, PulseData):
        raise InputDataError("raw", f"must be a PulseData, got {type(raw).__name__}")
    if raw.compressed:
        raise InputDataError("raw.compressed", "data are already range compressed")
    fs, bw, t_p = _waveform(raw)
    data = np.asarray(raw.data)
    n_r = np.size(raw.slant_range)
    if data.ndim != 2 or data.shape[1] != n_r:
        raise InputDataError("raw.data", f"must have shape (P, {n_r}) (one column per slant_range sample), "
                             f"got {data.shape}")
    if not np.all(np.isfinite(data)):
        raise InputDataError("raw.data", "contains NaN or inf")
    w = as_window((raw.range_window or "none") if window is None else window, "window")
    n = data.shape[1]
    m = sampled_replica(fs, t_p, bw / t_p)[1].size
    a, b, lo = 0, n, 0
    if columns is not None:
        a, b = (int(c) for c in columns)
        lo, hi = compression_reach(raw, (a, b))
        data = data[:, lo:hi]
    nfft = sfft.next_fast_len(data.shape[1] + m)
    h = matched_filter(fs, bw, t_p, nfft, w, mode)
    spec = sfft.fft(data, n=nfft, axis=1, workers=workers)
    spec *= h[None, :]
    out = sfft.ifft(spec, axis=1, workers=workers)[:, a - lo:b - lo]
    if data.dtype == np.complex64:
        out = out.astype(np.complex64)
    meta = dict(raw.metadata)
    meta["range_window"] = w.label
    meta["range_filter"] = mode
    if columns is not None:
        return replace(raw, data=out, compressed=True, metadata=meta, slant_range=np.asarray(raw.slant_range)[a:b])
    return replace(raw, data=out, compressed=True, metadata=meta)


def compression_reach(raw: PulseData, columns: tuple[int, int]) -> tuple[int, int]:
    """(lo, hi): the input samples ``raw.data[:, lo:hi]`` that the output samples ``columns`` = (a, b) of
    :func:`range_compress` depend on (a correlation with the centred replica reaches its half length either side).
    Compressing ``raw`` cropped to them with columns (a - lo, b - lo) gives the same values bit for bit."""
    fs, bw, t_p = _waveform(raw)
    n = np.size(raw.slant_range)
    a, b = (int(c) for c in columns)
    if not 0 <= a < b <= n:
        raise InputDataError("columns", f"must be 0 <= a < b <= {n}, got {columns!r}")
    half = (sampled_replica(fs, t_p, bw / t_p)[1].size - 1) // 2 + 1  # the replica's reach either side of zero lag
    return max(a - half, 0), min(b + half, n)


def _waveform(raw: PulseData) -> tuple[float, float, float]:
    """(sample_rate, bandwidth, pulse_length) of raw pulses, each finite and > 0 (InputDataError naming it)."""
    values = (("sample_rate", raw.sample_rate), ("bandwidth", raw.bandwidth), ("pulse_length", raw.pulse_length))
    for name, v in values:
        if v is None or not (math.isfinite(v) and v > 0):
            raise InputDataError(f"raw.{name}", f"range compression needs it finite and > 0, got {v!r} "
                                 "(simulate_echoes fills it from the RadarParams)")
    return raw.sample_rate, raw.bandwidth, raw.pulse_length
