"""Image-formation scenarios (``kind = "image"``): one block of echoes focused into one image (docs/imaging.md
"Scenarios": the tables ``[radar]``, ``[trajectory]``, ``[scene]``, ``[image]`` and their keys).

``point-target`` (one point target: IRW, PSLR, ISLR against theory) and ``scatterers`` (a Poisson field of point
scatterers, seeded). The antenna flies north through ``trajectory.start_ned`` at t = 0 (pulse times centred on 0),
looking right by default; ``image.speed_error_mps`` is added to the true speed for focusing; the receive window spans
the imaged slant ranges plus cT/4 and ``radar.range_margin_m``. Configuration and wiring only: the defaults,
``parse`` (TOML -> :class:`~sarnav.simulation.image_scene.ImageSceneParams`) and the kind; the experiment is
``simulation.image_scene.run``, the files ``report.image_files.write_scene_image`` (CPHD, SICD through ``sarnav.io``).
"""

from __future__ import annotations

import math
from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.imaging.backprojection import INTERPOLATIONS
from sarnav.imaging.straight_block import ALGORITHMS, AUTOFOCUS
from sarnav.radar.params import RadarParams
from sarnav.scenarios.fields import known_keys
from sarnav.scenarios.kind_base import FileKind
from sarnav.scenarios.registry import packaged
from sarnav.scenarios.vocabulary import echo_block_check, make_radar, radar_fields, radar_key
from sarnav.simulation.image_scene import ImageSceneParams, run

__all__ = ["IMAGE_SCENARIOS", "ImageKind", "default_config", "validate", "parse", "run_image", "origin_llh",
           "ALGORITHMS", "AUTOFOCUS"]

SCENE_TYPES = ("point", "random")
#: snr_db at or above this value means "no receiver noise" (TOML has no None; inf is rejected)
NO_NOISE_SNR_DB = 200.0

#: the registered scenarios of the kind (``defaults/<name>.toml``)
IMAGE_SCENARIOS = ("point-target", "scatterers")


def default_config(name: str = "point-target") -> dict:
    """A fresh copy of the named image scenario's configuration (the reference file of the kind: point-target)."""
    if name not in IMAGE_SCENARIOS:
        raise ConfigError("scenario.name", f"unknown image scenario {name!r}; known: {', '.join(IMAGE_SCENARIOS)}")
    return packaged(name)


def _num(cfg, table, key, lo=None, hi=None, lo_open=False, integer=False):
    field = f"{table}.{key}"
    v = cfg[table].get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)):
        raise ConfigError(field, f"must be {'an integer' if integer else 'a number'}, got {v!r}")
    if not math.isfinite(v):
        raise ConfigError(field, f"must be finite, got {v!r}")
    bad_lo = lo is not None and (v <= lo if lo_open else v < lo)
    if bad_lo or (hi is not None and v > hi):
        rng = f"{'(' if lo_open else '['}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}]"
        raise ConfigError(field, f"must be in {rng}, got {v!r}")
    return v


def _choice(cfg, table, key, options):
    v = cfg[table].get(key)
    if v not in options:
        raise ConfigError(f"{table}.{key}", f"must be one of {tuple(options)}, got {v!r}")
    return v


def _tables(cfg: dict) -> None:
    base = packaged("point-target")
    for table in base:
        if not isinstance(cfg.get(table), dict):
            raise ConfigError(table, f"missing table [{table}]")
        known_keys(cfg[table], base[table], table)
        missing = set(base[table]) - set(cfg[table])
        if missing:
            raise ConfigError(f"{table}.{sorted(missing)[0]}", "missing")
    if cfg["scenario"]["kind"] != "image":
        raise ConfigError("scenario.kind", f"must be 'image' for sarnav image, got {cfg['scenario']['kind']!r}")


def altitude(cfg: dict) -> float:
    return -float(cfg["trajectory"]["start_ned"][2])


def validate(cfg: dict) -> None:
    """Raise :class:`ConfigError` naming the first bad field and its valid range (:func:`parse`)."""
    parse(cfg)


def _check(cfg: dict) -> None:
    from sarnav.imaging.rda import RCMC_KERNELS
    from sarnav.signal.windows import Window

    _tables(cfg)
    if not isinstance(cfg["radar"]["antenna_pattern"], bool):
        raise ConfigError("radar.antenna_pattern", f"must be true or false, got {cfg['radar']['antenna_pattern']!r}")
    _num(cfg, "radar", "snr_db", -50.0, NO_NOISE_SNR_DB)
    _num(cfg, "radar", "range_margin_m", 0, 1e4)
    start = cfg["trajectory"]["start_ned"]
    if not (isinstance(start, list) and len(start) == 3 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                                 and math.isfinite(v) for v in start)):
        raise ConfigError("trajectory.start_ned", f"must be 3 finite numbers [m], got {start!r}")
    if not -1e6 <= start[2] < 0:
        raise ConfigError("trajectory.start_ned[2]", f"must be in [-1e6, 0) m (above the ground), got {start[2]!r}")
    _num(cfg, "trajectory", "speed", 0, 1e4, lo_open=True)
    h = altitude(cfg)
    _num(cfg, "trajectory", "duration", 0, 60.0, lo_open=True)
    _num(cfg, "radar", "prf_hz", 0, None, lo_open=True)
    n_pulses = cfg["trajectory"]["duration"] * cfg["radar"]["prf_hz"]
    if not 8 <= n_pulses <= 65536:
        raise ConfigError("trajectory.duration", f"duration x radar.prf_hz must give 8 to 65536 pulses, got {n_pulses:g}")
    st = _choice(cfg, "scene", "type", SCENE_TYPES)
    _num(cfg, "scene", "seed", 0, None, integer=True)
    if st == "point":
        _num(cfg, "scene", "target_slant_range_m", h, None, lo_open=True)
        half = 0.5 * cfg["trajectory"]["speed"] * cfg["trajectory"]["duration"]
        _num(cfg, "scene", "target_along_track_m", -half, half)
    else:
        _num(cfg, "scene", "along_track_extent_m", 0, None, lo_open=True)
        rmin = _num(cfg, "scene", "slant_range_min_m", h, None, lo_open=True)
        _num(cfg, "scene", "slant_range_max_m", rmin, None, lo_open=True)
        _num(cfg, "scene", "density_per_m2", 0, 10.0, lo_open=True)
        _choice(cfg, "scene", "amplitude_law", ("rayleigh", "constant"))
    origin_llh(cfg)
    params = radar_params(cfg)  # RadarParams validates the radar, naming the [radar] keys
    echo_block_check(n_pulses, params.n_range_samples)
    _choice(cfg, "image", "algorithm", ALGORITHMS)
    Window.from_spec(cfg["image"]["window"], "image.window")
    _choice(cfg, "image", "rcmc_kernel", tuple(RCMC_KERNELS))
    _choice(cfg, "image", "azimuth_model", ("parabolic", "hyperbolic"))
    _num(cfg, "image", "speed_error_mps", -0.5 * cfg["trajectory"]["speed"], 0.5 * cfg["trajectory"]["speed"])
    _choice(cfg, "image", "autofocus", AUTOFOCUS)
    if cfg["image"]["autofocus"] != "none" and cfg["image"]["algorithm"] != "rda":
        raise ConfigError("image.autofocus", "autofocus works on RDA images; set image.algorithm = \"rda\"")
    _choice(cfg, "image", "bpa_interpolation", INTERPOLATIONS)


def origin_llh(cfg: dict) -> list[float]:
    """``scene.origin_llh`` validated: latitude in [-90, 90] deg, longitude in [-180, 360] deg, height in
    [-1e4, 1e5] m above the WGS-84 ellipsoid."""
    v = cfg["scene"].get("origin_llh")
    ok = isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                     and math.isfinite(x) for x in v)
    if not ok or not (-90 <= v[0] <= 90 and -180 <= v[1] <= 360 and -1e4 <= v[2] <= 1e5):
        raise ConfigError("scene.origin_llh", "must be [latitude deg in [-90, 90], longitude deg in [-180, 360], "
                          f"height m in [-1e4, 1e5]], got {v!r}")
    return [float(x) for x in v]


def imaged_slant_ranges(cfg: dict) -> tuple[float, float]:
    """(min, max) slant range of the imaged patch [m]."""
    s = cfg["scene"]
    if s["type"] == "point":
        return float(s["target_slant_range_m"]), float(s["target_slant_range_m"])
    return float(s["slant_range_min_m"]), float(s["slant_range_max_m"])


def radar_params(cfg: dict):
    """The :class:`~sarnav.radar.params.RadarParams`: ``[radar]`` with a receive window over the imaged slant ranges
    plus the pulse half-extent cT/4 and ``radar.range_margin_m``."""
    from sarnav.errors import require_positive

    preset, fields = radar_fields(cfg)
    for key, field in (("pulse_length_us", "pulse_length"), ("sample_rate_mhz", "sample_rate")):
        if field in fields:  # used for the receive window before RadarParams sees them
            require_positive(f"radar.{key}", fields[field])
    window = RadarParams.window_over(imaged_slant_ranges(cfg), fields.get("pulse_length", 0.0), fields["sample_rate"],
                                     float(cfg["radar"]["range_margin_m"]), "radar.range_margin_m")
    azimuth_window = {"azimuth_window": cfg["image"]["window"]} if preset is None else {}
    return make_radar(preset, dict(fields, **azimuth_window), **window)


#: ImageSceneParams field -> [scene] key, of each scene type (the other type's keys are not read)
_SCENE_KEYS = {"point": {"target_along_track": "target_along_track_m", "target_slant_range": "target_slant_range_m"},
               "random": {"along_track_extent": "along_track_extent_m", "slant_range_min": "slant_range_min_m",
                          "slant_range_max": "slant_range_max_m", "density": "density_per_m2"}}


def parse(cfg: dict) -> ImageSceneParams:
    """Validate ``cfg`` and convert it to the :class:`ImageSceneParams` of the experiment; the scene's azimuth band
    against the PRF is ``ImageSceneParams.check_doppler_band``."""
    _check(cfg)
    tr, s, im, snr = cfg["trajectory"], cfg["scene"], cfg["image"], float(cfg["radar"]["snr_db"])
    scene = {field: float(s[key]) for field, key in _SCENE_KEYS[s["type"]].items()}
    if s["type"] == "random":
        scene["amplitude_law"] = s["amplitude_law"]
    prm = ImageSceneParams(
        radar=radar_params(cfg), start_ned=tuple(float(v) for v in tr["start_ned"]), speed=float(tr["speed"]),
        duration=float(tr["duration"]), scene=s["type"], seed=int(s["seed"]), **scene,
        snr_db=snr if snr < NO_NOISE_SNR_DB else None, antenna_pattern=cfg["radar"]["antenna_pattern"],
        algorithm=im["algorithm"], window=im["window"], rcmc_kernel=im["rcmc_kernel"],
        azimuth_model=im["azimuth_model"], autofocus=im["autofocus"], bpa_interpolation=im["bpa_interpolation"],
        speed_error=float(im["speed_error_mps"]), origin_llh=tuple(origin_llh(cfg)), name=cfg["scenario"]["name"])
    try:
        prm.check_doppler_band()
    except ConfigError as err:
        raise ConfigError(radar_key(err.field), err.message) from None
    return prm


def run_image(cfg: dict, out, overwrite: bool = False, *, cphd: bool = False, sicd: bool = False) -> dict:
    """Simulate, focus, measure (``simulation.image_scene.run``); write ``image.npz``, ``image.png`` and
    ``metrics.json`` into ``out`` (claimed as ``montecarlo.outdir.OutputFolder``: ``overwrite`` replaces another
    scenario's results), with ``cphd`` also the collect as ``collect.cphd``, with ``sicd`` the image as ``image.nitf``
    (BPA only; ``report.image_files.write_scene_image``); return the metrics."""
    from sarnav.montecarlo.outdir import OutputFolder, identity
    from sarnav.report.image_files import write_scene_image
    from sarnav.tomlio import dump_toml

    prm = parse(cfg)
    if sicd and prm.algorithm != "bpa":
        raise ConfigError("--sicd", f"a SICD holds a back-projected image on a plane; {prm.algorithm!r} "
                          "images have none: use --algorithm bpa (or sarnav image FILE.cphd --sicd)")
    with OutputFolder(out, identity(cfg), overwrite=overwrite):
        return write_scene_image(prm, run(prm), Path(out), cphd=cphd, sicd=sicd, scenario_toml=dump_toml(cfg))


class ImageKind(FileKind):
    """Kind ``"image"``: one simulated block of echoes focused into one image (not a Monte Carlo campaign);
    ``sarnav run point-target`` is ``sarnav image point-target``."""

    kind = "image"
    needs_campaign = False
    config, check, write = staticmethod(default_config), staticmethod(validate), staticmethod(run_image)
    options = ("overwrite",)
    what = "a single-image kind (sarnav image NAME)"
