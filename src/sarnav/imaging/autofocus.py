"""Azimuth autofocus for the RDA: mapdrift (two-look misregistration) and contrast maximisation.

Both estimate the azimuth FM-rate error that a forward-speed error causes (K_a = 2V^2/(lambda R0),
paper eq. 7, so K_a / K_amf = (V / V_hat)^2 at every range) and refocus the image.

* :func:`mapdrift` — paper §2.2 eqs. 14–16, thesis §5.6.1 / App. D.2 (notes/seed-001 §2.2,
  notes/seed-000 §10.1). The azimuth-compressed spectrum (filter rate K_amf) is split into two
  disjoint halves of the processed Doppler band; each half is inverse-transformed into a look image.
  The look-to-look azimuth offset Delta_eta (sub-pixel registration of the look magnitudes,
  :func:`sarnav.imaging.registration.register`) gives, by eq. (14) inverted exactly,
  ``1/K_a = 1/K_amf - Delta_eta / Delta_f_a`` (eq. 15 is its first-order form
  ``Delta_K ~ -K_amf^2 Delta_eta / Delta_f_a``). Gap G12 choices: Delta_f_a is the measured difference
  of the two looks' energy-weighted Doppler centroids (equal to half the band for a target in the
  middle of the block, smaller for off-centre targets, so the estimate is iterated until the
  looks align; the fixed point Delta_eta = 0 is exactly K_amf = K_a); the correlation is on
  magnitude images, along azimuth only (1-D correlations summed over range bins,
  :func:`sarnav.imaging.registration.register_axis`: the looks are aligned in range). The refocused
  image uses the corrected filter rate (eq. 16).
* :func:`contrast_autofocus` — thesis App. D.2 (contrast maximisation) with the spacecraft source's
  normalised-variance sharpness (notes/seed-002 §2.9, eq. 3) as default metric: the image is formed
  for candidate speeds; a coarse scan over ±``search`` (relative) picks the best bracket, then
  ``scipy.optimize.minimize_scalar`` (bounded Brent) refines the maximum (instead of the sources'
  fixed-step hill climb, whose resolution equals its step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.fft as sfft
from scipy.optimize import minimize_scalar

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging import quality
from sarnav.signal.data import PulseData, SarImage
from sarnav.imaging.rda import (along_track_axis, apply_azimuth_filter, azimuth_compressed_spectrum,
                                image_from_focused, range_doppler)
from sarnav.imaging.registration import register_axis
from sarnav.signal.windows import as_window

__all__ = ["MapdriftResult", "ContrastResult", "mapdrift", "contrast_autofocus", "CONTRAST_METRICS"]

#: contrast / sharpness metrics (maximised)
CONTRAST_METRICS = {
    "normalised_variance": quality.normalised_variance,
    "intensity_contrast": quality.intensity_contrast,          # thesis (D.11)
    "std_to_mean_contrast": quality.std_to_mean_contrast,      # thesis (D.12)
    "kurtosis": quality.normalised_complex_kurtosis,           # Hathaway (3.5), normalised
}


@dataclass
class MapdriftResult:
    """Result of :func:`mapdrift`.

    Attributes
    ----------
    fm_rate_error : Delta_K = K_amf - K_a at mid-swath for the input speed [Hz/s] (paper eq. 15 sign).
    fm_rate_scale : estimated K_a / K_amf (= (V / V_hat)^2), range independent.
    speed : speed consistent with the estimated FM rate, V_hat * sqrt(fm_rate_scale) [m/s].
    image : refocused image (corrected filter, eq. 16).
    misregistration : look-to-look offset Delta_eta of each iteration [s] (last one ~ 0).
    look_separation : Delta_f_a of each iteration [Hz].
    iterations : number of look correlations performed.
    """

    fm_rate_error: float
    fm_rate_scale: float
    speed: float
    image: SarImage
    misregistration: list = field(default_factory=list)
    look_separation: list = field(default_factory=list)
    iterations: int = 0


@dataclass
class ContrastResult:
    """Result of :func:`contrast_autofocus`.

    Attributes
    ----------
    speed : speed maximising the metric [m/s].
    fm_rate_error : K_a(V_hat) - K_a(speed) at mid-swath [Hz/s] (same sign as mapdrift's).
    image : image formed with ``speed``.
    metric : metric value at ``speed``.
    evaluations : (speeds, values) of every image formed, in order.
    """

    speed: float
    fm_rate_error: float
    image: SarImage
    metric: float
    evaluations: tuple = ()


def _mid_fm_rate(rc: PulseData, speed: float, lam: float) -> float:
    r = np.asarray(rc.slant_range, dtype=np.float64)
    return 2.0 * speed**2 / (lam * 0.5 * (r[0] + r[-1]))


def _speed_and_padding(rc: PulseData, speed, origin, padding) -> tuple[float, float, float]:
    """(focusing speed: ``speed`` or the pulses' own along-track speed; azimuth padding: ``padding`` or
    :func:`_auto_padding`; the widest band-limit factor the padding allows without wrap: a filter chirp of 2 b T in a
    pad T FFT)."""
    if speed is None:
        speed = abs(along_track_axis(rc.positions, rc.pulse_times, origin)[3])
    speed = float(speed)
    if padding is None:
        padding = _auto_padding(rc, speed)
    return speed, padding, max(1.0, 0.5 * (padding - 1.0))


def _auto_padding(rc: PulseData, speed: float, bins: float = 32.0) -> float:
    """Azimuth zero-padding: >= 3 (the band-limited filter is a chirp of 2T: linear correlation of a
    T-long block needs 3T) and >= ``bins`` Doppler bins across K_a T (T = block duration)."""
    from sarnav.imaging.rda import radar_constants, uniform_prf

    t_block = rc.n_pulses / uniform_prf(rc.pulse_times)
    k = _mid_fm_rate(rc, speed, radar_constants(rc)["wavelength"])
    return float(min(64.0, max(3.0, bins / (k * t_block**2))))


def _rcmc_spectra(rc: PulseData, speed: float, looks: str, kw: dict):
    """Range-migration-corrected azimuth spectra of the looks: (spec_a, spec_b, spec0 = both, freqs, info, dt_looks);
    ``"subaperture"``: the first and second half of the pulses (dt_looks: the time between their centres);
    ``"doppler"``: spec_a = spec_b = None and spec0 of all pulses."""
    if looks != "subaperture":
        spec0, freqs, info = azimuth_compressed_spectrum(rc, speed, **kw)
        return None, None, spec0, freqs, info, None
    n = rc.n_pulses
    half = n // 2
    first = np.zeros(n, dtype=bool)
    first[:half] = True
    parts = [replace(rc, data=np.where(m[:, None], rc.data, 0)) for m in (first, ~first)]
    spec_a, freqs, info = azimuth_compressed_spectrum(parts[0], speed, **kw)
    spec_b, _, _ = azimuth_compressed_spectrum(parts[1], speed, **kw)
    dt_looks = (0.5 * (n + half) - 0.5 * half) / info["prf"]  # centre of pulses [half, n) minus [0, half)
    return spec_a, spec_b, spec_a + spec_b, freqs, info, dt_looks


def _doppler_looks(spec, freqs, prf: float, k_mf: float, n: int, look_bandwidth):
    """The paper's two looks: disjoint halves of the processed Doppler band of the compressed spectrum, and
    Delta_f_a, the difference of their energy centroids [Hz]."""
    band = min(prf, k_mf * n / prf) if look_bandwidth is None else float(look_bandwidth)
    if not (math.isfinite(band) and 0 < band <= prf):
        raise ConfigError("look_bandwidth", f"must be in (0, PRF = {prf:g}] Hz, got {band!r}")
    lo = (freqs >= -band / 2) & (freqs < 0)
    hi = (freqs >= 0) & (freqs <= band / 2)
    power = np.sum(np.abs(spec) ** 2, axis=1)
    d_f = float(np.sum(freqs[hi] * power[hi]) / np.sum(power[hi])
                - np.sum(freqs[lo] * power[lo]) / np.sum(power[lo]))
    return sfft.ifft(spec * lo[:, None], axis=0), sfft.ifft(spec * hi[:, None], axis=0), d_f


def mapdrift(rc: PulseData, speed: float | None = None, *, looks: str = "subaperture", max_iterations: int = 4,
             tolerance_px: float = 0.02, look_bandwidth: float | None = None, rcmc_kernel: str = "sinc8",
             azimuth_model: str = "parabolic", window=None, along_track_origin=None, upsample: int = 100,
             azimuth_padding: float | None = None) -> MapdriftResult:
    """Mapdrift autofocus of range-compressed pulses (paper eqs. 14–16, module docstring).

    Parameters
    ----------
    rc : range-compressed ``PulseData``.
    speed : forward speed estimate V_hat that sets K_amf and RCMC [m/s]; default from ``rc.positions``.
    looks : how the two looks are made (gap G12):

        * ``"subaperture"`` (default): the first and second half of the pulses, each compressed with
          K_amf. A target seen by the whole block has Doppler centroid -K_a (t_i - eta_c) in
          sub-aperture i (eq. 8), so Delta_f_a = -K_a Delta_t for every target and eq. (14) becomes
          ``Delta_eta = Delta_t (1 - K_a / K_amf)``, solved exactly for K_a. Unbiased for any
          time-bandwidth product and any target position in the block.
        * ``"doppler"``: the paper's literal form: two disjoint halves of the processed Doppler band
          of the compressed spectrum; Delta_f_a is the measured difference of the looks' energy
          centroids, ``1/K_a = 1/K_amf - Delta_eta / Delta_f_a``. Biased where the compressed
          spectrum is not flat (Fresnel edges; weak chirps K_a T^2 of a few, as in the paper's
          1-s, 10 m/s images, where it fails), hence not the default.
    max_iterations : at most this many look correlations (>= 1); 1 = the paper's single pass.
    tolerance_px : stop once the look offset is below this many azimuth samples (> 0).
    look_bandwidth : ``"doppler"`` looks only: processed Doppler band split into the two looks [Hz];
        default min(PRF, K_amf T) at mid-swath (T = block duration).
    rcmc_kernel, azimuth_model, window, along_track_origin : as in :func:`~sarnav.imaging.rda.range_doppler`
        (the looks are formed without window; ``window`` applies to the returned image).
    upsample : sub-pixel factor of the look registration.
    azimuth_padding : azimuth FFT zero-padding factor (``range_doppler``); default
        max(3, 32 / (K_amf T^2)): linear (not circular) compression of the band-limited filter and
        >= 32 Doppler bins across K_amf T.

    Returns
    -------
    MapdriftResult
    """
    if looks not in ("subaperture", "doppler"):
        raise ConfigError("looks", f"must be 'subaperture' or 'doppler', got {looks!r}")
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)) or max_iterations < 1:
        raise ConfigError("max_iterations", f"must be an integer >= 1, got {max_iterations!r}")
    if not (math.isfinite(tolerance_px) and tolerance_px > 0):
        raise ConfigError("tolerance_px", f"must be finite and > 0 samples, got {tolerance_px!r}")
    speed, azimuth_padding, blim = _speed_and_padding(rc, speed, along_track_origin, azimuth_padding)
    n = rc.n_pulses
    kw = dict(rcmc_kernel=rcmc_kernel, azimuth_model=azimuth_model, apply_filter=False, azimuth_padding=azimuth_padding,
              band_limit=blim)
    # RCMC once (it depends on V_hat only, and is linear); the matched filter is re-applied per iteration
    spec_a, spec_b, spec0, freqs, info, dt_looks = _rcmc_spectra(rc, speed, looks, kw)
    prf, lam = info["prf"], info["wavelength"]
    r = np.asarray(rc.slant_range, dtype=np.float64)
    k0 = _mid_fm_rate(rc, speed, lam)

    def compressed(spec, s):  # eqs. (11)-(12) with K_amf = s K_a: spec * exp(1j * outer(filter_phase / s, R0))
        return apply_azimuth_filter(spec, info["filter_phase"] / s, r, info["abs_freq"], s * info["fr_limit"])

    scale = 1.0
    dets, dfs = [], []
    it = 0
    for it in range(1, int(max_iterations) + 1):
        k_mf = scale * k0
        if looks == "subaperture":
            look1 = sfft.ifft(compressed(spec_a, scale), axis=0)
            look2 = sfft.ifft(compressed(spec_b, scale), axis=0)
            d_f = -k_mf * dt_looks                 # nominal Delta_f_a (reported only)
        else:
            look1, look2, d_f = _doppler_looks(compressed(spec0, scale), freqs, prf, k_mf, n, look_bandwidth)
        shift, _ = register_axis(look1, look2, axis=0, use_magnitude=True, upsample=upsample, circular=True)
        d_eta = shift / prf                        # eta_2 - eta_1 [s]
        dets.append(d_eta)
        dfs.append(d_f)
        if looks == "subaperture":
            k_a = k_mf * (1.0 - d_eta / dt_looks)  # eq. (14) with Delta_f_a = -K_a Delta_t
        else:
            k_a = 1.0 / (1.0 / k_mf - d_eta / d_f)  # eq. (14) inverted exactly
        if not (math.isfinite(k_a) and k_a > 0):
            raise InputDataError("rc", f"mapdrift diverged (look offset {d_eta:g} s); is there a focusable scene?")
        scale = scale * k_a / k_mf
        if abs(shift) < tolerance_px:
            break
    if window is None:
        window = rc.azimuth_window or "none"
    if as_window(window, "window").name == "none":  # eq. (16): corrected filter on the same spectrum
        img = image_from_focused(rc, sfft.ifft(compressed(spec0, scale), axis=0)[:n], info, speed,
                                 fm_rate_scale=scale, along_track_origin=along_track_origin)
    else:
        img = range_doppler(rc, speed, window=window, rcmc_kernel=rcmc_kernel, azimuth_model=azimuth_model,
                            along_track_origin=along_track_origin, fm_rate_scale=scale, azimuth_padding=azimuth_padding,
                            band_limit=blim)
    img.metadata["autofocus"] = f"mapdrift({looks})"
    img.metadata["fm_rate_scale"] = scale
    return MapdriftResult(fm_rate_error=k0 * (1.0 - scale), fm_rate_scale=scale, speed=speed * math.sqrt(scale),
                          image=img, misregistration=dets, look_separation=dfs, iterations=it)


def contrast_autofocus(rc: PulseData, speed: float | None = None, *, metric: str = "normalised_variance",
                       search: float = 0.1, grid: int = 11, xtol: float = 1e-4, rcmc_kernel: str = "sinc8",
                       azimuth_model: str = "parabolic", window=None, along_track_origin=None,
                       azimuth_padding: float | None = None) -> ContrastResult:
    """Contrast-maximisation autofocus over the forward speed (thesis App. D.2; spacecraft eq. 3).

    Parameters
    ----------
    rc : range-compressed ``PulseData``.
    speed : initial speed estimate V_hat [m/s]; default from ``rc.positions``.
    metric : one of :data:`CONTRAST_METRICS` (maximised).
    search : half-width of the relative speed interval searched, V_hat (1 ± search), in (0, 0.5].
    grid : points of the coarse scan (>= 3, odd keeps V_hat on the grid).
    xtol : relative tolerance of the Brent refinement on the speed (> 0).
    rcmc_kernel, azimuth_model, window, along_track_origin : as in ``range_doppler``.
    azimuth_padding : as in :func:`mapdrift` (default: automatic, >= 32 Doppler bins over K_a T).

    Returns
    -------
    ContrastResult
    """
    if metric not in CONTRAST_METRICS:
        raise ConfigError("metric", f"must be one of {tuple(CONTRAST_METRICS)}, got {metric!r}")
    if not (math.isfinite(search) and 0 < search <= 0.5):
        raise ConfigError("search", f"must be in (0, 0.5], got {search!r}")
    if isinstance(grid, bool) or not isinstance(grid, (int, np.integer)) or grid < 3:
        raise ConfigError("grid", f"must be an integer >= 3, got {grid!r}")
    if not (math.isfinite(xtol) and xtol > 0):
        raise ConfigError("xtol", f"must be finite and > 0, got {xtol!r}")
    v0, azimuth_padding, blim = _speed_and_padding(rc, speed, along_track_origin, azimuth_padding)
    score = CONTRAST_METRICS[metric]
    seen_v, seen_s = [], []

    def form(v):
        return range_doppler(rc, v, window=window, rcmc_kernel=rcmc_kernel, azimuth_model=azimuth_model,
                             along_track_origin=along_track_origin, azimuth_padding=azimuth_padding,
                             band_limit=blim * (v0 / v) ** 2)  # same absolute Doppler band for all v

    def neg(v):
        s = score(form(v).data)
        seen_v.append(float(v))
        seen_s.append(float(s))
        return -s

    vs = v0 * (1.0 + np.linspace(-search, search, int(grid)))
    vals = [-neg(v) for v in vs]
    i = int(np.argmax(vals))
    lo, hi = vs[max(i - 1, 0)], vs[min(i + 1, len(vs) - 1)]
    res = minimize_scalar(neg, bounds=(lo, hi), method="bounded", options={"xatol": xtol * v0})
    best = float(res.x) if -res.fun >= vals[i] else float(vs[i])
    img = form(best)
    img.metadata["autofocus"] = f"contrast({metric})"
    lam = img.metadata["wavelength"]
    return ContrastResult(speed=best, fm_rate_error=_mid_fm_rate(rc, v0, lam) - _mid_fm_rate(rc, best, lam),
                          image=img, metric=float(score(img.data)), evaluations=(seen_v, seen_s))
