"""Scenario files: TOML load and dump, ``--set key=value`` overrides, generic validation.

A scenario is a nested dict (docs/architecture.md §Contracts) that round-trips through TOML; its edits by dotted key
(``--set``, a file merged onto its reference) are :mod:`sarnav.tomlio`'s. This module knows no kind: it checks what every scenario shares (``[scenario] name, kind``,
``[campaign] runs, seed``), rejects NaN/inf anywhere, unknown keys and type mismatches against the
kind's reference configuration (the registry entry named like the kind, when there is one), and then
calls the kind's own ``validate``.

Every failure is a :class:`sarnav.errors.ConfigError` naming the field (dotted path) or, for malformed
TOML, the file and line.
"""

from __future__ import annotations

import os
from typing import Sequence

from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import validate_campaign, validate_common  # noqa: F401  (re-exported)
from sarnav.scenarios.aliases import rename_key, rename_keys
from sarnav.tomlio import (apply_overrides, check_finite, dump_toml, load_toml_file, merge_onto,  # noqa: F401
                           parse_override, parse_toml, set_value)  # (re-exported: the scenario's edits by dotted key)

__all__ = ["parse_toml", "load_toml_file", "dump_toml", "parse_override", "apply_overrides", "set_value",
           "check_finite", "merge_onto", "validate_common", "validate_scenario", "load_scenario"]


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
