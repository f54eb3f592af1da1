"""Radar description: :class:`RadarParams` (frozen, SI) and its validation.

Signal model (architecture §3, Cumming & Wong 2005 eq. 4.38, stop-and-hop): the complex baseband
echo of a point of amplitude A at slant range R is

    s(t) = A G(theta) rect((t - tau)/T) exp(-j 4 pi f_c R / c) exp(j pi K (t - tau)^2),  tau = 2R/c,

with the chirp *centred* on tau (instantaneous frequency -B/2 .. +B/2 around f_c). Fast time t is
measured from the transmit instant of the pulse centre; the receive window samples
t_i = 2 near_range / c + i / fs, i = 0 .. n_range_samples-1, i.e. slant ranges
near_range + i c / (2 fs).

The radar's three clocks and checks live here, one formula each: :func:`pulse_clock` (slow time of
the pulses, :meth:`RadarParams.pulse_times`), :meth:`RadarParams.window_over` (the receive window over a
span of slant ranges, :meth:`RadarParams.receive_window`) and :meth:`RadarParams.check_doppler` (the PRF
against the beam's Doppler bandwidth). Errors name the radar's own parameters (``prf``,
``near_range``, ...); the scenario layer names them as the user's keys.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, asdict, dataclass, field, fields

import numpy as np

from sarnav.errors import ConfigError, require_positive
from sarnav.signal.windows import Window, as_window
from sarnav.units import C

LOOK_SIDES = ("left", "right")
#: one-way -3 dB beamwidth of a uniformly illuminated aperture of length L: 0.886 lambda / L
BEAMWIDTH_FACTOR = 0.886


def pulse_clock(n: int, prf: float, t0: float = 0.0, ref_pulse: float = 0) -> np.ndarray:
    """(n,) slow times ``t0 + (k - ref_pulse) / prf``, k = 0 .. n-1, of pulses at a constant PRF [s].

    ``ref_pulse`` is the index of the pulse sent at ``t0``: 0 (default) the first, ``n // 2`` the
    middle pulse, ``(n - 1) / 2`` a clock symmetric about ``t0`` (fractional), ``n - 1`` the last.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ConfigError("n", f"must be an integer >= 0 (number of pulses), got {n!r}")
    prf = require_positive("prf", prf, "Hz")
    if not (math.isfinite(t0) and math.isfinite(ref_pulse)):
        raise ConfigError("t0", f"t0 and ref_pulse must be finite, got {t0!r}, {ref_pulse!r}")
    return t0 + (np.arange(int(n)) - ref_pulse) / prf


@dataclass(frozen=True)
class RadarParams:
    """Pulsed LFM radar with complex baseband sampling (all SI).

    Parameters
    ----------
    carrier_frequency : centre (carrier) frequency f_c [Hz] (paper gap G8: 9.75 GHz is the centre).
    bandwidth : chirp bandwidth B = K T [Hz].
    pulse_length : chirp duration T [s].
    sample_rate : complex sampling rate fs [Hz], >= B.
    prf : pulse repetition frequency [Hz].
    near_range : slant range of the first fast-time sample [m].
    n_range_samples : number of fast-time samples in the receive window.
    antenna_length : azimuth antenna length L [m]; one-way -3 dB beamwidth 0.886 lambda / L.
    azimuth_beamwidth : alternatively the one-way -3 dB azimuth beamwidth [rad]; give exactly one
        of ``antenna_length`` and ``azimuth_beamwidth``.
    look_side : "left" or "right" of the velocity vector.
    range_window, azimuth_window : spectral weighting (name, tuple, dict or
        :class:`~sarnav.signal.windows.Window`; normalised to a ``Window``).

    Raises
    ------
    ConfigError
        at construction for values that are bad on their own (non-positive, NaN, fs < B, pulse
        longer than the receive window, unknown look side or window); :meth:`validate` adds the
        checks that need the platform speed and the scene.
    """

    carrier_frequency: float
    bandwidth: float
    pulse_length: float
    sample_rate: float
    prf: float
    near_range: float
    n_range_samples: int
    antenna_length: float | None = None
    azimuth_beamwidth: float | None = None
    look_side: str = "right"
    range_window: Window = field(default_factory=Window)
    azimuth_window: Window = field(default_factory=Window)

    def __post_init__(self):
        for name in ("carrier_frequency", "bandwidth", "pulse_length", "sample_rate", "prf"):
            object.__setattr__(self, name, require_positive(name, getattr(self, name)))
        if self.bandwidth >= 2.0 * self.carrier_frequency:
            raise ConfigError("bandwidth", f"must be < 2 x carrier_frequency = {2.0 * self.carrier_frequency:g} Hz "
                              f"(lowest transmitted frequency f_c - B/2 > 0), got {self.bandwidth:g} Hz")
        if self.pulse_length >= 1.0 / self.prf:
            raise ConfigError("pulse_length", f"must be shorter than the pulse repetition interval 1/prf = "
                              f"{1.0 / self.prf:g} s, got {self.pulse_length:g} s")
        object.__setattr__(self, "near_range", require_positive("near_range", self.near_range))
        n = self.n_range_samples
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ConfigError("n_range_samples", f"must be an integer >= 2, got {n!r}")
        object.__setattr__(self, "n_range_samples", int(n))
        if (self.antenna_length is None) == (self.azimuth_beamwidth is None):
            raise ConfigError("antenna_length",
                              "give exactly one of antenna_length [m] and azimuth_beamwidth [rad]")
        if self.antenna_length is not None:
            L = require_positive("antenna_length", self.antenna_length, "m")
            l_min = BEAMWIDTH_FACTOR * (C / self.carrier_frequency) / math.pi
            if L <= l_min:
                raise ConfigError("antenna_length", f"must be > 0.886 lambda / pi = {l_min:.4g} m "
                                  f"(-3 dB beamwidth below pi rad), got {L!r} m")
            object.__setattr__(self, "antenna_length", L)
        else:
            bw = require_positive("azimuth_beamwidth", self.azimuth_beamwidth, "rad")
            if bw >= math.pi:
                raise ConfigError("azimuth_beamwidth", f"must be in (0, pi) rad, got {bw!r}")
            object.__setattr__(self, "azimuth_beamwidth", bw)
        if self.look_side not in LOOK_SIDES:
            raise ConfigError("look_side", f"must be one of {LOOK_SIDES}, got {self.look_side!r}")
        object.__setattr__(self, "range_window", as_window(self.range_window, "range_window"))
        object.__setattr__(self, "azimuth_window", as_window(self.azimuth_window, "azimuth_window"))
        # complex sampling: fs >= B (equality allowed, FlexSAR oversample 1)
        if self.sample_rate < self.bandwidth * (1 - 1e-12):
            raise ConfigError("sample_rate",
                              f"must be >= bandwidth {self.bandwidth:g} Hz (complex Nyquist), got {self.sample_rate:g} Hz")
        if self.pulse_length >= self.window_duration:
            raise ConfigError("pulse_length",
                              f"must be shorter than the receive window {self.window_duration:g} s "
                              f"(n_range_samples / sample_rate), got {self.pulse_length:g} s")

    # ---- (de)serialisation --------------------------------------------------------------------
    def to_dict(self) -> dict:
        """JSON/TOML-serialisable dict of the fields (windows as dicts; absent optional fields omitted)."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None:
                continue
            out[f.name] = asdict(v) if isinstance(v, Window) else v
        return out

    @classmethod
    def from_dict(cls, d: dict, prefix: str = "radar") -> "RadarParams":
        """Build from a dict such as a scenario's ``[radar]`` table; unknown keys raise ConfigError."""
        if not isinstance(d, dict):
            raise ConfigError(prefix, f"must be a table of radar parameters, got {type(d).__name__}")
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ConfigError(f"{prefix}.{unknown[0]}", f"unknown radar parameter; valid: {sorted(names)}")
        missing = sorted(n for n in names - set(d) if _FIELDS[n].default is MISSING
                         and _FIELDS[n].default_factory is MISSING)
        if missing:
            raise ConfigError(f"{prefix}.{missing[0]}", "missing required radar parameter")
        try:
            return cls(**d)
        except ConfigError as err:  # named as in the table: ``radar.prf``, ``radar.azimuth_window[2]``
            raise ConfigError(f"{prefix}.{err.field}", err.message) from None

    # ---- derived quantities -------------------------------------------------------------------
    @property
    def wavelength(self) -> float:
        """lambda = c / f_c [m]."""
        return C / self.carrier_frequency

    @property
    def chirp_rate(self) -> float:
        """K = B / T [Hz/s] (thesis (2.1))."""
        return self.bandwidth / self.pulse_length

    @property
    def range_resolution(self) -> float:
        """Unweighted slant-range IRW 0.886 c / (2B) [m] (thesis (2.2) with the sinc -3 dB factor)."""
        return BEAMWIDTH_FACTOR * C / (2.0 * self.bandwidth)

    @property
    def range_bin_spacing(self) -> float:
        """c / (2 fs) [m]."""
        return C / (2.0 * self.sample_rate)

    @property
    def slant_range_axis(self) -> np.ndarray:
        """(n_range_samples,) near_range + i c / (2 fs) [m], float64."""
        return self.near_range + np.arange(self.n_range_samples, dtype=np.float64) * self.range_bin_spacing

    @property
    def far_range(self) -> float:
        """Slant range of the last fast-time sample [m]."""
        return self.near_range + (self.n_range_samples - 1) * self.range_bin_spacing

    @property
    def window_duration(self) -> float:
        """Receive window length n_range_samples / fs [s]."""
        return self.n_range_samples / self.sample_rate

    @property
    def pulse_half_extent(self) -> float:
        """Half the pulse's extent in slant range, c T / 4 [m] (the chirp is centred on tau = 2R/c)."""
        return C * self.pulse_length / 4.0

    @property
    def target_range_limits(self) -> tuple[float, float]:
        """(min, max) slant range of a target whose whole echo lies in the receive window [m]."""
        return self.near_range + self.pulse_half_extent, self.far_range - self.pulse_half_extent

    @property
    def beamwidth(self) -> float:
        """One-way -3 dB azimuth beamwidth [rad]: 0.886 lambda / L, or ``azimuth_beamwidth``."""
        if self.azimuth_beamwidth is not None:
            return self.azimuth_beamwidth
        return BEAMWIDTH_FACTOR * self.wavelength / self.antenna_length

    @property
    def effective_antenna_length(self) -> float:
        """Antenna length giving ``beamwidth``: L = 0.886 lambda / theta_bw [m]."""
        if self.antenna_length is not None:
            return self.antenna_length
        return BEAMWIDTH_FACTOR * self.wavelength / self.azimuth_beamwidth

    def doppler_bandwidth(self, speed: float, squint: float = 0.0) -> float:
        """Doppler bandwidth of the -3 dB azimuth beam [Hz].

        B_D = (2V/lambda) [sin(theta_sq + theta_bw/2) - sin(theta_sq - theta_bw/2)]
            = (4V/lambda) cos(theta_sq) sin(theta_bw/2)  ~=  0.886 * 2V/L * cos(theta_sq)

        (Cumming & Wong 2005 eq. 4.36 with the -3 dB beamwidth 0.886 lambda/L). The simulator
        uses zero squint.
        """
        v = require_positive("speed", speed, "m/s")
        return 4.0 * v / self.wavelength * math.cos(squint) * math.sin(0.5 * self.beamwidth)

    def check_doppler(self, speed: float, squint: float = 0.0) -> "RadarParams":
        """Azimuth Nyquist: raise ``ConfigError("prf", ...)`` unless ``prf >= doppler_bandwidth(speed, squint)``.

        A scatterer seen at angle theta off broadside has the Doppler f = 2V sin(theta) / lambda; the
        -3 dB beam spans theta_sq -+ theta_bw/2, so its echoes occupy
        B_D = (2V/lambda) [sin(theta_sq + theta_bw/2) - sin(theta_sq - theta_bw/2)]
            = (4V/lambda) cos(theta_sq) sin(theta_bw/2)  ~=  0.886 * 2V/L  (theta_bw = 0.886 lambda/L, small)
        (Cumming & Wong 2005 eq. 4.36; docs/radar.md). Complex slow-time samples at the PRF are
        unambiguous over a band of width PRF, so the PRF must be >= B_D; the boundary prf = B_D is
        accepted. Returns self.
        """
        if not math.isfinite(squint) or abs(squint) >= 0.5 * math.pi:
            raise ConfigError("squint", f"must be in (-pi/2, pi/2) rad, got {squint!r}")
        bd = self.doppler_bandwidth(speed, squint)
        if self.prf < bd:
            raise ConfigError(
                "prf",
                f"must be >= the Doppler bandwidth (4V/lambda) cos(squint) sin(beamwidth/2) = {bd:.6g} Hz "
                f"at speed {float(speed):g} m/s "
                f"(beamwidth {self.beamwidth:.4g} rad), got {self.prf:g} Hz",
            )
        return self

    # ---- clocks and windows -------------------------------------------------------------------
    def pulse_times(self, n: int, t0: float = 0.0, ref_pulse: float = 0) -> np.ndarray:
        """(n,) slow times of n pulses at this PRF, pulse ``ref_pulse`` at ``t0`` [s] (:func:`pulse_clock`)."""
        return pulse_clock(n, self.prf, t0, ref_pulse)

    @staticmethod
    def window_over(span, pulse_length: float, sample_rate: float, margin: float = 0.0,
                    margin_key: str = "margin") -> dict:
        """``near_range`` and ``n_range_samples`` of a receive window over the slant ranges ``span``.

        The window runs from ``span[0] - pad`` with ``pad = c T / 4 + margin`` (T the pulse length: a
        scatterer at R has its centred chirp on ``[R - cT/4, R + cT/4]`` in slant range, so every
        scatterer of the span has its whole chirp inside) for ``ceil((span[1] - span[0] + 2 pad) / dr)
        + 1`` samples of ``dr = c / (2 fs)``: the last sample lies at or beyond ``span[1] + pad``.
        ``pulse_length`` 0 pads by ``margin`` alone. A margin that alone pushes the window's start to or
        below 0 m is refused naming ``margin_key`` (the caller's configuration key) and its bound.
        """
        lo, hi = span
        if not (math.isfinite(lo) and math.isfinite(hi) and hi >= lo):
            raise ConfigError("span", f"must be two finite slant ranges [m] with span[0] <= span[1], got {span!r}")
        if pulse_length != 0:  # 0: no padding for the chirp; otherwise RadarParams' own check and message
            require_positive("pulse_length", pulse_length)
        fs = require_positive("sample_rate", sample_rate)
        if not (math.isfinite(margin) and margin >= 0):
            raise ConfigError("margin", f"must be finite and >= 0 m, got {margin!r}")
        pad = C * pulse_length / 4.0 + margin
        if lo - pad <= 0.0 < lo - pad + margin:  # the margin's fault: name it, not the derived near_range
            raise ConfigError(margin_key, f"must be < {lo - pad + margin:.6g} m (the nearest imaged slant range less "
                              f"the pulse half-extent): the receive window would start at {lo - pad:.6g} m, got "
                              f"{margin!r}")
        dr = C / (2.0 * fs)
        return {"near_range": lo - pad, "n_range_samples": int(math.ceil((hi - lo + 2 * pad) / dr)) + 1}

    def receive_window(self, span, margin: float = 0.0) -> dict:
        """``{"near_range", "n_range_samples"}`` of a window over the slant ranges ``span`` [m] with this
        pulse length and sample rate, widened by ``margin`` [m] each side (:func:`window_over`);
        ``dataclasses.replace(params, **params.receive_window(span))`` is the radar recording it."""
        return window_over(span, self.pulse_length, self.sample_rate, margin)

    def pulse_data_fields(self) -> dict:
        """The :class:`~sarnav.signal.data.PulseData` fields this radar fills: wavelength, bandwidth,
        sample_rate, pulse_length and the range / azimuth windows."""
        return {"wavelength": self.wavelength, "bandwidth": self.bandwidth, "sample_rate": self.sample_rate,
                "pulse_length": self.pulse_length, "range_window": self.range_window,
                "azimuth_window": self.azimuth_window}

    # ---- validation ---------------------------------------------------------------------------
    def validate(self, speed: float | None = None, scene_ranges=None, squint: float = 0.0) -> "RadarParams":
        """Check the parameters against a platform speed and a scene; return self.

        Parameters
        ----------
        speed : platform speed [m/s]; checks ``prf >= doppler_bandwidth(speed)`` (azimuth Nyquist
            for the -3 dB beam, complex sampling: :meth:`check_doppler`).
        scene_ranges : array of target slant ranges [m] (any shape, e.g. over all pulses); each
            must satisfy ``near_range + cT/4 <= R <= far_range - cT/4`` so that the whole chirp
            lies in the receive window.
        squint : beam squint [rad] for the Doppler bandwidth (the simulator uses 0).

        Raises
        ------
        ConfigError naming the field and the bound.
        """
        # construction-time checks already ran in __post_init__ (also on dataclasses.replace)
        if speed is not None:
            self.check_doppler(speed, squint)
        if scene_ranges is not None:
            r = np.asarray(scene_ranges, dtype=np.float64)
            if r.size:
                if not np.all(np.isfinite(r)):
                    raise ConfigError("scene", "target slant ranges contain NaN or inf")
                lo, hi = self.target_range_limits
                rmin, rmax = float(r.min()), float(r.max())
                if rmin < lo or rmax > hi:
                    raise ConfigError(
                        "near_range",
                        f"receive window {self.near_range:.3f}-{self.far_range:.3f} m holds whole echoes "
                        f"only for targets in [{lo:.3f}, {hi:.3f}] m (pulse half-extent cT/4 = "
                        f"{self.pulse_half_extent:.3f} m); scene spans [{rmin:.3f}, {rmax:.3f}] m",
                    )
        return self


#: :meth:`RadarParams.window_over` under the name the presets and the docs use
window_over = RadarParams.window_over


_FIELDS = {f.name: f for f in fields(RadarParams)}
