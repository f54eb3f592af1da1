"""Typed reads of scenario values that raise :class:`ConfigError` naming the dotted field.

Shared by the kinds' ``parse`` functions (``telemetry``, ``rda-nav``).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError, require_finite, require_positive

__all__ = ["table", "get", "positive", "vector", "boolean"]


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


def positive(cfg: dict, name: str, key: str, unit: str = "") -> float:
    """``name.key`` as a finite float > 0."""
    return require_positive(f"{name}.{key}", get(cfg, name, key), unit)


def vector(cfg: dict, name: str, key: str, n: int = 3, positive: bool = False, unit: str = "") -> np.ndarray:
    """``name.key`` as a list of ``n`` finite numbers (each > 0 when ``positive``)."""
    field = f"{name}.{key}"
    val = get(cfg, name, key)
    if not isinstance(val, (list, tuple)) or len(val) != n:
        raise ConfigError(field, f"must be a list of {n} numbers{(' [' + unit + ']') if unit else ''}, got {val!r}")
    if positive:
        return np.array([require_positive(f"{field}[{i}]", v, unit) for i, v in enumerate(val)])
    return np.array([require_finite(f"{field}[{i}]", v, unit=unit) for i, v in enumerate(val)])


def boolean(cfg: dict, name: str, key: str) -> bool:
    """``name.key`` as true or false (no numbers, no strings)."""
    v = get(cfg, name, key)
    if not isinstance(v, bool):
        raise ConfigError(f"{name}.{key}", f"must be true or false, got {v!r}")
    return v
