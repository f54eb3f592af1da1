"""Configuration of ``sarnav navigate``: the navigator's settings for a recording (docs/navigate.md).

The keys are the rda-nav scenario's (docs/scenarios/rda-nav.md, docs/scenarios/vocabulary.md) that describe the
navigator rather than the world: every ``[sar]`` key, ``[filter.imu]`` and ``earth.modelled``. Their defaults are the
recording's ``scenario.toml`` when it has one (an exported recording: the campaign's own settings, so navigating it
gives the campaign's run again), else the rda-nav scenario's defaults with the manifest's ``[imu]`` and
``frame.earth_rotation``; over them ``--config nav.toml`` (those tables only), then ``--set KEY=VALUE``. The whole is
read by the rda-nav kind's own parser (``scenarios.rda_nav.parse``): one meaning and one error message per key.
"""

from __future__ import annotations

import copy
from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.recording import Recording
from sarnav.recording.fields import MANIFEST
from sarnav.recording.navigate import NavigateSettings
from sarnav.scenarios import fields, rda_nav
from sarnav.scenarios.config import apply_overrides, merge_onto, parse_override
from sarnav.scenarios.vocabulary import IMU_OVERRIDES, filter_imu_keys
from sarnav.tomlio import load_toml_file, parse_toml

__all__ = ["read_navigate_settings", "NAVIGATOR_TABLES", "SCENARIO_FILE"]

#: the tables of nav.toml (and the first component of a --set key)
NAVIGATOR_TABLES = ("sar", "filter", "earth", "ins")
#: the navigator's own keys (not the rda-nav scenario's): the longest IMU gap bridged [s] (recording.timeline)
INS_DEFAULTS = {"max_gap_s": 1.0}
#: an exported recording's scenario, the defaults of its settings
SCENARIO_FILE = "scenario.toml"
_IMU_KEYS = ("grade", "rate_hz", "tau_accel", "tau_gyro") + IMU_OVERRIDES
_OPTIONAL = ["sar.registration_sigma_m"] + filter_imu_keys()


def _defaults(rec: Recording) -> dict:
    """The scenario the settings are read from before nav.toml and --set (module docstring)."""
    if rec.scenario_text is not None:
        cfg = parse_toml(rec.scenario_text, SCENARIO_FILE)
        kind = cfg.get("scenario", {}).get("kind") if isinstance(cfg.get("scenario"), dict) else None
        if kind != "rda-nav":
            raise ConfigError(f"{SCENARIO_FILE}:scenario.kind", f"navigate reads the settings of an rda-nav "
                              f"scenario, got {kind!r}")
        cfg["ins"] = dict(INS_DEFAULTS)
        return cfg
    cfg = rda_nav.default_config()
    cfg["trajectory"]["duration"] = 1.0  # the world's keys are parsed, never used
    raw = load_toml_file(rec.folder / MANIFEST)["imu"]
    cfg["imu"] = {k: raw[k] for k in _IMU_KEYS if k in raw}
    cfg["earth"].update(rotation=bool(rec.manifest.frame.earth_rotation),
                        latitude_deg=float(rec.manifest.frame.origin[0]))
    cfg["ins"] = dict(INS_DEFAULTS)
    return cfg


def _check_keys(keys, where: str) -> None:
    """Only the navigator's tables: ``sar.*``, ``filter.imu.*``, ``earth.modelled``, ``ins.*``."""
    for key in keys:
        top = key.split(".", 1)[0]
        if top not in NAVIGATOR_TABLES or (top == "earth" and key != "earth.modelled"):
            raise ConfigError(f"{where}{key}", "not a setting of the navigator (navigate reads [sar], [filter.imu], "
                              "earth.modelled and [ins]; the recording gives the rest)")


def _leaves(doc: dict, prefix: str = ""):
    for k, v in doc.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and v:
            yield from _leaves(v, key + ".")
        else:
            yield key


def read_navigate_settings(rec: Recording, config=None, overrides=()) -> NavigateSettings:
    """The navigator's settings for ``rec``: defaults (module docstring), ``config`` (a nav.toml path or None),
    ``overrides`` (``KEY=VALUE`` strings). ConfigError names the file and key."""
    cfg = _defaults(rec)
    if config is not None:
        path = Path(config)
        doc = load_toml_file(path)
        _check_keys(list(_leaves(doc)), f"{path.name}:")
        try:
            cfg = merge_onto(cfg, doc, _OPTIONAL)
        except ConfigError as err:
            raise ConfigError(f"{path.name}:{err.field}", err.message) from None
    _check_keys([parse_override(o)[0] for o in overrides], "")
    cfg = apply_overrides(cfg, list(overrides), _OPTIONAL)
    ins = {"ins": cfg.pop("ins")}
    max_gap = fields.number(ins, "ins", "max_gap_s", 0.0, 3600.0, "s")
    if not max_gap > 0:
        raise ConfigError("ins.max_gap_s", f"must be > 0 s and <= 3600 s, got {max_gap!r}")
    prm = rda_nav.parse(copy.deepcopy(cfg))
    if prm.sar_enabled and prm.measurement != "image":
        raise ConfigError("sar.measurement", "navigate forms the images from the recording's pulses: must be "
                          f"'image', got {prm.measurement!r}")
    return NavigateSettings(sar=prm.sar_update if prm.sar_enabled else None, imaging=prm.imaging,
                            sar_bias_sigma=prm.bias_sigma[1:].copy(), sar_bias_tau=prm.bias_tau[1:].copy(),
                            imu_filter=prm.imu_filter, earth_modelled=bool(cfg["earth"]["modelled"]),
                            max_gap=max_gap)
