"""Scenario files: TOML load and dump, ``--set key=value`` overrides, generic validation.

A scenario is a nested dict (docs/architecture.md §Contracts) that round-trips through TOML. This
module knows no kind: it checks what every scenario shares (``[scenario] name, kind``,
``[campaign] runs, seed``), rejects NaN/inf anywhere, unknown keys and type mismatches against the
kind's reference configuration (the registry entry named like the kind, when there is one), and then
calls the kind's own ``validate``.

Every failure is a :class:`sarnav.errors.ConfigError` naming the field (dotted path) or, for malformed
TOML, the file and line.
"""

from __future__ import annotations

import copy
import os
from typing import Any, Iterable, Sequence

from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import validate_campaign, validate_common  # noqa: F401  (re-exported)
from sarnav.scenarios.aliases import rename_key, rename_keys
from sarnav.tomlio import check_finite, dump_toml, load_toml_file, parse_toml, parse_value

__all__ = [
    "parse_toml",
    "load_toml_file",
    "dump_toml",
    "parse_override",
    "apply_overrides",
    "set_value",
    "check_finite",
    "merge_onto",
    "validate_common",
    "validate_scenario",
    "load_scenario",
]


# ----------------------------------------------------------------------------- overrides
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
    """A ``--set`` value is exactly one TOML value (``tomlio.parse_value``); a bare word is accepted as a string where
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


# ----------------------------------------------------------------------------- validation
def validate_scenario(cfg: dict, kind=None) -> None:
    """Generic checks, then the kind's ``validate`` (kind resolved from ``scenario.kind`` if not given)."""
    from sarnav.scenarios.registry import get_kind

    validate_common(cfg, needs_campaign=False)
    kind = kind if kind is not None else get_kind(cfg["scenario"]["kind"])
    validate_common(cfg, needs_campaign=kind.needs_campaign)
    kind.validate(cfg)


def _rename_overrides(overrides: Sequence[str], kind_name: str, notices: list) -> list[str]:
    out = []
    for item in overrides:
        key, text = parse_override(item)
        new, _, note = rename_key(kind_name, key, None)
        if note:
            notices.append(note)
            item = f"{new}={text}"
            if new == "trajectory.start_ned" and _is_number(text):  # an altitude given under its old name
                item = f"{new}=[0.0, 0.0, {-float(text)!r}]"
        out.append(item)
    return out


def _is_number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def _emit(notices: list, sink) -> None:
    if sink is not None:
        sink.extend(notices)
        return
    import warnings

    for n in notices:
        warnings.warn(n, FutureWarning, stacklevel=3)


def load_scenario(
    source: str | os.PathLike,
    overrides: Sequence[str] = (),
    runs: int | None = None,
    seed: int | None = None,
    validate: bool = True,
    notices: list | None = None,
) -> dict:
    """Resolve a registered scenario name or a ``.toml`` file into a validated scenario dict.

    Parameters
    ----------
    source : a name from :func:`sarnav.scenarios.registry.list_scenarios` or a path to a TOML file.
        A file is merged onto a reference configuration (the registered scenario of the file's ``scenario.name``
        when it has the same kind, else the kind's reference), so it may give only the keys it changes. Keys
        renamed since sarnav 0.1 are moved to their new names (:mod:`sarnav.scenarios.aliases`).
    overrides : ``"dotted.key=value"`` strings, values parsed as TOML (bare words as strings).
    runs, seed : shortcuts for ``campaign.runs`` / ``campaign.seed``.
    validate : run :func:`validate_scenario` at the end.
    notices : a list that receives one line per renamed key found; None: each is a ``FutureWarning``.
    """
    from sarnav.scenarios import registry

    found: list[str] = []
    src = os.fspath(source)
    registered = {name for name, _ in registry.list_scenarios()}
    if src not in registered and (src.endswith(".toml") or os.sep in src or os.path.isfile(src)):
        raw = load_toml_file(src)
        check_finite(raw)
        kind_name = raw.get("scenario", {}).get("kind") if isinstance(raw.get("scenario"), dict) else None
        if not isinstance(kind_name, str) or not kind_name:
            raise ConfigError("scenario.kind", f"missing in {src} (e.g. kind = \"telemetry\")")
        registry.get_kind(kind_name)  # an unknown kind is the error to report, not the keys it lacks
        found += rename_keys(raw, kind_name)
        template = registry.template_for(kind_name, raw["scenario"].get("name"))
        cfg = merge_onto(template, raw, registry.optional_keys(kind_name)) if template is not None else raw
    else:
        cfg = registry.get_scenario(src)
    kind_name = cfg.get("scenario", {}).get("kind", "") if isinstance(cfg.get("scenario"), dict) else ""
    optional = registry.optional_keys(kind_name) if isinstance(kind_name, str) and kind_name else set()
    overrides = _rename_overrides(overrides, kind_name, found)
    _emit(found, notices)
    cfg = apply_overrides(cfg, overrides, optional)
    if runs is not None:
        cfg.setdefault("campaign", {})["runs"] = runs
    if seed is not None:
        cfg.setdefault("campaign", {})["seed"] = seed
    if validate:
        validate_scenario(cfg)
    return cfg
