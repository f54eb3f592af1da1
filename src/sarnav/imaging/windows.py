"""Spectral weighting windows for range / azimuth compression and their theoretical IRF figures.

A window weights the *spectrum* of a compressed response over the processed band. Four kinds:

* ``"none"``    rectangular (no weighting);
* ``"hamming"`` Hamming (0.54 + 0.46 cos);
* ``"taylor"``  Taylor, parameters ``nbar`` (number of nearly constant sidelobes, default 4) and
  ``sll_db`` (design sidelobe level, negative dB, default -35);
* ``"kaiser"``  Kaiser, parameter ``beta`` (default 2.5).

Samples come from :mod:`scipy.signal.windows`. Theoretical impulse-response figures are *derived
numerically* by :func:`irf_theory` (window of 256 taps, zero-padded x64, analysed with
:func:`sarnav.imaging.metrics.irf_from_fine_cut`, i.e. with the same mainlobe/sidelobe convention as
the measurements), and the published values are kept in :data:`PUBLISHED_IRF` for comparison.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from scipy.signal import windows as _sw

from sarnav.errors import ConfigError

WINDOW_NAMES = ("none", "hamming", "taylor", "kaiser")


@dataclass(frozen=True)
class Window:
    """A spectral weighting window.

    Parameters
    ----------
    name : one of ``"none"``, ``"hamming"``, ``"taylor"``, ``"kaiser"``.
    nbar : Taylor number of nearly constant sidelobes (integer >= 1).
    sll_db : Taylor design peak sidelobe level in dB, < 0 (e.g. -35).
    beta : Kaiser shape parameter, >= 0.
    """

    name: str = "none"
    nbar: int = 4
    sll_db: float = -35.0
    beta: float = 2.5

    def __post_init__(self):
        if self.name not in WINDOW_NAMES:
            raise ConfigError("window.name", f"must be one of {WINDOW_NAMES}, got {self.name!r}")
        if not isinstance(self.nbar, (int, np.integer)) or self.nbar < 1:
            raise ConfigError("window.nbar", f"must be an integer >= 1, got {self.nbar!r}")
        if not np.isfinite(self.sll_db) or not (-200.0 <= self.sll_db < 0.0):
            raise ConfigError("window.sll_db", f"must be in [-200, 0) dB, got {self.sll_db!r}")
        if not np.isfinite(self.beta) or self.beta < 0:
            raise ConfigError("window.beta", f"must be finite and >= 0, got {self.beta!r}")

    @property
    def label(self) -> str:
        """Short text label, e.g. ``"taylor(nbar=4,sll=-35)"``."""
        if self.name == "taylor":
            return f"taylor(nbar={self.nbar},sll={self.sll_db:g})"
        if self.name == "kaiser":
            return f"kaiser(beta={self.beta:g})"
        return self.name

    def samples(self, m: int) -> np.ndarray:
        """Symmetric window of ``m`` taps (float64), peak 1 for the tapered windows."""
        m = int(m)
        if m < 1:
            raise ConfigError("window.length", f"must be >= 1, got {m}")
        if self.name == "none":
            return np.ones(m)
        if self.name == "hamming":
            return _sw.hamming(m, sym=True)
        if self.name == "taylor":
            return _sw.taylor(m, nbar=int(self.nbar), sll=-float(self.sll_db), norm=True, sym=True)
        return _sw.kaiser(m, beta=float(self.beta), sym=True)


def as_window(spec, field: str = "window") -> Window:
    """Normalise a window specification.

    Accepts a :class:`Window`, a name (``"hamming"``), ``None`` (= ``"none"``), a dict of
    :class:`Window` fields, or a tuple ``("taylor", nbar, sll_db)`` / ``("kaiser", beta)``.
    Errors name ``field``.
    """
    try:
        if spec is None:
            return Window("none")
        if isinstance(spec, Window):
            return spec
        if isinstance(spec, str):
            return Window(spec.lower())
        if isinstance(spec, dict):
            return Window(**spec)
        if isinstance(spec, (tuple, list)) and spec:
            name = str(spec[0]).lower()
            if name == "taylor":
                return Window(name, *([int(spec[1])] if len(spec) > 1 else []),
                              **({"sll_db": float(spec[2])} if len(spec) > 2 else {}))
            if name == "kaiser":
                return Window(name, beta=float(spec[1])) if len(spec) > 1 else Window(name)
            if len(spec) == 1:
                return Window(name)
    except ConfigError as err:
        raise ConfigError(f"{field}.{err.field.split('.', 1)[-1]}", err.message) from None
    except TypeError as err:
        raise ConfigError(field, f"bad window specification {spec!r}: {err}") from None
    raise ConfigError(field, f"must be one of {WINDOW_NAMES}, a Window, a dict or a tuple, got {spec!r}")


def frequency_weights(window, freqs: np.ndarray, bandwidth: float) -> np.ndarray:
    """Window weights on an FFT frequency grid.

    The window's taps are laid, in increasing frequency, on the bins with ``|f| <= bandwidth/2``;
    bins outside the band get 0. ``"none"`` returns ones everywhere (plain matched filter).

    Parameters
    ----------
    window : window specification (see :func:`as_window`).
    freqs : (N,) frequencies of the FFT bins [Hz] (any order, e.g. ``scipy.fft.fftfreq``).
    bandwidth : processed bandwidth B [Hz].
    """
    w = as_window(window)
    freqs = np.asarray(freqs, dtype=np.float64)
    if w.name == "none":
        return np.ones(freqs.shape)
    in_band = np.flatnonzero(np.abs(freqs) <= 0.5 * bandwidth * (1 + 1e-12))
    order = in_band[np.argsort(freqs[in_band], kind="stable")]
    out = np.zeros(freqs.shape)
    out[order] = w.samples(order.size)
    return out


class IrfFigures(NamedTuple):
    """Impulse-response figures of a weighted uniform spectrum of width B.

    irw_factor : -3 dB width in units of 1/B: IRW = irw_factor / B in time, irw_factor * c/(2B) in
        slant range, irw_factor * V / B_a along track.
    pslr_db : peak sidelobe ratio [dB].
    islr_db : integrated sidelobe ratio [dB] (convention of :mod:`sarnav.imaging.metrics`).
    """

    irw_factor: float
    pslr_db: float
    islr_db: float


#: Published reference values for a uniform band (anchors-sar §3.1; Harris 1978 Table 1 for
#: Hamming; Cumming & Wong 2005 §2.6 for the rectangular case). ISLR with mainlobe to the first
#: nulls and 10 sidelobes each side (isce3 convention) where marked ``islr10``; ``islr_inf`` for
#: all sidelobes.
PUBLISHED_IRF = {
    "none": {"irw_factor": 0.886, "pslr_db": -13.26, "islr10_db": -10.11, "islr_inf_db": -9.68},
    "hamming": {"irw_factor": 1.30, "pslr_db": -42.7, "islr_inf_db": -34.4},
    "taylor(nbar=4,sll=-35)": {"irw_factor": 1.184, "pslr_db": -35.2, "islr_inf_db": -27.1},
    "taylor(nbar=5,sll=-40)": {"irw_factor": 1.246, "pslr_db": -40.1, "islr_inf_db": -31.4},
    "kaiser(beta=2.5)": {"irw_factor": 1.043, "pslr_db": -21.0, "islr_inf_db": -18.5},
}


def irf_theory(window, n_sidelobes: int | None = 10, taps: int = 256, oversample: int = 64) -> IrfFigures:
    """Theoretical IRW factor, PSLR and ISLR of a window applied to a uniform spectrum.

    Derived numerically: ``taps`` window samples across the band, zero-padded by ``oversample``,
    inverse FFT, and the power response analysed by
    :func:`sarnav.imaging.metrics.irf_from_fine_cut` with ``n_sidelobes`` (None = whole cut).
    For ``"none"`` this reproduces the closed forms 0.886/B and -13.26 dB.
    """
    w = as_window(window)
    return _irf_theory_cached(w, n_sidelobes, int(taps), int(oversample))


@lru_cache(maxsize=64)
def _irf_theory_cached(w: Window, n_sidelobes, taps: int, oversample: int) -> IrfFigures:
    from sarnav.imaging.metrics import irf_from_fine_cut

    n = taps * oversample
    spec = np.zeros(n, dtype=np.complex128)
    spec[:taps] = w.samples(taps)
    # centre the band on 0 Hz so the response is real and even around sample 0
    spec = np.roll(spec, -(taps // 2))
    resp = np.fft.fftshift(np.fft.ifft(spec))
    power = np.abs(resp) ** 2
    if n_sidelobes is None:
        # keep only a cut of +-taps/2 resolution cells (1/B = oversample samples) to avoid wrap-around
        c = n // 2
        half = (taps // 4) * oversample
        power = power[c - half: c + half + 1]
    ir = irf_from_fine_cut(power, spacing=1.0 / oversample, n_sidelobes=n_sidelobes)
    return IrfFigures(ir.irw, ir.pslr_db, ir.islr_db)
