"""The tables the image-quality kinds share (``quality-sweep``, ``gpsd-search``): ``[geometry]`` and ``[scene]``.

Configuration and wiring only: the geometry is :class:`sarnav.radar.quality_scenes.QualityGeometry` (the thesis'
radar at PRF 1667 Hz, docs/quality.md §2), the scenes are ``usu_picture``/``binary_scene`` (the USU-like binary
picture) and ``point_clutter_scene``. Every value is checked here with its range, so that a scenario of any size
is refused before anything is allocated (echo data pulses x range samples, scatterers x pulses of echo work).
"""

from __future__ import annotations

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError, require_finite
from sarnav.radar.quality_scenes import QualityGeometry, binary_scene, point_clutter_scene, usu_picture
from sarnav.scenarios.fields import boolean, get, table

__all__ = ["SCENE_TYPES", "default_geometry", "default_scene", "read_geometry", "read_scene", "make_scene",
           "integer", "int_list", "str_list", "MAX_ECHO_SAMPLES", "MAX_ECHO_WORK"]

SCENE_TYPES = ("usu", "point-clutter")
#: echo data held at once (pulses x range samples, complex128: 16 bytes each): 2^24 = 256 MiB
MAX_ECHO_SAMPLES = 2**24
#: echo work (scatterers x pulses): about 1 s per 2e7 on 2 cores
MAX_ECHO_WORK = 1e8


def default_geometry() -> dict:
    """The thesis' geometry as sarnav fills it (docs/quality.md §2): 60 m/s at 1000 m, scene 1760 m east."""
    return {"speed": 60.0, "altitude": 1000.0, "ground_range": 1760.0, "n_pulses": 4000, "scene_extent": 25.0,
            "pulse_length_us": 0.2, "range_margin_m": 10.0}


def default_scene(kind: str = "usu") -> dict:
    """``[scene]``: the USU-like picture (quality sweep) or points over clutter (the search)."""
    return {"type": kind, "seed": 5, "points": 12, "point_to_clutter_db": 20.0, "clutter_density": 0.5,
            "usu_cells": 24, "receiver_noise": False, "snr_db": 10.0}


def integer(field: str, value, lo: int, hi: int) -> int:
    """``value`` as an integer in [lo, hi] (no booleans, no floats), else ConfigError naming ``field``."""
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ConfigError(field, f"must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def int_list(field: str, value, lo: int, hi: int, max_len: int = 16) -> list[int]:
    """A non-empty list of distinct integers in [lo, hi]."""
    if not isinstance(value, list) or not 1 <= len(value) <= max_len:
        raise ConfigError(field, f"must be a list of 1 to {max_len} integers in [{lo}, {hi}], got {value!r}")
    out = [integer(f"{field}[{i}]", v, lo, hi) for i, v in enumerate(value)]
    if len(set(out)) != len(out):
        raise ConfigError(field, f"must not repeat a value, got {value!r}")
    return out


def str_list(field: str, value, choices, allow_empty: bool = False) -> list[str]:
    """A list of distinct names from ``choices``."""
    if not isinstance(value, list) or (not value and not allow_empty):
        raise ConfigError(field, f"must be a list of names from {list(choices)}, got {value!r}")
    for i, v in enumerate(value):
        if v not in choices:
            raise ConfigError(f"{field}[{i}]", f"must be one of {list(choices)}, got {v!r}")
    if len(set(value)) != len(value):
        raise ConfigError(field, f"must not repeat a name, got {value!r}")
    return list(value)


def read_geometry(cfg: dict) -> QualityGeometry:
    """``[geometry]`` -> QualityGeometry, with the echo data bounded (:data:`MAX_ECHO_SAMPLES`)."""
    table(cfg, "geometry")

    def num(key, lo, hi, unit):
        return require_finite(f"geometry.{key}", get(cfg, "geometry", key), lo, hi, unit)

    speed = num("speed", 1.0, 1000.0, "m/s")
    altitude = num("altitude", 10.0, 1e5, "m")
    extent = num("scene_extent", 1.0, 1000.0, "m")
    ground = num("ground_range", 10.0, 1e5, "m")
    if not ground > 2.0 * extent:
        raise ConfigError("geometry.ground_range", f"must exceed twice geometry.scene_extent = {extent} m, got {ground}")
    n = integer("geometry.n_pulses", get(cfg, "geometry", "n_pulses"), 16, 100_000)
    pulse = float(units.us_to_s(num("pulse_length_us", 0.01, 10.0, "us")))
    margin = num("range_margin_m", 0.0, 1000.0, "m")
    geo = QualityGeometry(speed=speed, altitude=altitude, ground_range=ground, n_pulses=n, scene_extent=extent,
                          pulse_length=pulse, range_margin=margin)
    samples = n * geo.radar().n_range_samples
    if samples > MAX_ECHO_SAMPLES:
        raise ConfigError("geometry.n_pulses", f"{n} pulses x {geo.radar().n_range_samples} range samples = "
                          f"{samples:.3g} echo samples; at most {MAX_ECHO_SAMPLES:.3g} (fewer pulses, a smaller scene "
                          "or a smaller geometry.range_margin_m)")
    try:  # the source's fixed PRF must cover the Doppler band at this speed (the echoes would alias)
        geo.radar().check_doppler(speed)
    except ConfigError as err:
        if err.field != "prf":
            raise
        raise ConfigError("geometry.speed", f"{err.message} (the PRF is the source's; lower geometry.speed)") from None
    return geo


def read_scene(cfg: dict, geo: QualityGeometry) -> dict:
    """``[scene]`` checked: type, seed, points, point_to_clutter_db, clutter_density [1/m^2], usu_cells,
    receiver_noise, snr_db (per-sample SNR of the strongest scatterer [dB], radar.echoes; used when receiver_noise
    is true)."""
    sc = table(cfg, "scene")
    kind = sc.get("type")
    if kind not in SCENE_TYPES:
        raise ConfigError("scene.type", f"must be one of {list(SCENE_TYPES)}, got {kind!r}")
    out = {"type": kind, "seed": integer("scene.seed", get(cfg, "scene", "seed"), 0, 2**63 - 1),
           "points": integer("scene.points", get(cfg, "scene", "points"), 0, 1000),
           "point_to_clutter_db": require_finite("scene.point_to_clutter_db", get(cfg, "scene", "point_to_clutter_db"),
                                                 -40.0, 80.0, "dB"),
           "clutter_density": require_finite("scene.clutter_density", get(cfg, "scene", "clutter_density"), 0.0,
                                             100.0, "1/m^2"),
           "usu_cells": integer("scene.usu_cells", get(cfg, "scene", "usu_cells"), 24, 240),
           "receiver_noise": boolean(cfg, "scene", "receiver_noise"),
           "snr_db": require_finite("scene.snr_db", get(cfg, "scene", "snr_db"), -60.0, 100.0, "dB")}
    if kind == "point-clutter":
        scatterers = out["points"] + out["clutter_density"] * geo.scene_extent**2
        field = "scene.clutter_density"
    else:
        scatterers = float(np.count_nonzero(usu_picture((out["usu_cells"],) * 2)))
        field = "scene.usu_cells"
    if scatterers < 1:
        raise ConfigError("scene.points", "the scene has no scatterer: give points or clutter_density > 0")
    if scatterers * geo.n_pulses > MAX_ECHO_WORK:
        raise ConfigError(field, f"{scatterers:.0f} scatterers x {geo.n_pulses} pulses = {scatterers * geo.n_pulses:.3g}"
                          f" echo evaluations; at most {MAX_ECHO_WORK:.0e}")
    return out


def make_scene(scene: dict, geo: QualityGeometry, seed_offset: int = 0):
    """(Scene, receiver-noise Generator or None, snr_db or None) of a checked ``[scene]``; the point/clutter draw and
    the noise come from ``SeedSequence([scene.seed, seed_offset])``."""
    ss = np.random.SeedSequence([scene["seed"], seed_offset])
    scene_ss, noise_ss = ss.spawn(2)
    if scene["type"] == "usu":
        pic = usu_picture((scene["usu_cells"],) * 2)
        sc = binary_scene(pic, geo.scene_center, geo.scene_extent)
    else:
        sc = point_clutter_scene(np.random.default_rng(scene_ss), geo.scene_center, geo.scene_extent,
                                 n_points=scene["points"], point_to_clutter_db=scene["point_to_clutter_db"],
                                 clutter_density=scene["clutter_density"])
    if not scene["receiver_noise"]:
        return sc, None, None
    return sc, np.random.default_rng(noise_ss), scene["snr_db"]
