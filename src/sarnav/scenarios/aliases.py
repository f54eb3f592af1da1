"""Renamed scenario keys: the old names accepted for one more release, each with a one-line notice.

sarnav 0.2 gave every kind one vocabulary (docs/scenarios/vocabulary.md): the keys of 0.1, and the kind-local
spellings that 0.2 still had (``[geometry]`` of the quality kinds, the closed loop's ``[radar]`` keys), moved to the
shared names. A scenario file written by ``sarnav show`` before the move still runs: each old key found (in a file, in
a study's ``[base]`` or case ``set`` tables, or in ``--set``) is moved to its new name (with the value converted where
the quantity changed form) and reported as ``<old> is now <new> (the old name is accepted until sarnav 0.3)``.
Giving both the old and the new key is an error.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from sarnav.errors import ConfigError

__all__ = ["RENAMED", "RETIRED", "UNTIL", "rename_keys", "rename_key"]

#: the release that stops accepting the old names
UNTIL = "0.3"


def _altitude_to_start(altitude):
    """An altitude [m] -> ``start_ned`` of a track over the origin: [0, 0, -altitude]."""
    if isinstance(altitude, bool) or not isinstance(altitude, (int, float)):
        return altitude  # left for the kind's validation to name
    return [0.0, 0.0, -float(altitude)]


@dataclass(frozen=True)
class Renamed:
    """``old`` (dotted key) of scenarios of ``kind`` is now ``new``; ``convert`` maps the value (None: same)."""

    kind: str
    old: str
    new: str
    convert: Callable | None = None


RENAMED: tuple[Renamed, ...] = (
    Renamed("rda-nav", "scene.snr_db", "radar.snr_db"),
    Renamed("image", "trajectory.speed_mps", "trajectory.speed"),
    Renamed("image", "trajectory.altitude_m", "trajectory.start_ned", _altitude_to_start),
    Renamed("image", "trajectory.duration_s", "trajectory.duration"),
    Renamed("image", "image.margin_m", "radar.range_margin_m"),
    Renamed("bpa-sensitivity", "geometry.speed", "trajectory.speed"),
    Renamed("bpa-sensitivity", "geometry.altitude", "trajectory.start_ned", _altitude_to_start),
    Renamed("bpa-sensitivity", "geometry.aperture", "trajectory.duration"),
    Renamed("bpa-sensitivity", "geometry.target_ground_range", "scene.target_ground_range"),
    Renamed("bpa-sensitivity", "radar.prf", "radar.prf_hz"),
    Renamed("bpa-sensitivity", "radar.range_margin", "radar.range_margin_m"),
    # sarnav 0.2's own tables of the quality and spacecraft closed-loop kinds, now in the shared vocabulary (issue 25)
    *(Renamed(kind, old, new, convert) for kind in ("quality-sweep", "gpsd-search") for old, new, convert in (
        ("geometry.speed", "trajectory.speed", None),
        ("geometry.altitude", "trajectory.start_ned", _altitude_to_start),
        ("geometry.ground_range", "scene.ground_range", None),
        ("geometry.n_pulses", "aperture.n_pulses", None),
        ("geometry.scene_extent", "scene.extent", None),
        ("geometry.pulse_length_us", "radar.pulse_length_us", None),
        ("geometry.range_margin_m", "radar.range_margin_m", None),
        ("scene.receiver_noise", "radar.receiver_noise", None),
        ("scene.snr_db", "radar.snr_db", None))),
    Renamed("quality-nav", "focus.aperture_pulses", "aperture.n_pulses"),
    Renamed("spacecraft-closed-loop", "radar.pulse_us", "radar.pulse_length_us"),
    Renamed("spacecraft-closed-loop", "radar.range_samples", "radar.n_range_samples"),
    Renamed("spacecraft-closed-loop", "radar.antenna_length", "radar.antenna_length_m"),
    Renamed("spacecraft-closed-loop", "radar.block_s", "aperture.duration"),
)


@dataclass(frozen=True)
class Retired:
    """``key`` of scenarios of ``kind`` had the default ``values`` (one per scenario of the kind) that is a default
    no more: a file that still carries one of them did not choose it, so it is dropped with ``why`` as the notice; any
    other value is the user's and kept."""

    kind: str
    key: str
    values: tuple
    why: str


RETIRED: tuple[Retired, ...] = (
    Retired("rda-nav", "sar.registration_sigma_m", ([0.00125, 0.0315], [0.0007, 0.0024]),
            "the registration sigma now comes from each image (issue 10); the constant is an optional override"),
)


def _notice(prefix: str, r: Renamed) -> str:
    return f"{prefix}{r.old} is now {prefix}{r.new} (the old name is accepted until sarnav {UNTIL})"


def rename_key(kind: str, key: str, value, prefix: str = "") -> tuple[str, object, str | None]:
    """(new key, converted value, notice or None) for one dotted ``key`` of a scenario of ``kind``."""
    for r in RENAMED:
        if r.kind == kind and r.old == key:
            return r.new, (value if r.convert is None else r.convert(value)), _notice(prefix, r)
    return key, value, None


def _pop(cfg: dict, dotted: str):
    *tables, leaf = dotted.split(".")
    node = cfg
    for t in tables:
        node = node.get(t) if isinstance(node, dict) else None
        if not isinstance(node, dict):
            return False, None
    if leaf not in node:
        return False, None
    value = node.pop(leaf)
    if not node and len(tables) == 1:  # a table emptied by the moves (e.g. [geometry]) goes too
        cfg.pop(tables[0], None)
    return True, value


def _has(cfg: dict, dotted: str) -> bool:
    node = cfg
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return False
        node = node[part]
    return True


def rename_keys(cfg: dict, kind: str, prefix: str = "") -> list[str]:
    """Move the old keys of a scenario of ``kind`` to their new names, in place; returns the notices.

    A study's ``[base]`` scenario and its cases' ``set`` tables are renamed with the base's kind."""
    notices = []
    for r in RENAMED:
        if r.kind != kind or not _has(cfg, r.old):
            continue
        if _has(cfg, r.new):
            raise ConfigError(f"{prefix}{r.old}", f"is the old name of {prefix}{r.new}; give only {prefix}{r.new}")
        _, value = _pop(cfg, r.old)
        *tables, leaf = r.new.split(".")
        node = cfg
        for t in tables:
            node = node.setdefault(t, {})
        node[leaf] = value if r.convert is None else r.convert(value)
        notices.append(_notice(prefix, r))
    for r in RETIRED:
        if r.kind == kind and _has(cfg, r.key):
            *tables, leaf = r.key.split(".")
            node = cfg
            for t in tables:
                node = node[t]
            if node[leaf] in [list(v) for v in r.values]:
                del node[leaf]
                notices.append(f"{prefix}{r.key}: the value of this file was the default of sarnav 0.2 and is "
                               f"dropped: {r.why}")
    base = cfg.get("base") if kind == "study" else None
    if isinstance(base, dict) and isinstance(base.get("scenario"), dict):
        base_kind = base["scenario"].get("kind")
        notices += rename_keys(base, base_kind, prefix="base.")
        for i, case in enumerate(cfg.get("cases") or []):
            sets = case.get("set") if isinstance(case, dict) else None
            if isinstance(sets, dict):
                for key in list(sets):
                    new, value, note = rename_key(base_kind, key, sets[key], prefix=f"cases[{i}].set.")
                    if note:
                        sets[new] = value
                        del sets[key]
                        notices.append(note)
    return notices
