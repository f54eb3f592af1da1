"""Spectral weighting windows for range / azimuth compression and their theoretical IRF figures.

A window weights the *spectrum* of a compressed response over the processed band. Four kinds:

* ``"none"``    rectangular (no weighting);
* ``"hamming"`` Hamming (0.54 + 0.46 cos);
* ``"taylor"``  Taylor, parameters ``nbar`` (number of nearly constant sidelobes, default 4) and
  ``sll_db`` (design sidelobe level, negative dB, default -35);
* ``"kaiser"``  Kaiser, parameter ``beta`` (default 2.5).

Samples come from :mod:`scipy.signal.windows`. The theoretical impulse-response figures of a window
(:func:`sarnav.signal.metrics.irf_theory`, published values :data:`sarnav.signal.metrics.PUBLISHED_IRF`)
live with the measurement conventions in :mod:`sarnav.signal.metrics`.
"""

from __future__ import annotations

from dataclasses import dataclass

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

    @classmethod
    def from_spec(cls, spec, field: str = "window") -> "Window":
        """Normalise a window specification.

        Accepts a :class:`Window`, a name (``"hamming"``), ``None`` (= ``"none"``), a dict of
        :class:`Window` fields, or a tuple ``("taylor", nbar, sll_db)`` / ``("kaiser", beta)``.
        Errors name ``field``.
        """
        try:
            if spec is None:
                return cls("none")
            if isinstance(spec, cls):
                return spec
            if isinstance(spec, str):
                return cls(spec.lower())
            if isinstance(spec, dict):
                return cls(**spec)
            if isinstance(spec, (tuple, list)) and spec:
                name = str(spec[0]).lower()
                if name == "taylor":
                    return cls(name, *([int(spec[1])] if len(spec) > 1 else []),
                               **({"sll_db": float(spec[2])} if len(spec) > 2 else {}))
                if name == "kaiser":
                    return cls(name, beta=float(spec[1])) if len(spec) > 1 else cls(name)
                if len(spec) == 1:
                    return cls(name)
        except ConfigError as err:  # named as the user wrote it: a table's key, a list's entry, a name itself
            sub = err.field.split(".", 1)[-1]
            if isinstance(spec, dict):
                where = f"{field}.{sub}"
            elif isinstance(spec, (tuple, list)):
                where = f"{field}[{_POSITION.get(sub, 0)}]"
            else:
                where = field
            raise ConfigError(where, err.message) from None
        except TypeError as err:
            raise ConfigError(field, f"bad window specification {spec!r}: {err}") from None
        raise ConfigError(field, f"must be one of {WINDOW_NAMES}, a Window, a dict or a tuple, got {spec!r}")


#: the entry of a ``(name, nbar, sll_db)`` / ``(name, beta)`` list that holds each Window field
_POSITION = {"name": 0, "nbar": 1, "sll_db": 2, "beta": 1}


#: :meth:`Window.from_spec` under the name the library and the docs use
as_window = Window.from_spec


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
