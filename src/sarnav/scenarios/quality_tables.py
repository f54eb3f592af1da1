"""The tables the image-quality kinds share (``quality-sweep``, ``gpsd-search``), in the shared vocabulary
(docs/scenarios/vocabulary.md, docs/quality.md §2): ``[trajectory]`` (``start_ned`` = [0, 0, -altitude], the
aperture centre over the NED origin, flying north; ``speed``), ``[aperture] n_pulses``, ``[radar]`` (the thesis'
FlexSAR, the only radar ``QualityGeometry`` forms) and ``[scene]``.

Configuration only: the geometry is :class:`sarnav.radar.quality_scenes.QualityGeometry`, the scene
:class:`sarnav.simulation.quality_scene.QualitySceneSpec`. Every value is checked here with its range, so that a
scenario of any size is refused before anything is allocated.
"""

from __future__ import annotations

from sarnav import units
from sarnav.errors import ConfigError
from sarnav.radar.quality_scenes import QualityGeometry
from sarnav.scenarios.fields import boolean, choice, integer, number, table
from sarnav.scenarios.vocabulary import read_altitude
from sarnav.simulation.quality_scene import SCENE_TYPES, QualitySceneSpec

__all__ = ["SCENE_TYPES", "RADAR_KEYS", "read_geometry", "read_scene",
           "MAX_ECHO_SAMPLES", "MAX_ECHO_WORK"]

#: the ``[radar]`` keys of the quality kinds (the radar itself is the thesis' FlexSAR, docs/quality.md §2)
RADAR_KEYS = ("preset", "pulse_length_us", "range_margin_m", "snr_db", "receiver_noise")
#: echo data held at once (pulses x range samples, complex128: 16 bytes each): 2^24 = 256 MiB
MAX_ECHO_SAMPLES = 2**24
#: echo work (scatterers x pulses): about 1 s per 2e7 on 2 cores
MAX_ECHO_WORK = 1e8


def _check_radar_keys(cfg: dict) -> None:
    for key in table(cfg, "radar"):
        if key not in RADAR_KEYS:
            raise ConfigError(f"radar.{key}", f"unknown key: the quality kinds form the thesis' radar (FlexSAR at PRF "
                              f"1667 Hz, docs/quality.md §2); known: {', '.join(RADAR_KEYS)}")
    choice(cfg, "radar", "preset", ("flexsar",))


def read_geometry(cfg: dict) -> QualityGeometry:
    """``[trajectory]``, ``[aperture]``, ``[radar]``, ``scene.ground_range`` and ``scene.extent`` -> QualityGeometry,
    with the echo data bounded (:data:`MAX_ECHO_SAMPLES`)."""
    _check_radar_keys(cfg)
    speed = number(cfg, "trajectory", "speed", 1.0, 1000.0, "m/s")
    altitude = read_altitude(cfg, 10.0, 1e5, over_origin=True)
    extent = number(cfg, "scene", "extent", 1.0, 1000.0, "m")
    ground = number(cfg, "scene", "ground_range", 10.0, 1e5, "m")
    if not ground > 2.0 * extent:
        raise ConfigError("scene.ground_range", f"must exceed twice scene.extent = {extent} m, got {ground}")
    n = integer(cfg, "aperture", "n_pulses", 16, 100_000)
    pulse = float(units.us_to_s(number(cfg, "radar", "pulse_length_us", 0.01, 10.0, "us")))
    margin = number(cfg, "radar", "range_margin_m", 0.0, 1000.0, "m")
    geo = QualityGeometry(speed=speed, altitude=altitude, ground_range=ground, n_pulses=n, scene_extent=extent,
                          pulse_length=pulse, range_margin=margin)
    samples = n * geo.radar().n_range_samples
    if samples > MAX_ECHO_SAMPLES:
        raise ConfigError("aperture.n_pulses", f"{n} pulses x {geo.radar().n_range_samples} range samples = "
                          f"{samples:.3g} echo samples; at most {MAX_ECHO_SAMPLES:.3g} (fewer pulses, a smaller scene "
                          "or a smaller radar.range_margin_m)")
    try:  # the source's fixed PRF must cover the Doppler band at this speed (the echoes would alias)
        geo.radar().check_doppler(speed)
    except ConfigError as err:
        if err.field != "prf":
            raise
        raise ConfigError("trajectory.speed", f"{err.message} (the PRF is the source's; lower trajectory.speed)") from None
    return geo


def read_scene(cfg: dict, geo: QualityGeometry) -> QualitySceneSpec:
    """``[scene]`` checked (type, seed, points, point_to_clutter_db, clutter_density [1/m^2], usu_cells) with the
    receiver of ``[radar]``: receiver_noise, snr_db (per-sample SNR of the strongest scatterer [dB], radar.echoes;
    used when receiver_noise is true)."""
    out = QualitySceneSpec(type=choice(cfg, "scene", "type", SCENE_TYPES),
                           seed=integer(cfg, "scene", "seed", 0, 2**63 - 1),
                           points=integer(cfg, "scene", "points", 0, 1000),
                           point_to_clutter_db=number(cfg, "scene", "point_to_clutter_db", -40.0, 80.0, "dB"),
                           clutter_density=number(cfg, "scene", "clutter_density", 0.0, 100.0, "1/m^2"),
                           usu_cells=integer(cfg, "scene", "usu_cells", 24, 240),
                           receiver_noise=boolean(cfg, "radar", "receiver_noise"),
                           snr_db=number(cfg, "radar", "snr_db", -60.0, 100.0, "dB"))
    scatterers = out.scatterers(geo)
    field = "scene.clutter_density" if out.type == "point-clutter" else "scene.usu_cells"
    if scatterers < 1:
        raise ConfigError("scene.points", "the scene has no scatterer: give points or clutter_density > 0")
    if scatterers * geo.n_pulses > MAX_ECHO_WORK:
        raise ConfigError(field, f"{scatterers:.0f} scatterers x {geo.n_pulses} pulses = {scatterers * geo.n_pulses:.3g}"
                          f" echo evaluations; at most {MAX_ECHO_WORK:.0e}")
    return out
