"""Scenario text: TOML parse and dump with NaN/inf rejection (ground floor: imports only ``errors``).

Every scenario is a nested dict that round-trips through TOML; the campaign store keeps its text, the
scenario reader parses it. Malformed text raises :class:`~sarnav.errors.ConfigError` naming the origin and line.
"""

from __future__ import annotations

import math
import os
import tomllib
from typing import Any

import tomli_w

from sarnav.errors import ConfigError

__all__ = ["parse_toml", "parse_value", "load_toml_file", "dump_toml", "check_finite", "MAX_FILE_BYTES", "MAX_DEPTH",
           "MAX_VALUE_CHARS"]

#: largest scenario file read [bytes]
MAX_FILE_BYTES = 10 * 2**20
#: deepest nesting of tables and arrays in a scenario (sarnav's own go 4 deep; 1,000 gave a RecursionError)
MAX_DEPTH = 32
#: longest ``--set`` value [characters]
MAX_VALUE_CHARS = 65536


def _depth(value) -> int:
    """Nesting depth of tables and arrays (iterative: a value too deep for recursion is measured too)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            stack.extend((x, d + 1) for x in v.values())
        elif isinstance(v, list):
            stack.extend((x, d + 1) for x in v)
        else:
            continue
        deepest = max(deepest, d + 1)
    return deepest


def parse_toml(text: str, origin: str = "<string>") -> dict:
    """Parse TOML text; malformed text -> ConfigError naming ``origin`` and the line; nesting deeper than
    :data:`MAX_DEPTH` -> ConfigError."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:  # message carries "(at line L, column C)"
        raise ConfigError(origin, f"malformed TOML: {err}") from None
    except RecursionError:
        doc = None
    if doc is None or _depth(doc) > MAX_DEPTH:
        raise ConfigError(origin, f"tables or arrays nested more than {MAX_DEPTH} deep (a scenario nests a few)")
    return doc


def parse_value(text: str, field: str, bare_string: bool = False):
    """Exactly one TOML value (the ``--set`` parser; scenario files go through :func:`parse_toml`, the same TOML
    reader and bounds). Anything after the value (another key, a table) is refused, not dropped. ``bare_string``: a
    text that is no TOML value is taken as a string (``--set imu.grade=consumer``) if it is one line without
    control characters. Raises ConfigError naming ``field``."""
    if len(text) > MAX_VALUE_CHARS:
        raise ConfigError(field, f"value of {len(text)} characters; at most {MAX_VALUE_CHARS}")
    try:
        doc = parse_toml(f"v = {text}", origin=field)
    except ConfigError as err:
        if "nested" in err.message:
            raise
        if bare_string and text and all(ch.isprintable() for ch in text):
            return text
        raise ConfigError(field, f"cannot parse {text!r} as one TOML value") from None
    if set(doc) != {"v"}:
        extra = sorted(set(doc) - {"v"})[0]
        raise ConfigError(field, f"must be exactly one TOML value, got {text!r} (which also sets {extra!r}; give "
                          "each key its own --set)")
    return doc["v"]


def load_toml_file(path: str | os.PathLike) -> dict:
    """Read a ``.toml`` scenario file (UTF-8, a regular file: never a FIFO or device, which could block)."""
    import stat

    path = os.fspath(path)
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise ConfigError(path, "is not a regular file (a scenario is a .toml file)")
        if st.st_size > MAX_FILE_BYTES:
            raise ConfigError(path, f"is {st.st_size} bytes; a scenario file is at most {MAX_FILE_BYTES} bytes")
        with open(path, "rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
    except OSError as err:
        raise ConfigError(path, f"cannot read scenario file: {err.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(path, "scenario file is not UTF-8 text") from None
    return parse_toml(text, origin=path)


def dump_toml(cfg: dict) -> str:
    """The scenario as TOML text (``parse_toml(dump_toml(cfg)) == cfg`` for finite configs)."""
    check_finite(cfg)
    return tomli_w.dumps(cfg)


# ----------------------------------------------------------------------------- finiteness
def check_finite(value: Any, field: str = "") -> None:
    """Raise ConfigError naming the first NaN/inf number anywhere in ``value`` (nested dicts/lists)."""
    if isinstance(value, dict):
        for key, sub in value.items():
            check_finite(sub, f"{field}.{key}" if field else str(key))
    elif isinstance(value, list):
        for i, sub in enumerate(value):
            check_finite(sub, f"{field}[{i}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(field or "<value>", f"must be a finite number, got {value!r}")
