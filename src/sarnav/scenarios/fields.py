"""Typed reads of scenario values that raise :class:`ConfigError` naming the dotted field.

Shared by the kinds' ``parse`` functions (``telemetry``, ``rda-nav``).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError, require_finite, require_positive

__all__ = ["table", "get", "positive", "vector", "boolean", "bounded_positive", "POSITIVE_RANGE",
           "MIN_CORRELATION_TIME"]

#: the range of a positive physical quantity read from a scenario, in SI units (a noise 3-sigma, a correlation time,
#: a rate...): below 1e-6 a noise variance (<= 1e-13) is too small beside the others' for float64 (a 1e-12 m altimeter
#: 3-sigma made the innovation covariance singular), above 1e9 nothing the sources describe; kinds narrow it where
#: they know
POSITIVE_RANGE = (1e-6, 1e9)
#: the shortest correlation time of a first-order Gauss-Markov state (keys ``tau``, ``tau_*``) [s]: shorter ones make
#: the state white noise within a filter step (0.01-0.1 s), and the delayed-state mapping inverts exp(-span / tau)
#: over an aperture (1 s): at tau = 0.01 s that is e^100 (numpy's singular matrix); the sources use 300-3600 s
MIN_CORRELATION_TIME = 1.0


def _is_correlation_time(field: str) -> bool:
    last = field.rsplit(".", 1)[-1]
    return last == "tau" or last.startswith("tau_")


def bounded_positive(field: str, value, unit: str = "", lo: float | None = None, hi: float | None = None) -> float:
    """``value`` as a finite float in [lo, hi] (default :data:`POSITIVE_RANGE`; correlation times, keys ``tau`` and
    ``tau_*``, at least :data:`MIN_CORRELATION_TIME`), else ConfigError naming ``field``."""
    lo = (MIN_CORRELATION_TIME if _is_correlation_time(field) else POSITIVE_RANGE[0]) if lo is None else lo
    hi = POSITIVE_RANGE[1] if hi is None else hi
    v = require_positive(field, value, unit)
    if not lo <= v <= hi:
        raise ConfigError(field, f"must be in [{lo:g}, {hi:g}]{(' ' + unit) if unit else ''}, got {v!r}")
    return v


def table(cfg: dict, name: str) -> dict:
    """The ``[name]`` table of the scenario."""
    t = cfg.get(name)
    if not isinstance(t, dict):
        raise ConfigError(name, "missing table")
    return t


def get(cfg: dict, name: str, key: str):
    """The raw value ``name.key``."""
    t = table(cfg, name)
    if key not in t:
        raise ConfigError(f"{name}.{key}", "missing")
    return t[key]


def positive(cfg: dict, name: str, key: str, unit: str = "", lo: float | None = None, hi: float | None = None) -> float:
    """``name.key`` as a finite float in [lo, hi] (default :data:`POSITIVE_RANGE`)."""
    return bounded_positive(f"{name}.{key}", get(cfg, name, key), unit, lo, hi)


def vector(cfg: dict, name: str, key: str, n: int = 3, positive: bool = False, unit: str = "",
           lo: float | None = None, hi: float | None = None) -> np.ndarray:
    """``name.key`` as a list of ``n`` finite numbers (each in [lo, hi], default :data:`POSITIVE_RANGE`, when
    ``positive``)."""
    field = f"{name}.{key}"
    val = get(cfg, name, key)
    if not isinstance(val, (list, tuple)) or len(val) != n:
        raise ConfigError(field, f"must be a list of {n} numbers{(' [' + unit + ']') if unit else ''}, got {val!r}")
    if positive:
        return np.array([bounded_positive(f"{field}[{i}]", v, unit, lo, hi) for i, v in enumerate(val)])
    return np.array([require_finite(f"{field}[{i}]", v, unit=unit) for i, v in enumerate(val)])


def boolean(cfg: dict, name: str, key: str) -> bool:
    """``name.key`` as true or false (no numbers, no strings)."""
    v = get(cfg, name, key)
    if not isinstance(v, bool):
        raise ConfigError(f"{name}.{key}", f"must be true or false, got {v!r}")
    return v
