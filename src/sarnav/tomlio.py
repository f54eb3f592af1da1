"""Scenario text: TOML parse and dump with NaN/inf rejection, and edits by dotted key (ground floor: imports only
``errors``).

Every scenario is a nested dict that round-trips through TOML; the campaign store keeps its text, the
scenario reader parses it. Malformed text raises :class:`~sarnav.errors.ConfigError` naming the origin and line.
An edit (``--set a.b=value``, a file merged onto a reference configuration) may only replace a key that exists (or one
of the dotted keys listed as optional) with a value of its type; it knows no scenario kind.
"""

from __future__ import annotations

import copy
import math
import os
import tomllib
from typing import Any, Iterable, Sequence

import tomli_w

from sarnav.errors import ConfigError

__all__ = ["parse_toml", "parse_value", "load_toml_file", "dump_toml", "check_finite", "MAX_FILE_BYTES", "MAX_DEPTH",
           "MAX_VALUE_CHARS", "parse_override", "set_value", "apply_overrides", "merge_onto"]

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


# ----------------------------------------------------------------------------- edits by dotted key
#: the TOML value types in the order they are told apart (a bool is an int to Python) and their names in messages
_TYPES = ((bool, "boolean"), (int, "integer"), (float, "number"), (str, "string"), (list, "list"), (dict, "table"))


def _type_name(value: Any) -> str:
    return next((name for t, name in _TYPES if isinstance(value, t)), type(value).__name__)


def _coerce(field: str, old: Any, new: Any) -> Any:
    """Return ``new`` converted to the type of ``old`` or raise ConfigError (type mismatch)."""
    want, got = _type_name(old), _type_name(new)
    if want == "table":
        raise ConfigError(field, "is a table; set one of its keys instead, e.g. " + f"{field}.{next(iter(old), 'key')}")
    if want == "number" and got in ("integer", "number"):
        return float(new)
    if want == "list" and got == "list":
        numeric = [isinstance(v, (int, float)) and not isinstance(v, bool) for v in old]
        if old and all(numeric):
            for i, v in enumerate(new):
                if isinstance(v, bool) or not isinstance(v, (int, float)):
                    raise ConfigError(f"{field}[{i}]", f"must be a number, got {_type_name(v)} {v!r}")
            return [float(v) if any(isinstance(o, float) for o in old) else v for v in new]
        return new
    if want == got or want not in {name for _, name in _TYPES}:
        return new
    article = "an" if want[0] in "aeiou" else "a"
    raise ConfigError(field, f"must be {article} {want} (like the default {old!r}), got {got} {new!r}")


def parse_override(item: str) -> tuple[str, str]:
    """Split ``"a.b=value"`` into ``("a.b", "value")``; no ``=`` -> ConfigError."""
    key, sep, value = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError("--set", f"expected key=value (e.g. imu.grade=tactical), got {item!r}")
    return key, value.strip()


def _parse_value(field: str, text: str, old: Any) -> Any:
    """A ``--set`` value is exactly one TOML value (:func:`parse_value`); a bare word is accepted as a string where
    one is expected."""
    try:
        return parse_value(text, field, bare_string=isinstance(old, str) or old is None)
    except ConfigError as err:
        if "cannot parse" in err.message:
            raise ConfigError(field, f"{err.message} (expected like {old!r})") from None
        raise


def _split(field: str) -> list[str]:
    parts = field.split(".")
    if any(not p for p in parts):
        raise ConfigError(field, "malformed key (empty component)")
    return parts


def set_value(cfg: dict, field: str, value: Any, optional: Iterable[str] = ()) -> None:
    """Set ``cfg[a][b] = value`` for ``field = "a.b"``, in place.

    The key must already exist (unknown keys are errors, except the dotted paths listed in
    ``optional``) and ``value`` must have the type of the value it replaces (an integer is accepted
    for a float). NaN/inf are rejected.
    """
    parts = _split(field)
    node = cfg
    for i, part in enumerate(parts[:-1]):
        sub = node.get(part) if isinstance(node, dict) else None
        if not isinstance(sub, dict):
            here = ".".join(parts[: i + 1])
            if sub is None and field in set(optional):
                node[part] = sub = {}
            elif sub is None:
                raise ConfigError(field, f"unknown key ({here!r} is not a table of this scenario)")
            else:
                raise ConfigError(field, f"unknown key ({here!r} is a {_type_name(sub)}, not a table)")
        node = sub
    last = parts[-1]
    check_finite(value, field)
    if last in node:
        node[last] = _coerce(field, node[last], value)
    elif field in set(optional):
        node[last] = value
    else:
        known = ", ".join(sorted(node)) or "none"
        raise ConfigError(field, f"unknown key (known keys here: {known})")


def apply_overrides(cfg: dict, overrides: Sequence[str], optional: Iterable[str] = ()) -> dict:
    """Return a copy of ``cfg`` with each ``key=value`` string of ``overrides`` applied in order."""
    out = copy.deepcopy(cfg)
    optional = set(optional)
    for item in overrides:
        key, text = parse_override(item)
        node: Any = out
        for part in _split(key):
            node = node.get(part) if isinstance(node, dict) else None
        set_value(out, key, _parse_value(key, text, node), optional)
    return out


def merge_onto(template: dict, cfg: dict, optional: Iterable[str] = (), prefix: str = "") -> dict:
    """Return ``template`` updated with every leaf of ``cfg`` (unknown keys / wrong types -> ConfigError).

    Lists (including arrays of tables) replace the template's value as a whole.
    """
    out = copy.deepcopy(template)
    optional = set(optional)

    def walk(node: dict, path: str) -> None:
        for key, value in node.items():
            field = f"{path}.{key}" if path else str(key)
            if isinstance(value, dict) and (field in optional or _lookup(out, field) is not None):
                target = _lookup(out, field)
                if target is not None and not isinstance(target, dict):
                    raise ConfigError(field, f"must be a {_type_name(target)}, got a table")
                if target is None:
                    set_value(out, field, {}, optional | {field})
                walk(value, field)
            else:
                set_value(out, field, value, optional)

    walk(cfg, prefix)
    return out


def _lookup(cfg: dict, field: str) -> Any:
    node: Any = cfg
    for part in field.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node
