"""Typed reads of scenario values that raise :class:`ConfigError` naming the dotted field and the valid range.

The one reader family of every kind's ``parse``: a kind declares which keys it reads and their ranges
(``number(cfg, "scene", "width", 0.5, 1000.0, "m")``); the reading, the type check and the one-line error are here.
Readers of a table key take ``(cfg, table, key, ...)``; the ``*_value`` forms check a value already in hand (a list
entry) under a given field name.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError, require_finite, require_positive

__all__ = ["table", "get", "positive", "vector", "boolean", "bounded_positive", "POSITIVE_RANGE",
           "MIN_CORRELATION_TIME", "number", "integer", "integer_value", "choice", "bounded_vector", "number_list",
           "int_list", "name_list", "known_keys"]

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
    try:
        v = require_positive(field, value, unit)
    except ConfigError as err:  # zero, negative, NaN or not a number: say the valid range too
        raise ConfigError(field, f"{err.message}; valid range [{lo:g}, {hi:g}]{(' ' + unit) if unit else ''}") from None
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


def number(cfg: dict, name: str, key: str, lo: float | None = None, hi: float | None = None, unit: str = "") -> float:
    """``name.key`` as a finite number in [lo, hi] (either bound may be None: open)."""
    return require_finite(f"{name}.{key}", get(cfg, name, key), lo, hi, unit)


def integer_value(field: str, value, lo: int, hi: int, note: str = "") -> int:
    """``value`` as an integer in [lo, hi] (no booleans, no floats), else ConfigError naming ``field`` (``note``
    follows the range in the message, e.g. ``" (0: every update)"``)."""
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ConfigError(field, f"must be an integer in [{lo}, {hi}]{note}, got {value!r}")
    return int(value)


def integer(cfg: dict, name: str, key: str, lo: int, hi: int, note: str = "") -> int:
    """``name.key`` as an integer in [lo, hi] (:func:`integer_value`)."""
    return integer_value(f"{name}.{key}", get(cfg, name, key), lo, hi, note)


def choice(cfg: dict, name: str, key: str, options) -> str:
    """``name.key`` as one of ``options``."""
    v = get(cfg, name, key)
    if v not in options:
        raise ConfigError(f"{name}.{key}", f"must be one of {list(options)}, got {v!r}")
    return v


def bounded_vector(cfg: dict, name: str, key: str, lo: float, hi: float, n: int = 3, unit: str = "") -> tuple:
    """``name.key`` as a list of ``n`` finite numbers, each in [lo, hi]."""
    v = vector(cfg, name, key, n=n, unit=unit)
    return tuple(require_finite(f"{name}.{key}[{i}]", x, lo, hi, unit) for i, x in enumerate(v))


def number_list(cfg: dict, name: str, key: str, lo: float, hi: float, unit: str = "", max_len: int = 10) -> tuple:
    """``name.key`` as a list of 1 to ``max_len`` finite numbers, each in [lo, hi]."""
    v = get(cfg, name, key)
    if not isinstance(v, list) or not 1 <= len(v) <= max_len:
        raise ConfigError(f"{name}.{key}", f"must be a list of 1 to {max_len} numbers{(' [' + unit + ']') if unit else ''}"
                          f", got {v!r}")
    return tuple(require_finite(f"{name}.{key}[{i}]", x, lo, hi, unit) for i, x in enumerate(v))


def int_list(cfg: dict, name: str, key: str, lo: int, hi: int, max_len: int = 16) -> list[int]:
    """``name.key`` as a non-empty list of distinct integers in [lo, hi]."""
    field, value = f"{name}.{key}", get(cfg, name, key)
    if not isinstance(value, list) or not 1 <= len(value) <= max_len:
        raise ConfigError(field, f"must be a list of 1 to {max_len} integers in [{lo}, {hi}], got {value!r}")
    out = [integer_value(f"{field}[{i}]", v, lo, hi) for i, v in enumerate(value)]
    if len(set(out)) != len(out):
        raise ConfigError(field, f"must not repeat a value, got {value!r}")
    return out


def name_list(cfg: dict, name: str, key: str, choices, allow_empty: bool = False) -> list[str]:
    """``name.key`` as a list of distinct names from ``choices`` (empty only when ``allow_empty``)."""
    field, value = f"{name}.{key}", get(cfg, name, key)
    if not isinstance(value, list) or (not value and not allow_empty):
        raise ConfigError(field, f"must be a list of names from {list(choices)}, got {value!r}")
    for i, v in enumerate(value):
        if v not in choices:
            raise ConfigError(f"{field}[{i}]", f"must be one of {list(choices)}, got {v!r}")
    if len(set(value)) != len(value):
        raise ConfigError(field, f"must not repeat a name, got {value!r}")
    return list(value)


def known_keys(table: dict, known, field: str) -> None:
    """Refuse a key of ``table`` (the table ``field``) that is not in ``known``, naming it and the known keys."""
    unknown = set(table) - set(known)
    if unknown:
        raise ConfigError(f"{field}.{sorted(unknown)[0]}", f"unknown key (known: {', '.join(sorted(known))})")
