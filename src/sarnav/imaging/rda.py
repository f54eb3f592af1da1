"""Range-Doppler Algorithm (RDA) for zero-squint, straight-line stripmap data.

Steps (Lindstrom 2020 thesis §5.2, L1161–L1169; paper Lindstrom et al. 2022 §2.1, eqs. 4–13;
notes/seed-000 §9, notes/seed-001 §2.1), on range-compressed pulses ``rc`` (rows = pulses):

1. optional azimuth weighting of the pulses (window, see below);
2. azimuth FFT (eq. 4): ``S_rc(f_eta, R0)``;
3. range-variant RCMC (eq. 5/9): row ``f_eta`` is resampled at ``R0 + dR(f_eta, R0)`` with
   ``dR = lambda^2 R0 f_eta^2 / (8 V^2)``, by an 8-tap Kaiser-windowed sinc (beta = 2.5, 1024
   fractional positions, taps normalised to unit DC gain; the kernel Cumming & Wong 2005 §3.4
   recommend, gap G9; tabulated in :mod:`sarnav.imaging.kernels`, ``rcmc_kernel_table``);
4. azimuth matched filter per range bin (eqs. 10–12), by stationary phase
   ``H(f_eta) = exp(-j pi f_eta^2 / K_a)``, ``K_a = 2 V^2 / (lambda R0)`` (eq. 7);
5. inverse azimuth FFT (eq. 13).

``azimuth_model="hyperbolic"`` replaces the parabolic forms of steps 3–4 by the exact zero-squint
ones, ``dR = R0 (1/D - 1)`` and ``H = exp(j 4 pi R0 (D - 1) / lambda)`` with
``D = sqrt(1 - (lambda f_eta / 2V)^2)`` (Cumming & Wong eqs. 6.25, 7.17); both reduce to the paper's
forms to second order in ``f_eta``.

Assumptions (documented limits)
-------------------------------
* Stop-and-hop, zero squint (Doppler centroid 0, thesis Tables 5.1/5.3), straight constant-speed
  track: the speed ``V`` used for focusing is an **input** (navigation estimate or truth); the
  antenna positions the data are referred to (``rc.positions``, replaceable with
  ``PulseData.with_positions``) only label the image rows.
* Baseband data with the carrier phase ``-4 pi R / lambda`` of docs/conventions.md, uniform pulse
  times, uniform slant-range samples.
* The azimuth FFT is circular over the pulses of the block: the whole Doppler band of the scene must
  fit in the PRF, and a target must be inside the block to be focused in place.
* The azimuth window weights the *pulses* (slow time). For a target seen by all pulses, ``f_eta =
  -K_a (eta - eta_c)`` (eq. 8) maps that weighting onto its Doppler band, i.e. it is the spectral
  window of ``sarnav.signal.windows`` for every target, whatever its position in the block.

Image axes
----------
Rows are azimuth times (one per pulse); row k is labelled with the along-track coordinate of the
antenna at that time, ``y_k = u . (p(t_k) - origin)`` from a straight-line least-squares fit of the
given positions (``u`` = unit track direction, first to last position; ``origin`` defaults to the
first position). Zero squint puts a target at the row of its time of closest approach, i.e. at its
own along-track coordinate. Columns are slant range of closest approach (the ``rc.slant_range`` axis).
"""

from __future__ import annotations

import math

import numba
import numpy as np
import scipy.fft as sfft

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.kernels import RCMC_KERNELS, RCMC_TABLE_STEPS, rcmc_kernel_table
from sarnav.signal.data import PulseData, SarImage
from sarnav.signal.windows import as_window

__all__ = ["range_doppler", "azimuth_compressed_spectrum", "image_from_focused", "apply_azimuth_filter", "rcmc_kernel_table", "radar_constants",
           "along_track_axis", "uniform_prf", "RCMC_KERNELS"]


@numba.njit(cache=True, nogil=True)
def _rcmc_and_filter(spec, shift_coef, phase_coef, r_first, dr, table, steps, do_rcmc, absf, fr_limit):
    """out[i, j] = interp(spec[i, :], at R0_j (1 + a_i)) * exp(j b_i R0_j), R0_j = r_first + j dr,
    and 0 where |f_i| R0_j > fr_limit (the band limit |f| <= K_a(R0) T_band).

    The input position is linear in j (pos_j = j (1 + a_i) + a_i r_first / dr) and the phase factor
    is a geometric sequence in j; both are advanced incrementally and re-anchored every 64 samples
    (rounding drift < 1e-13).
    """
    na, nr = spec.shape
    out = np.empty_like(spec)
    taps = table.shape[1]
    lo_off = taps // 2 - 1
    for i in range(na):
        a = shift_coef[i]
        b = phase_coef[i]
        step = complex(math.cos(b * dr), math.sin(b * dr))
        slope = 1.0 + a
        off = a * r_first / dr
        rot = 0j
        for j in range(nr):
            if j % 64 == 0:
                ph = b * (r_first + j * dr)
                rot = complex(math.cos(ph), math.sin(ph))
            if absf[i] * (r_first + j * dr) > fr_limit:
                out[i, j] = 0j
                rot *= step
                continue
            if not do_rcmc:
                out[i, j] = spec[i, j] * rot
            else:
                pos = j * slope + off
                base = int(math.floor(pos))
                q = int((pos - base) * steps + 0.5)
                if q == steps:
                    q = 0
                    base += 1
                k0 = base - lo_off
                if q == 0 and 0 <= base < nr:
                    acc = spec[i, base]  # table row 0 is the identity
                elif k0 >= 0 and k0 + taps <= nr:
                    acc = 0j
                    for t in range(taps):
                        acc += table[q, t] * spec[i, k0 + t]
                else:
                    acc = 0j
                    for t in range(taps):
                        k = k0 + t
                        if 0 <= k < nr:
                            acc += table[q, t] * spec[i, k]
                out[i, j] = acc * rot
            rot *= step
    return out


def apply_azimuth_filter(spec: np.ndarray, phase_per_metre: np.ndarray, slant_range: np.ndarray,
                         abs_freq: np.ndarray | None = None, fr_limit: float = math.inf) -> np.ndarray:
    """``spec * exp(1j * outer(phase_per_metre, slant_range))`` (the per-range-bin matched filter of
    eq. 12 on an RCMC'd spectrum), zero where ``abs_freq * slant_range > fr_limit`` (band limit),
    computed by the compiled kernel without RCMC."""
    r = np.asarray(slant_range, dtype=np.float64)
    dr = float(r[-1] - r[0]) / (r.size - 1)
    absf = np.zeros(spec.shape[0]) if abs_freq is None else np.asarray(abs_freq, dtype=np.float64)
    return _rcmc_and_filter(np.ascontiguousarray(spec), np.zeros(spec.shape[0]),
                            np.asarray(phase_per_metre, dtype=np.float64), float(r[0]), dr,
                            rcmc_kernel_table(2, 0.0), RCMC_TABLE_STEPS, False, absf, float(fr_limit))


def radar_constants(rc: PulseData) -> dict:
    """Carrier frequency, wavelength and bandwidth of range-compressed pulses from their explicit
    fields (``rc.wavelength``, ``rc.bandwidth``; f_c = c / lambda). Raises
    ``InputDataError("rc.wavelength", ...)`` when the pulses carry no wavelength."""
    lam = rc.carrier_wavelength
    if lam is None or not (math.isfinite(lam) and lam > 0):
        raise InputDataError("rc.wavelength", f"the RDA needs the carrier wavelength (finite, > 0 m), got {lam!r}")
    bw = rc.bandwidth
    return {"carrier_frequency": rc.carrier_frequency, "wavelength": lam, "bandwidth": None if bw is None else float(bw)}


def uniform_prf(pulse_times: np.ndarray) -> float:
    """The pulse repetition frequency [Hz] of uniformly spaced ``pulse_times`` [s] (an error for any other)."""
    t = np.asarray(pulse_times, dtype=np.float64)
    if t.ndim != 1 or t.size < 2:
        raise InputDataError("rc.pulse_times", f"must be 1-D with >= 2 pulses, got shape {t.shape}")
    dt = np.diff(t)
    if np.any(dt <= 0) or np.ptp(dt) > 1e-6 * dt.mean():
        raise InputDataError("rc.pulse_times", "must be strictly increasing and uniform (constant PRF)")
    return 1.0 / float(dt.mean())


def along_track_axis(positions, pulse_times, origin=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Along-track coordinate of each pulse from a straight-line fit of the antenna positions.

    Returns
    -------
    y : (P,) along-track coordinate [m] of the fitted antenna position at each pulse time.
    direction : (3,) unit track direction (last minus first position).
    origin : (3,) reference point of the along-track coordinate.
    track_speed : slope of the fit [m/s].
    """
    p = np.asarray(positions, dtype=np.float64)
    t = np.asarray(pulse_times, dtype=np.float64)
    if p.ndim != 2 or p.shape != (t.size, 3) or not np.all(np.isfinite(p)):
        raise InputDataError("rc.positions", f"must be finite with shape ({t.size}, 3), got {p.shape}")
    d = p[-1] - p[0]
    n = float(np.linalg.norm(d))
    if n == 0.0:
        raise InputDataError("rc.positions", "first and last antenna positions coincide: no track")
    u = d / n
    o = p[0] if origin is None else np.asarray(origin, dtype=np.float64).reshape(3)
    s = (p - o) @ u
    slope, icept = np.polyfit(t - t[0], s, 1)
    return icept + slope * (t - t[0]), u, o, float(slope)


def _check_inputs(rc: PulseData):
    if not isinstance(rc, PulseData):
        raise InputDataError("rc", f"must be a PulseData, got {type(rc).__name__}")
    data = np.asarray(rc.data)
    if data.ndim != 2 or data.shape[0] < 2 or data.shape[1] < 2:
        raise InputDataError("rc.data", f"must be (pulses, range bins) with both >= 2, got {data.shape}")
    if not rc.compressed:
        raise InputDataError("rc.compressed", "RDA needs range-compressed pulses (range_compress first)")
    r = np.asarray(rc.slant_range, dtype=np.float64)
    if r.shape != (data.shape[1],):
        raise InputDataError("rc.slant_range", f"must have {data.shape[1]} samples, got {r.shape}")
    dr = np.diff(r)
    if np.any(dr <= 0) or np.ptp(dr) > 1e-6 * dr.mean():
        raise InputDataError("rc.slant_range", "must be strictly increasing and uniform")
    if not np.all(np.isfinite(data)):
        raise InputDataError("rc.data", "contains NaN or inf")
    return data, r


def azimuth_compressed_spectrum(rc: PulseData, speed: float, *, window="none", rcmc_kernel: str = "sinc8",
                                azimuth_model: str = "parabolic", fm_rate_scale: float = 1.0,
                                apply_filter: bool = True, azimuth_padding: float = 1.0, band_limit: float = 1.0,
                                _checked=None):
    """Steps 1–4 of the RDA: the range-Doppler spectrum after RCMC and azimuth matched filtering.

    Parameters
    ----------
    rc : range-compressed ``PulseData``.
    speed : forward speed V used for focusing [m/s] (> 0).
    window : azimuth window (``sarnav.signal.windows.as_window`` spec), applied over the pulses.
    rcmc_kernel : one of :data:`RCMC_KERNELS`.
    azimuth_model : "parabolic" (paper eqs. 5, 11) or "hyperbolic" (exact zero-squint).
    fm_rate_scale : multiplies K_a of the matched filter (autofocus: K_amf = s K_a(V), eq. 16);
        RCMC keeps the speed's migration.
    azimuth_padding : azimuth FFT length >= ``azimuth_padding`` x P (zero-padded pulses, next fast
        length); 1 = the block's own length (circular, the sources' processing). Padding makes the
        azimuth correlation linear and samples the Doppler spectrum finely (needed for short,
        weak-chirp blocks such as the paper's K_a T^2 ~ 3); the spectrum then has that many rows.
    band_limit : pass only |f| <= band_limit K_amf(R0) T (T = block duration; 0 = no limit). With
        1 (default) that is the Doppler extent of any target inside the block (f = -K_a (eta - eta_c),
        eq. 8) and the filter is a chirp of duration 2T instead of PRF/K_a, which matters when PRF/K_a
        exceeds the FFT length (weak chirps); the noise outside the band is rejected. Weak chirps
        (K_a T^2 of a few) spread beyond K_a T (Fresnel): use a wider limit with more padding.
    apply_filter : False stops after RCMC (step 3); the filter is then
        ``apply_azimuth_filter(spec, info["filter_phase"] / s, R0, info["abs_freq"], s * info["fr_limit"])``.

    Returns
    -------
    spec : (P, N) complex, rows in FFT order of ``freqs``.
    freqs : (P,) Doppler frequency of each row [Hz].
    info : dict with wavelength, carrier_frequency, bandwidth, prf, window, rcmc_kernel,
        azimuth_model, filter_phase ((P,) matched-filter phase per metre of R0 at fm_rate_scale 1).
    """
    data, r = _check_inputs(rc) if _checked is None else _checked
    speed = float(speed)
    if not math.isfinite(speed) or speed <= 0:
        raise ConfigError("speed", f"must be finite and > 0 m/s, got {speed!r}")
    if rcmc_kernel not in RCMC_KERNELS:
        raise ConfigError("rcmc_kernel", f"must be one of {tuple(RCMC_KERNELS)}, got {rcmc_kernel!r}")
    if azimuth_model not in ("parabolic", "hyperbolic"):
        raise ConfigError("azimuth_model", f"must be 'parabolic' or 'hyperbolic', got {azimuth_model!r}")
    if not (math.isfinite(fm_rate_scale) and fm_rate_scale > 0):
        raise ConfigError("fm_rate_scale", f"must be finite and > 0, got {fm_rate_scale!r}")
    win = as_window(window, "window")
    consts = radar_constants(rc)
    lam = consts["wavelength"]
    prf = uniform_prf(rc.pulse_times)
    na = data.shape[0]
    cdtype = np.complex64 if data.dtype == np.complex64 else np.complex128
    x = data.astype(cdtype, copy=False)
    if win.name != "none":
        x = x * win.samples(na).astype(x.real.dtype)[:, None]
    if not (math.isfinite(azimuth_padding) and 1.0 <= azimuth_padding <= 64.0):
        raise ConfigError("azimuth_padding", f"must be in [1, 64], got {azimuth_padding!r}")
    nfft = na if azimuth_padding == 1.0 else sfft.next_fast_len(int(math.ceil(na * azimuth_padding)))
    spec = sfft.fft(x, n=nfft, axis=0)  # eq. (4)
    freqs = sfft.fftfreq(nfft, d=1.0 / prf)
    if azimuth_model == "parabolic":
        shift = lam**2 * freqs**2 / (8.0 * speed**2)      # eq. (5)/(9): dR / R0
        phase1 = -np.pi * lam * freqs**2 / (2.0 * speed**2)  # -pi f^2 / K_a (eq. 11), per metre of R0
    else:
        arg = 1.0 - (lam * freqs / (2.0 * speed)) ** 2
        if np.any(arg <= 0):
            raise InputDataError("rc.pulse_times", f"PRF {prf:g} Hz exceeds the maximum Doppler 4V/lambda "
                                 f"= {4 * speed / lam:g} Hz for the hyperbolic model")
        dfac = np.sqrt(arg)
        shift = 1.0 / dfac - 1.0
        phase1 = 4.0 * np.pi * (dfac - 1.0) / lam
    taps, beta = RCMC_KERNELS[rcmc_kernel]
    table = rcmc_kernel_table(max(taps, 2), beta if taps else 0.0)
    dr = float(r[-1] - r[0]) / (r.size - 1)
    phase = phase1 / fm_rate_scale if apply_filter else np.zeros_like(phase1)
    absf = np.abs(freqs)
    # |f| <= K_a(R0) T  <=>  |f| R0 <= 2 V^2 T / lambda   (K_a of eq. 7, times the autofocus scale)
    if not (math.isfinite(band_limit) and band_limit >= 0):
        raise ConfigError("band_limit", f"must be finite and >= 0 (0 = none), got {band_limit!r}")
    fr_limit = band_limit * 2.0 * speed**2 * na / prf / lam if band_limit > 0 else math.inf
    out = _rcmc_and_filter(np.ascontiguousarray(spec), shift.astype(np.float64), phase.astype(np.float64),
                           float(r[0]), dr, table, RCMC_TABLE_STEPS, taps > 0, absf,
                           fr_limit * fm_rate_scale if apply_filter else math.inf)
    info = {"wavelength": lam, "carrier_frequency": consts["carrier_frequency"], "bandwidth": consts["bandwidth"],
            "prf": prf, "window": win.label, "rcmc_kernel": rcmc_kernel, "azimuth_model": azimuth_model,
            "filter_phase": phase1, "abs_freq": absf, "fr_limit": fr_limit, "azimuth_padding": nfft / na,
            "band_limit": band_limit}
    return out, freqs, info


def range_doppler(rc: PulseData, speed: float | None = None, *, window=None, rcmc_kernel: str = "sinc8",
                  azimuth_model: str = "parabolic", along_track_origin=None,
                  fm_rate_scale: float = 1.0, azimuth_padding: float | None = None,
                  band_limit: float = 1.0) -> SarImage:
    """Focus range-compressed pulses with the Range-Doppler Algorithm (module docstring).

    Parameters
    ----------
    rc : range-compressed ``PulseData`` (``rc.positions`` label the image rows; pass an estimated
        trajectory with ``rc.with_positions``).
    speed : forward speed for K_a and RCMC [m/s]; default the slope of the straight-line fit of
        ``rc.positions`` (so an estimated trajectory forms the image).
    window : azimuth window, e.g. "none", "hamming", ("taylor", 4, -35); None (default) uses
        ``rc.azimuth_window`` when the pulses carry one, else "none".
    rcmc_kernel : "sinc8" (default), "sinc16" or "none".
    azimuth_model : "parabolic" (paper) or "hyperbolic" (exact).
    along_track_origin : (3,) origin of the along-track axis (default: first antenna position).
    fm_rate_scale : K_amf / K_a(V) (used by autofocus).
    azimuth_padding : zero-pad the azimuth FFT to this many times the pulses (see
        :func:`azimuth_compressed_spectrum`); the image keeps one row per pulse. None (default): 1
        (the sources' block processing) when K_a T^2 >= 32 at mid-swath, else 3 (linear compression:
        weak chirps, e.g. the paper's 1-s images at 10 m/s, K_a T^2 ~ 3).
    band_limit : limit the matched filter to |f| <= band_limit K_a T (see
        :func:`azimuth_compressed_spectrum`; 0 = no limit).

    Returns
    -------
    SarImage
        ``data`` (P, N) complex; ``y`` along-track [m] per pulse, ``x`` slant range of closest
        approach [m]; metadata: carrier_frequency, wavelength, bandwidth, prf, speed,
        closest_approach_range (mid-swath), aperture_length (V P / PRF), fm_rate (K_a at mid-swath),
        algorithm "rda", window, range_window, rcmc_kernel, azimuth_model, along_track_origin,
        along_track_direction, pulse_time0.
    """
    data, r = _check_inputs(rc)
    v = abs(along_track_axis(rc.positions, rc.pulse_times, along_track_origin)[3]) if speed is None else speed
    if window is None:
        window = rc.azimuth_window or "none"
    if azimuth_padding is None:
        t_block = data.shape[0] / uniform_prf(rc.pulse_times)
        k_mid = 2.0 * float(v) ** 2 / (radar_constants(rc)["wavelength"] * 0.5 * (r[0] + r[-1]))
        azimuth_padding = 1.0 if k_mid * t_block**2 >= 32.0 else 3.0
    spec, _, info = azimuth_compressed_spectrum(rc, v, window=window, rcmc_kernel=rcmc_kernel,
                                                azimuth_model=azimuth_model, fm_rate_scale=fm_rate_scale,
                                                azimuth_padding=azimuth_padding, band_limit=band_limit,
                                                _checked=(data, r))
    img = sfft.ifft(spec, axis=0, overwrite_x=True)[: data.shape[0]]  # eq. (13)
    return image_from_focused(rc, img, info, v, fm_rate_scale=fm_rate_scale, along_track_origin=along_track_origin)


def image_from_focused(rc: PulseData, img: np.ndarray, info: dict, speed: float, *, fm_rate_scale: float = 1.0,
                       along_track_origin=None) -> SarImage:
    """Wrap focused RDA data (after step 5) in a :class:`SarImage` with axes and metadata.

    ``info`` is the dict returned by :func:`azimuth_compressed_spectrum`.
    """
    r = np.asarray(rc.slant_range, dtype=np.float64)
    y, u, origin, _ = along_track_axis(rc.positions, rc.pulse_times, along_track_origin)
    rcmc_kernel, azimuth_model = info["rcmc_kernel"], info["azimuth_model"]
    v = float(speed)
    r_mid = float(0.5 * (r[0] + r[-1]))
    meta = {
        "algorithm": "rda",
        "carrier_frequency": info["carrier_frequency"],
        "wavelength": info["wavelength"],
        "bandwidth": info["bandwidth"],
        "prf": info["prf"],
        "speed": v,
        "closest_approach_range": r_mid,
        "aperture_length": v * img.shape[0] / info["prf"],
        "fm_rate": fm_rate_scale * 2.0 * v**2 / (info["wavelength"] * r_mid),
        "window": info["window"],
        "range_window": str(rc.metadata.get("range_window", rc.metadata.get("window", "unknown"))),
        "rcmc_kernel": rcmc_kernel,
        "azimuth_model": azimuth_model,
        "azimuth_padding": float(info.get("azimuth_padding", 1.0)),
        "band_limit": float(info.get("band_limit", 1.0)),
        "along_track_origin": [float(c) for c in origin],
        "along_track_direction": [float(c) for c in u],
        "pulse_time0": float(rc.pulse_times[0]),
    }
    return SarImage(data=img, y=y, x=r.copy(), y_name="along_track", x_name="slant_range", metadata=meta)
