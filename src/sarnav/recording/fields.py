"""Typed readers of the manifest's tables (``flight.toml``): every bad or missing key is one line naming the file,
the key and the valid range, ``flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got -100.0``. The
recording's own family of readers (the scenario layer's, ``scenarios.fields``, sit above this package and name
scenario keys)."""

from __future__ import annotations

import datetime
import math
from pathlib import PurePosixPath

import numpy as np

from sarnav.errors import ConfigError, require_finite

__all__ = ["Table", "MANIFEST"]

MANIFEST = "flight.toml"
_MISSING = object()


class Table:
    """One table of the manifest (``name``: ``imu``, ``aperture[3]``...) holding only the keys ``known``."""

    def __init__(self, data, name: str, known, where: str = MANIFEST):
        self.name, self.where = name, where
        if not isinstance(data, dict):
            raise ConfigError(f"{where}:{name}", f"must be a table, got {type(data).__name__}")
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise ConfigError(self.field(unknown[0]), f"unknown key (known: {', '.join(known)})")
        self.data = data

    def field(self, key: str) -> str:
        return f"{self.where}:{self.name}.{key}" if self.name else f"{self.where}:{key}"

    def has(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, default=_MISSING):
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            raise ConfigError(self.field(key), "missing")
        return default

    def number(self, key: str, lo=None, hi=None, unit: str = "", default=_MISSING) -> float:
        """A finite number in [lo, hi] (either bound None: open)."""
        return _number(self.field(key), self.get(key, default), lo, hi, unit)

    def positive(self, key: str, unit: str = "", hi: float = 1e12, default=_MISSING) -> float:
        """A finite number > 0 and <= hi; the error states the range (0, hi]."""
        v = self.get(key, default)
        u = f" {unit}" if unit else ""
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and 0 < v <= hi):
            raise ConfigError(self.field(key), f"must be a finite number in (0, {hi:g}]{u}, got {v!r}")
        return float(v)

    def integer(self, key: str, lo: int, hi: int, default=_MISSING) -> int:
        v = self.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise ConfigError(self.field(key), f"must be an integer in [{lo}, {hi}], got {v!r}")
        return v

    def boolean(self, key: str, default=_MISSING) -> bool:
        v = self.get(key, default)
        if not isinstance(v, bool):
            raise ConfigError(self.field(key), f"must be true or false, got {v!r}")
        return v

    def string(self, key: str, choices=None, default=_MISSING) -> str:
        v = self.get(key, default)
        if not isinstance(v, str) or (choices is not None and v not in choices):
            want = f"one of {list(choices)}" if choices is not None else "a string"
            raise ConfigError(self.field(key), f"must be {want}, got {v!r}")
        return v

    def vector(self, key: str, n: int, lo=None, hi=None, unit: str = "", default=_MISSING) -> np.ndarray:
        """A list of ``n`` finite numbers, each in [lo, hi]."""
        v = self.get(key, default)
        f = self.field(key)
        if not isinstance(v, (list, tuple)) or len(v) != n:
            raise ConfigError(f, f"must be a list of {n} numbers{(' [' + unit + ']') if unit else ''}, got {v!r}")
        return np.array([_number(f"{f}[{i}]", x, lo, hi, unit) for i, x in enumerate(v)], dtype=np.float64)

    def path(self, key: str, default=_MISSING) -> str | None:
        """A file of the recording: a relative POSIX path inside the recording's folder (no ``..``)."""
        v = self.get(key, default)
        if v is None:
            return None
        p = PurePosixPath(v) if isinstance(v, str) else None
        if p is None or not v or p.is_absolute() or ".." in p.parts or "\\" in v:
            raise ConfigError(self.field(key), f"must be a path relative to the recording's folder (forward "
                              f"slashes, no '..'), got {v!r}")
        return str(p)

    def datetime(self, key: str) -> datetime.datetime:
        """A TOML offset date-time, or an ISO 8601 string with its offset (``2026-01-01T00:00:00Z``): UTC."""
        v = self.get(key)
        if isinstance(v, str):
            try:
                v = datetime.datetime.fromisoformat(v.replace("Z", "+00:00"))
            except ValueError:
                raise ConfigError(self.field(key), f"must be an ISO 8601 date-time, got {v!r}") from None
        if not isinstance(v, datetime.datetime) or v.tzinfo is None:
            raise ConfigError(self.field(key), f"must be a date-time with its UTC offset (e.g. "
                              f"2026-01-01T00:00:00Z), got {v!r}")
        return v.astimezone(datetime.timezone.utc)


def _number(field: str, value, lo, hi, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        rng = f" in [{-math.inf if lo is None else lo:g}, {math.inf if hi is None else hi:g}]" if (lo, hi) != (None, None) else ""
        raise ConfigError(field, f"must be a number{rng}{(' [' + unit + ']') if unit else ''}, got {value!r}")
    return require_finite(field, value, lo, hi, unit)  # a TOML number: the range check of every reader
