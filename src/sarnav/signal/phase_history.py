"""Phase history (frequency samples per pulse, the CPHD convention) <-> range-compressed pulses.

CPHD signal model (NGA.STND.0068-1 CPHD 1.0.1 §2-§4, "Compensated Phase History Data"; FX domain):
vector k holds N frequency samples ``S_k(f_n)`` at ``f_n = SC0_k + n SCSS_k`` [Hz], compensated to a
reference point (the SRP) so that a point scatterer whose two-way delay exceeds the reference delay
by ``dtau`` [s] contributes ``S_k(f) = a exp(j 2 pi SGN f dtau)`` (SGN = -1 in almost every file).
For a monostatic collect ``dtau = 2 (R - R_ref,k) / c`` with ``R_ref,k = |SRP_k - ARP_k|`` the
reference range of pulse k. TOA1_k <= dtau <= TOA2_k bounds the delays the vector supports.

sarnav's range-compressed convention (docs/conventions.md): a scatterer of amplitude a at range R
gives the baseband pulse ``a D(r - R) exp(-j 4 pi R / lambda)`` with D the real range response and
lambda = c / f_c. Both are related exactly, for any r (derivation in docs/io.md):

    s_k(r) = exp(-j 4 pi f_c r / c) * sum_n S_k(f_n) exp(j 4 pi f_n (r - R_ref,k) / c)     (SGN = -1)

(SGN = +1 data are conjugated first). Evaluated on one uniform absolute range axis r_m = r_0 + m dr
this is a chirp-z transform of each vector, whatever its own reference range, start frequency
and spacing: the per-pulse reference ranges of a CPHD are absorbed and every pulse lands on the
same axis, ready for back-projection. Samples whose delay falls outside [TOA1_k, TOA2_k] are set
to zero (the vector carries no information there; the sum is periodic in r with period
c / (2 SCSS)).

The inverse (:func:`pulses_to_phase_history`) pads each pulse to ``N_fx >= pad * N`` samples and
takes a DFT with frequencies symmetric about f_c; reading it back on the original axis returns the
original samples up to rounding (the two sums are a DFT pair on that lattice).

Geometry float64; positions in any Cartesian frame (ECEF for CPHD files).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import scipy.fft as sfft
import scipy.signal as ssig

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData

__all__ = ["PhaseHistory", "phase_history_to_pulses", "pulses_to_phase_history", "default_range_axis",
           "DEFAULT_OVERSAMPLE"]

#: speed of light [m/s] (same value as sarnav.units.C; signal sits below units-independent layers)
_C = 299792458.0
#: default range sampling of :func:`phase_history_to_pulses`: fs / B = 4 of the stored band N SCSS. The chirp-z
#: evaluation is exact at every sample whatever the spacing; what the spacing decides is how well back-projection
#: interpolates between samples. On the DFT lattice (fs / B = 1) the band fills the sampling period: no short kernel
#: interpolates it, and the FFT upsampling that must come first treats the window as periodic (it is not: the
#: delay window is not the sum's period, and the samples outside TOA1..TOA2 are zeroed): -52 dB against the exact
#: sum at best. At fs / B = 2 the zeroed window edges still limit "precise" to -77 dB; at 4 back-projection's "auto"
#: (Lagrange on x2 upsampled pulses) measures -76 dB and "precise" -89 dB (docs/imaging.md). Memory: 4 x the
#: vector length per pulse (complex128).
DEFAULT_OVERSAMPLE = 4.0


def _finite(name: str, a, shape=None) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if shape is not None and a.shape != shape:
        raise InputDataError(name, f"must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputDataError(name, "must be finite (found NaN/inf)")
    return a


@dataclass
class PhaseHistory:
    """Monostatic FX-domain phase history, one vector per pulse (CPHD convention, module doc).

    Attributes
    ----------
    data : (P, N) complex frequency samples S_k(f_n).
    fx0 : (P,) frequency of the first sample, SC0 [Hz].
    fx_step : (P,) frequency sample spacing, SCSS [Hz] (> 0).
    positions : (P, 3) float64 antenna reference positions (ARP; ECEF for CPHD) [m].
    ref_range : (P,) reference range |SRP_k - ARP_k| where the relative delay is zero [m];
        a reference *time* t_ref converts as c t_ref / 2.
    pulse_times : (P,) transmit times [s].
    toa : (P, 2) supported relative delays [TOA1, TOA2] [s], or None (the whole period).
    sgn : phase sign convention SGN of the file, -1 or +1.
    """

    data: np.ndarray
    fx0: np.ndarray
    fx_step: np.ndarray
    positions: np.ndarray
    ref_range: np.ndarray
    pulse_times: np.ndarray
    toa: np.ndarray | None = None
    sgn: int = -1

    def __post_init__(self):
        d = np.asarray(self.data)
        if d.ndim != 2 or d.shape[0] < 1 or d.shape[1] < 2:
            raise InputDataError("phase_history.data", f"must be (P, N) with P >= 1, N >= 2, got {d.shape}")
        if not np.iscomplexobj(d):
            d = d.astype(np.complex128)
        if not np.all(np.isfinite(d)):
            raise InputDataError("phase_history.data", "must be finite (found NaN/inf)")
        p = d.shape[0]
        self.data = d
        self.fx0 = _finite("phase_history.fx0", np.broadcast_to(np.asarray(self.fx0, float), (p,)).copy())
        self.fx_step = _finite("phase_history.fx_step", np.broadcast_to(np.asarray(self.fx_step, float), (p,)).copy())
        if np.any(self.fx0 <= 0) or np.any(self.fx_step <= 0):
            raise InputDataError("phase_history.fx0/fx_step", "must be > 0 Hz (FX domain)")
        self.positions = _finite("phase_history.positions", self.positions, (p, 3))
        self.ref_range = _finite("phase_history.ref_range", self.ref_range, (p,))
        self.pulse_times = _finite("phase_history.pulse_times", self.pulse_times, (p,))
        if self.toa is not None:
            self.toa = _finite("phase_history.toa", self.toa, (p, 2))
            if np.any(self.toa[:, 1] <= self.toa[:, 0]):
                raise InputDataError("phase_history.toa", "needs TOA2 > TOA1 for every pulse")
        if self.sgn not in (-1, 1):
            raise InputDataError("phase_history.sgn", f"must be -1 or +1, got {self.sgn!r}")

    @property
    def n_pulses(self) -> int:
        return self.data.shape[0]

    @property
    def center_frequency(self) -> float:
        """(min f_0 + max f_last) / 2 over all pulses [Hz] (CPHD FxC)."""
        last = self.fx0 + (self.data.shape[1] - 1) * self.fx_step
        return 0.5 * (float(np.min(self.fx0)) + float(np.max(last)))

    def delay_window(self) -> np.ndarray:
        """(P, 2) relative delays [s] each vector supports: ``toa`` or one period 1/SCSS centred on 0."""
        if self.toa is not None:
            return self.toa
        half = 0.5 / self.fx_step
        return np.stack([-half, half], axis=1)


def default_range_axis(ph: PhaseHistory, oversample: float = DEFAULT_OVERSAMPLE) -> np.ndarray:
    """Uniform absolute range axis covering every pulse's supported delays [m], float64.

    Spacing ``c / (2 oversample N SCSS_min)`` (``oversample`` = 1: the DFT lattice, fs/B = N/(N-1)
    of the stored band; default :data:`DEFAULT_OVERSAMPLE`); first sample ``min_k (R_ref,k + c TOA1_k / 2)``.
    """
    if not (math.isfinite(oversample) and oversample >= 1.0):
        raise ConfigError("oversample", f"must be finite and >= 1, got {oversample!r}")
    win = ph.delay_window()
    lo = float(np.min(ph.ref_range + 0.5 * _C * win[:, 0]))
    hi = float(np.max(ph.ref_range + 0.5 * _C * win[:, 1]))
    dr = _C / (2.0 * oversample * ph.data.shape[1] * float(np.min(ph.fx_step)))
    n = int(math.floor((hi - lo) / dr * (1 + 1e-12))) + 1
    return lo + np.arange(max(n, 2), dtype=np.float64) * dr


@numba.njit(cache=True, nogil=True)  # nogil: the read-ahead threads twiddle while the navigator works
def _frac_phase_kernel(cycles, out):  # pragma: no cover - numba
    c, o = cycles.ravel(), out.ravel()
    for i in range(c.size):
        t = 2.0 * math.pi * (c[i] - np.round(c[i]))
        o[i] = complex(math.cos(t), math.sin(t))


def _frac_phase(cycles: np.ndarray) -> np.ndarray:
    """exp(j 2 pi cycles) with cycles reduced to their fractional part first (float64 exactness). A numba loop of
    cos and sin: 1.8x numpy's complex exp on a CPHD file's 100 x 2458 twiddles (7.1 -> 4.0 ms, the same values to
    the last bit on that file; ``tests/signal/test_phase_history.py``)."""
    c = np.require(cycles, dtype=np.float64, requirements="C")
    out = np.empty(c.shape, dtype=np.complex128)
    _frac_phase_kernel(c, out)
    return out


#: samples per block of :func:`_ramp_multiply`: one exact exp at each block start, then products within the block
RAMP_BLOCK = 32


@numba.njit(cache=True, nogil=True)  # pragma: no cover - numba
def _ramp_kernel(x, a, b, out):
    rows, cols = x.shape
    steps = np.empty(RAMP_BLOCK, dtype=np.complex128)
    for k in range(rows):
        for j in range(RAMP_BLOCK):
            c = b[k] * j
            t = 2.0 * math.pi * (c - np.round(c))
            steps[j] = complex(math.cos(t), math.sin(t))
        for j0 in range(0, cols, RAMP_BLOCK):
            c = a[k] + b[k] * j0
            t = 2.0 * math.pi * (c - np.round(c))
            base = complex(math.cos(t), math.sin(t))
            for j in range(min(RAMP_BLOCK, cols - j0)):
                out[k, j0 + j] = x[k, j0 + j] * (base * steps[j])


def _ramp_multiply(x: np.ndarray, a, b, out: np.ndarray | None = None) -> np.ndarray:
    """``x[k, j] exp(j 2 pi (a_k + b_k j))`` (x (P, M) complex; a, b (P,) [cycles]): the twiddles of a linear phase
    ramp per row, each reduced to its fractional cycle before the exp (float64 exactness). One cos/sin pair at every
    ``RAMP_BLOCK``-th sample and one complex product per sample: the same values as an exp of every sample to the
    rounding of the cycles themselves (a few 1e-12 relative for ramps reaching 1e3 cycles, -230 dB;
    ``tests/signal/test_phase_history.py``), 0.4 ms against 7-17 ms for a CPHD file's 100 x 2458 twiddles.
    ``out`` may be ``x`` (in place)."""
    x = np.ascontiguousarray(x, dtype=np.complex128)
    out = np.empty_like(x) if out is None else out
    _ramp_kernel(x, np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64), out)
    return out


def _check_filter(filt, n: int):
    if filt is None:
        return None
    h = np.asarray(filt)
    if h.ndim != 1:
        raise InputDataError("filter", f"must be 1-D (one weight per frequency sample), got shape {h.shape}")
    if n < h.size:
        raise InputDataError("phase_history.data", f"has {n} frequency samples per pulse, shorter than the "
                             f"filter's {h.size}: the phase history must cover the filter")
    if h.size != n:
        raise InputDataError("filter", f"must have {n} weights (one per frequency sample), got {h.size}")
    if not np.all(np.isfinite(h)):
        raise InputDataError("filter", "must be finite (found NaN/inf)")
    return h


#: largest phase error [rad] :func:`_chirp_z` accepts for taking a sum's spacing as an exact DFT lattice 1 / L
LATTICE_PHASE_TOLERANCE = 1e-10


def _chirp_z(x: np.ndarray, m: int, alpha: float) -> np.ndarray:
    """``X[..., k] = sum_n x[..., n] exp(j 2 pi alpha n k)`` for k < m (a chirp-z transform along the last axis).

    On a DFT lattice, alpha = 1 / L with L an FFT-friendly integer >= N (the case of a file written on the range
    axis it is read on: ``pulses_to_phase_history``), the sum is L times an inverse FFT of length L, periodic in k
    with period L: one FFT of L samples instead of the chirp-z's three of >= N + m - 1 and its chirp products (3-4x
    faster). Taken when L is no longer than the chirp-z's own FFT (N + m - 1: a fine axis over a short window has a
    long period L, whose FFT would cost more time and memory than the chirp-z) and the phase its kernel would miss,
    2 pi |alpha - 1/L| (N - 1)(m - 1), is at most :data:`LATTICE_PHASE_TOLERANCE`; otherwise ``scipy.signal.czt``.
    Both are exact to rounding."""
    n = x.shape[-1]
    cap = sfft.next_fast_len(n + m - 1)
    lat = int(round(1.0 / alpha)) if alpha * (cap + 1) >= 1.0 else 0  # never rounds an overflowing 1 / alpha
    if (max(n, 1) <= lat <= cap and sfft.next_fast_len(lat) == lat
            and 2.0 * math.pi * abs(alpha - 1.0 / lat) * (n - 1) * (m - 1) <= LATTICE_PHASE_TOLERANCE):
        y = sfft.ifft(x, n=lat, axis=-1)
        y *= lat
        return y[..., :m] if m <= lat else y[..., np.arange(m) % lat]
    return ssig.czt(x, m=m, w=np.exp(2j * np.pi * alpha), a=1.0, axis=-1)


def phase_history_to_pulses(ph: PhaseHistory, range_axis=None, *, wavelength: float | None = None,
                            oversample: float = DEFAULT_OVERSAMPLE, filter=None, metadata: dict | None = None
                            ) -> PulseData:
    """Range-compressed pulses on one absolute range axis from a phase history (module doc equation).

    Parameters
    ----------
    ph : the phase history.
    range_axis : (M,) uniform increasing absolute ranges [m]; default :func:`default_range_axis`.
    wavelength : lambda = c / f_c of the baseband output [m]; default ``c / ph.center_frequency``.
    oversample : spacing factor of the default axis, fs / B of the stored band (ignored when ``range_axis`` is
        given); default :data:`DEFAULT_OVERSAMPLE` (4).
    filter : optional (N,) weights multiplying every vector's samples (a window, or a matched filter
        for a vector not yet compensated); must have exactly N entries.

    Returns
    -------
    PulseData, ``compressed=True``, ``params=None``, ``wavelength`` set, complex128 data, positions
    ``ph.positions`` (same frame); ``metadata["stored_band_hz"]`` = N max(SCSS), the band the vectors hold
    (``bandwidth`` stays None: back-projection's "auto" estimates the signal's band from the pulses' spectrum).
    """
    if not isinstance(ph, PhaseHistory):
        raise InputDataError("phase_history", f"must be a PhaseHistory, got {type(ph).__name__}")
    n = ph.data.shape[1]
    h = _check_filter(filter, n)
    r = default_range_axis(ph, oversample) if range_axis is None else _finite("range_axis", range_axis)
    if r.ndim != 1 or r.size < 2 or not np.all(np.diff(r) > 0) or not np.allclose(np.diff(r), r[1] - r[0],
                                                                                   rtol=1e-9, atol=0.0):
        raise InputDataError("range_axis", "must be 1-D, >= 2 samples, strictly increasing and uniform")
    fc = _C / wavelength if wavelength is not None else ph.center_frequency
    if not (math.isfinite(fc) and fc > 0):
        raise ConfigError("wavelength", f"must be finite and > 0 m, got {wavelength!r}")
    data = np.conj(ph.data) if ph.sgn == 1 else ph.data
    if h is not None:
        data = data * h[None, :]
    r0, dr, m = float(r[0]), float(r[1] - r[0]), r.size
    out = np.empty((ph.n_pulses, m), dtype=np.complex128)
    win = ph.delay_window()
    for step in np.unique(ph.fx_step):
        sel = np.flatnonzero(ph.fx_step == step)
        # pre-twiddle exp(j 4 pi n SCSS (r_0 - R_ref) / c), then sum_n x_n W^(n m), W = exp(j 4 pi SCSS dr / c)
        cyc = 2.0 * step * (r0 - ph.ref_range[sel]) / _C
        x = _ramp_multiply(data[sel], np.zeros(sel.size), cyc)
        out[sel] = _chirp_z(x, m, 2.0 * step * dr / _C)
    # post-twiddle exp(j 4 pi (f_0 - f_c) r_m / c) exp(-j 4 pi f_0 R_ref / c), reduced in cycles
    # per pulse a ramp in m: 2 (f_0 - f_c) (r_0 + m dr) / c - frac(2 f_0 R_ref / c)
    cyc_b = 2.0 * ph.fx0 * ph.ref_range / _C
    _ramp_multiply(out, 2.0 * (ph.fx0 - fc) * r0 / _C - (cyc_b - np.round(cyc_b)), 2.0 * (ph.fx0 - fc) * dr / _C,
                   out=out)
    delay = 2.0 * (r[None, :] - ph.ref_range[:, None]) / _C
    tol = 1e-6 * 2.0 * dr / _C
    out[(delay < win[:, :1] - tol) | (delay > win[:, 1:] + tol)] = 0.0
    meta = {"source": "phase_history", "sgn": int(ph.sgn), "stored_band_hz": n * float(np.max(ph.fx_step))}
    meta.update(metadata or {})
    return PulseData(out, r.copy(), ph.pulse_times.copy(), ph.positions.copy(), None, compressed=True,
                     metadata=meta, wavelength=_C / fc)


def pulses_to_phase_history(rc: PulseData, ref_range, *, pad: float = 1.25, wavelength: float | None = None
                            ) -> PhaseHistory:
    """The phase history whose :func:`phase_history_to_pulses` on ``rc.slant_range`` returns ``rc.data``.

    Each pulse is zero-padded to ``N_fx = next_fast_len(ceil(pad N))`` samples (``pad`` >= 1.2 keeps
    the CPHD FX oversampling 1/(SCSS (TOA2 - TOA1)) >= 1.2) and transformed with frequencies
    ``f_n = f_c + (n - (N_fx - 1)/2) SCSS``, ``SCSS = c / (2 N_fx dr)``, symmetric about f_c, and
    ``S_n = exp(j 4 pi f_n R_ref / c) / N_fx * sum_m b_m exp(-j 4 pi (f_n - f_c) r_m / c)``; TOA1/2 are
    the delays of the first and last sample. SGN = -1.

    Parameters
    ----------
    rc : range-compressed pulses (uniform ``slant_range``) with a wavelength.
    ref_range : (P,) reference ranges R_ref,k [m] (|SRP - ARP_k| for a CPHD).
    """
    if not isinstance(rc, PulseData) or not rc.compressed:
        raise InputDataError("rc", "must be range-compressed PulseData (compressed=True)")
    b = np.asarray(rc.data)
    p, n = b.shape
    r = _finite("rc.slant_range", rc.slant_range, (n,))
    if not np.all(np.isfinite(b)):
        raise InputDataError("rc.data", "must be finite (found NaN/inf)")
    rref = _finite("ref_range", ref_range, (p,))
    lam = wavelength if wavelength is not None else rc.carrier_wavelength
    if lam is None or not (math.isfinite(lam) and lam > 0):
        raise ConfigError("wavelength", f"must be finite and > 0 m (or rc must carry one), got {lam!r}")
    if not (math.isfinite(pad) and pad >= 1.0):
        raise ConfigError("pad", f"must be finite and >= 1, got {pad!r}")
    fc = _C / lam
    dr = float(r[1] - r[0])
    nfx = sfft.next_fast_len(int(math.ceil(pad * n)))
    step = _C / (2.0 * nfx * dr)
    k = np.arange(nfx) - 0.5 * (nfx - 1)
    fb = k * step
    # C_n = exp(-j 4 pi fb_n r_0 / c) * FFT_nfx(b_m exp(j 2 pi h m / nfx))[n],  h = (nfx - 1)/2
    mod = np.exp(2j * np.pi * (0.5 * (nfx - 1)) * np.arange(n) / nfx)
    cn = sfft.fft(b * mod[None, :], n=nfx, axis=1) * _frac_phase(-2.0 * fb * r[0] / _C)[None, :]
    f = fc + fb
    s = cn / nfx * _frac_phase(2.0 * np.outer(rref, f) / _C)
    toa = np.stack([2.0 * (r[0] - rref) / _C, 2.0 * (r[-1] - rref) / _C], axis=1)
    return PhaseHistory(s, np.full(p, f[0]), np.full(p, step), np.asarray(rc.positions, np.float64), rref,
                        np.asarray(rc.pulse_times, np.float64), toa, -1)
