"""Image-formation scenarios (``kind = "image"``): one block of echoes focused into one image.

Two named scenarios, each a nested dict that round-trips through TOML:

* ``point-target`` — one point target in the middle of the block (the point-target figures of the
  thesis ch. 5 / anchors-sar §3 checks: IRW, PSLR, ISLR against theory);
* ``scatterers`` — a random field of point scatterers (Poisson, seeded) over the imaged patch.

Tables (units in the key names, converted once with :mod:`sarnav.units`)::

    [scenario]   name, kind = "image", description
    [radar]      carrier_ghz, bandwidth_mhz, sample_rate_mhz, pulse_length_us, prf_hz, antenna_length_m,
                 look_side, range_window, antenna_pattern (bool), snr_db (<= 200; 200 = no noise)
    [trajectory] speed_mps, altitude_m, duration_s       (straight and level, heading north)
    [scene]      type ("point" | "random"), seed,
                 target_along_track_m, target_slant_range_m          (point)
                 along_track_extent_m, slant_range_min_m, slant_range_max_m,
                 density_per_m2 (per m^2 of flat ground), amplitude_law  (random)
    [image]      algorithm ("rda" | "bpa"), window, rcmc_kernel, azimuth_model, speed_error_mps,
                 autofocus ("none" | "mapdrift" | "contrast"), margin_m, bpa_interpolation

The antenna flies north at ``altitude_m``, looking right (east) by default; pulse times are
centred on 0, so the aperture centre is at north = 0 and the image's along-track axis is measured
from it. ``image.speed_error_mps`` is added to the true speed for focusing (a navigation speed
error, to exercise autofocus). The receive window spans the imaged slant ranges plus the pulse
half-extent cT/4 and ``image.margin_m`` on both sides.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError

__all__ = ["IMAGE_SCENARIOS", "default_config", "validate", "build_pulses", "load_image_scenario",
           "ALGORITHMS", "AUTOFOCUS"]

ALGORITHMS = ("rda", "bpa")
AUTOFOCUS = ("none", "mapdrift", "contrast")
SCENE_TYPES = ("point", "random")
#: snr_db at or above this value means "no receiver noise" (TOML has no None; inf is rejected)
NO_NOISE_SNR_DB = 200.0

_BASE = {
    "scenario": {"name": "", "kind": "image", "description": ""},
    "radar": {
        "carrier_ghz": 9.75, "bandwidth_mhz": 500.0, "sample_rate_mhz": 1000.0, "pulse_length_us": 1.0,
        "prf_hz": 250.0, "antenna_length_m": 0.5, "look_side": "right", "range_window": "none",
        "antenna_pattern": False, "snr_db": NO_NOISE_SNR_DB,
    },
    "trajectory": {"speed_mps": 60.0, "altitude_m": 1000.0, "duration_s": 1.0},
    "scene": {
        "type": "point", "seed": 0,
        "target_along_track_m": 0.0, "target_slant_range_m": 2000.0,
        "along_track_extent_m": 40.0, "slant_range_min_m": 1985.0, "slant_range_max_m": 2020.0,
        "density_per_m2": 0.01, "amplitude_law": "rayleigh",
    },
    "image": {
        "algorithm": "rda", "window": "none", "rcmc_kernel": "sinc8", "azimuth_model": "parabolic",
        "speed_error_mps": 0.0, "autofocus": "none", "margin_m": 10.0, "bpa_interpolation": "upsample",
    },
}


def _point_target() -> dict:
    cfg = copy.deepcopy(_BASE)
    cfg["scenario"].update(name="point-target", description="One point target, 1-s X-band aperture at 60 m/s, "
                           "RDA point-target metrics against theory (IRW, PSLR, ISLR)")
    return cfg


def _scatterers() -> dict:
    cfg = copy.deepcopy(_BASE)
    cfg["scenario"].update(name="scatterers", description="Random field of point scatterers (Poisson, Rayleigh "
                           "amplitudes, seeded) over a 40 m x 35 m slant patch")
    cfg["scene"]["type"] = "random"
    cfg["radar"]["antenna_pattern"] = True
    return cfg


#: name -> factory of the default configuration
IMAGE_SCENARIOS = {"point-target": _point_target, "scatterers": _scatterers}


def default_config(name: str) -> dict:
    """A fresh copy of the named scenario's configuration."""
    if name not in IMAGE_SCENARIOS:
        raise ConfigError("scenario.name", f"unknown image scenario {name!r}; known: {', '.join(IMAGE_SCENARIOS)}")
    return IMAGE_SCENARIOS[name]()


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


def validate(cfg: dict) -> None:
    """Raise :class:`ConfigError` naming the first bad field and its valid range."""
    from sarnav.imaging.rda import RCMC_KERNELS
    from sarnav.signal.windows import as_window

    for table in _BASE:
        if not isinstance(cfg.get(table), dict):
            raise ConfigError(table, f"missing table [{table}]")
        unknown = set(cfg[table]) - set(_BASE[table])
        if unknown:
            raise ConfigError(f"{table}.{sorted(unknown)[0]}", f"unknown key (known: {', '.join(sorted(_BASE[table]))})")
        missing = set(_BASE[table]) - set(cfg[table])
        if missing:
            raise ConfigError(f"{table}.{sorted(missing)[0]}", "missing")
    if cfg["scenario"]["kind"] != "image":
        raise ConfigError("scenario.kind", f"must be 'image' for sarnav image, got {cfg['scenario']['kind']!r}")
    for key in ("carrier_ghz", "bandwidth_mhz", "sample_rate_mhz", "pulse_length_us", "prf_hz", "antenna_length_m"):
        _num(cfg, "radar", key, 0, None, lo_open=True)
    if cfg["radar"]["sample_rate_mhz"] < cfg["radar"]["bandwidth_mhz"]:
        raise ConfigError("radar.sample_rate_mhz", f"must be >= radar.bandwidth_mhz = {cfg['radar']['bandwidth_mhz']} "
                          f"(complex Nyquist), got {cfg['radar']['sample_rate_mhz']}")
    r = cfg["radar"]
    if r["bandwidth_mhz"] * 1e-3 >= 2.0 * r["carrier_ghz"]:
        raise ConfigError("radar.bandwidth_mhz", f"must be < 2 x radar.carrier_ghz = {2e3 * r['carrier_ghz']:g} MHz "
                          f"(lowest transmitted frequency > 0), got {r['bandwidth_mhz']}")
    if r["pulse_length_us"] * 1e-6 >= 1.0 / r["prf_hz"]:
        raise ConfigError("radar.pulse_length_us", f"must be shorter than the pulse repetition interval "
                          f"1/radar.prf_hz = {1e6 / r['prf_hz']:g} us, got {r['pulse_length_us']}")
    l_min = 0.886 * units.C / float(units.ghz_to_hz(r["carrier_ghz"])) / math.pi
    if r["antenna_length_m"] <= l_min:
        raise ConfigError("radar.antenna_length_m", f"must be > 0.886 lambda / pi = {l_min:.4g} m "
                          f"(-3 dB beamwidth below pi rad), got {r['antenna_length_m']}")
    _choice(cfg, "radar", "look_side", ("left", "right"))
    as_window(cfg["radar"]["range_window"], "radar.range_window")
    if not isinstance(cfg["radar"]["antenna_pattern"], bool):
        raise ConfigError("radar.antenna_pattern", f"must be true or false, got {cfg['radar']['antenna_pattern']!r}")
    _num(cfg, "radar", "snr_db", -50.0, NO_NOISE_SNR_DB)
    _num(cfg, "trajectory", "speed_mps", 0, 1e4, lo_open=True)
    h = _num(cfg, "trajectory", "altitude_m", 0, 1e6)
    _num(cfg, "trajectory", "duration_s", 0, 60.0, lo_open=True)
    n_pulses = cfg["trajectory"]["duration_s"] * cfg["radar"]["prf_hz"]
    if not 8 <= n_pulses <= 65536:
        raise ConfigError("trajectory.duration_s", f"duration x radar.prf_hz must give 8 to 65536 pulses, got {n_pulses:g}")
    st = _choice(cfg, "scene", "type", SCENE_TYPES)
    _num(cfg, "scene", "seed", 0, None, integer=True)
    if st == "point":
        _num(cfg, "scene", "target_slant_range_m", h, None, lo_open=True)
        half = 0.5 * cfg["trajectory"]["speed_mps"] * cfg["trajectory"]["duration_s"]
        _num(cfg, "scene", "target_along_track_m", -half, half)
    else:
        _num(cfg, "scene", "along_track_extent_m", 0, None, lo_open=True)
        rmin = _num(cfg, "scene", "slant_range_min_m", h, None, lo_open=True)
        _num(cfg, "scene", "slant_range_max_m", rmin, None, lo_open=True)
        _num(cfg, "scene", "density_per_m2", 0, 10.0, lo_open=True)
        _choice(cfg, "scene", "amplitude_law", ("rayleigh", "constant"))
    _check_doppler_band(cfg)
    _choice(cfg, "image", "algorithm", ALGORITHMS)
    as_window(cfg["image"]["window"], "image.window")
    _choice(cfg, "image", "rcmc_kernel", tuple(RCMC_KERNELS))
    _choice(cfg, "image", "azimuth_model", ("parabolic", "hyperbolic"))
    _num(cfg, "image", "speed_error_mps", -0.5 * cfg["trajectory"]["speed_mps"], 0.5 * cfg["trajectory"]["speed_mps"])
    _choice(cfg, "image", "autofocus", AUTOFOCUS)
    if cfg["image"]["autofocus"] != "none" and cfg["image"]["algorithm"] != "rda":
        raise ConfigError("image.autofocus", "autofocus works on RDA images; set image.algorithm = \"rda\"")
    _num(cfg, "image", "margin_m", 0, 1e4)
    _choice(cfg, "image", "bpa_interpolation", ("nearest", "linear", "cubic", "upsample"))


def _check_doppler_band(cfg: dict) -> None:
    """The scene's azimuth band must fit in the PRF (the RDA azimuth FFT is circular).

    A scatterer at along-track y seen by pulses t in [-T/2, T/2] has Doppler -K_a (t - y/V) (paper
    eq. 8), so the scene occupies K_a (T + 2 max|y| / V) Hz at its nearest range (largest K_a); with
    the antenna pattern the band is at most the beam's Doppler bandwidth 0.886 * 2V / L_a.
    """
    v = float(cfg["trajectory"]["speed_mps"])
    lam = units.C / float(units.ghz_to_hz(cfg["radar"]["carrier_ghz"]))
    r_min = imaged_slant_ranges(cfg)[0]
    s = cfg["scene"]
    half = abs(s["target_along_track_m"]) if s["type"] == "point" else 0.5 * s["along_track_extent_m"]
    band = 2.0 * v**2 / (lam * r_min) * (cfg["trajectory"]["duration_s"] + 2.0 * half / v)
    if cfg["radar"]["antenna_pattern"]:
        band = min(band, 0.886 * 2.0 * v / float(cfg["radar"]["antenna_length_m"]))
    if band > cfg["radar"]["prf_hz"]:
        raise ConfigError("radar.prf_hz", f"must be >= the scene's azimuth bandwidth {band:.4g} Hz "
                          f"(K_a (T + 2 max|y|/V) at the nearest range), got {cfg['radar']['prf_hz']}")


def imaged_slant_ranges(cfg: dict) -> tuple[float, float]:
    """(min, max) slant range of the imaged patch [m]."""
    s = cfg["scene"]
    if s["type"] == "point":
        return float(s["target_slant_range_m"]), float(s["target_slant_range_m"])
    return float(s["slant_range_min_m"]), float(s["slant_range_max_m"])


def radar_params(cfg: dict):
    """The :class:`~sarnav.radar.params.RadarParams` of a validated configuration."""
    from sarnav.radar.params import RadarParams

    r = cfg["radar"]
    fs = float(units.mhz_to_hz(r["sample_rate_mhz"]))
    t_p = float(units.us_to_s(r["pulse_length_us"]))
    pad = units.C * t_p / 4.0 + float(cfg["image"]["margin_m"])
    lo, hi = imaged_slant_ranges(cfg)
    dr = units.C / (2.0 * fs)
    n = int(math.ceil((hi - lo + 2 * pad) / dr)) + 1
    return RadarParams(carrier_frequency=float(units.ghz_to_hz(r["carrier_ghz"])),
                       bandwidth=float(units.mhz_to_hz(r["bandwidth_mhz"])), pulse_length=t_p, sample_rate=fs,
                       prf=float(r["prf_hz"]), near_range=lo - pad, n_range_samples=n,
                       antenna_length=float(r["antenna_length_m"]), look_side=r["look_side"],
                       range_window=r["range_window"], azimuth_window=cfg["image"]["window"])


def trajectory(cfg: dict) -> tuple[np.ndarray, np.ndarray]:
    """(pulse_times (P,), positions (P, 3) NED): straight and level, north, times centred on 0."""
    tr = cfg["trajectory"]
    prf = float(cfg["radar"]["prf_hz"])
    n = int(round(tr["duration_s"] * prf))
    t = (np.arange(n, dtype=np.float64) - n // 2) / prf
    pos = np.zeros((n, 3))
    pos[:, 0] = float(tr["speed_mps"]) * t
    pos[:, 2] = -float(tr["altitude_m"])
    return t, pos


def _ground(r0, h, side):
    return (1.0 if side == "right" else -1.0) * math.sqrt(r0**2 - h**2)


def scene(cfg: dict):
    """The :class:`~sarnav.radar.scene.Scene` (random fields drawn from ``scene.seed``)."""
    from sarnav.radar.scene import point_targets, random_scatterers

    s = cfg["scene"]
    h = float(cfg["trajectory"]["altitude_m"])
    side = cfg["radar"]["look_side"]
    if s["type"] == "point":
        return point_targets([float(s["target_along_track_m"]), _ground(s["target_slant_range_m"], h, side), 0.0])
    rng = np.random.default_rng(np.random.SeedSequence(int(s["seed"])))
    half = 0.5 * float(s["along_track_extent_m"])
    g = sorted(_ground(float(s[k]), h, side) for k in ("slant_range_min_m", "slant_range_max_m"))
    # homogeneous Poisson field on the flat ground (density per m^2 of ground)
    return random_scatterers(rng, ((-half, half), tuple(g)), float(s["density_per_m2"]), s["amplitude_law"])


def build_pulses(cfg: dict):
    """Simulate and range-compress the echoes of a validated configuration.

    Returns
    -------
    rc : range-compressed ``PulseData`` (true positions).
    scene : the simulated ``Scene``.
    params : the ``RadarParams``.
    """
    from sarnav.imaging.range_compression import range_compress
    from sarnav.radar.echoes import simulate_echoes

    validate(cfg)
    params = radar_params(cfg)
    t, pos = trajectory(cfg)
    sc = scene(cfg)
    snr = float(cfg["radar"]["snr_db"])
    noisy = snr < NO_NOISE_SNR_DB
    rng = np.random.default_rng(np.random.SeedSequence([int(cfg["scene"]["seed"]), 1])) if noisy else None
    raw = simulate_echoes(params, pos, t, sc, snr_db=snr if noisy else None, rng=rng,
                          pattern=bool(cfg["radar"]["antenna_pattern"]))
    return range_compress(raw), sc, params


def load_image_scenario(source: str, overrides=()) -> dict:
    """A named image scenario or a ``.toml`` file (merged onto its named or base defaults), with
    ``--set key=value`` overrides applied, validated.

    Uses the TOML loading and override parsing of :mod:`sarnav.scenarios.config`.
    """
    import os

    from sarnav.scenarios.config import apply_overrides, load_toml_file, merge_onto

    src = os.fspath(source)
    if src in IMAGE_SCENARIOS:
        cfg = default_config(src)
    elif src.endswith(".toml") or os.path.isfile(src):
        raw = load_toml_file(src)
        name = raw.get("scenario", {}).get("name") if isinstance(raw.get("scenario"), dict) else None
        template = default_config(name) if name in IMAGE_SCENARIOS else copy.deepcopy(_BASE)
        cfg = merge_onto(template, raw)
    else:
        raise ConfigError("scenario", f"unknown image scenario {src!r}; known: {', '.join(IMAGE_SCENARIOS)} "
                          "or a FILE.toml")
    cfg = apply_overrides(cfg, list(overrides))
    validate(cfg)
    return cfg
