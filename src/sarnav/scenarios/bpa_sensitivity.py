"""Study ``bpa-sensitivity``: image shift and blur of a BPA image formed with an erroneous trajectory (thesis ch. 4).

Configuration and wiring only: the defaults (the geometry, which the thesis does not give for ch. 4:
docs/scenarios/bpa-sensitivity.md), ``parse`` (TOML -> :class:`~sarnav.analysis.bpa_sensitivity.BpaSensitivityParams`)
and the kind; the study itself is ``sarnav.analysis.bpa_sensitivity.run``, its table and figure
``sarnav.report.sensitivity``.
"""

from __future__ import annotations

from pathlib import Path

from sarnav.analysis.bpa_sensitivity import (MAX_PIXEL_PULSES, THESIS_SIM_ERRORS, BpaSensitivityParams,
                                             ImageSettings, image_pixels, make_geometry, plan_case, run)
from sarnav.errors import ConfigError, require_finite
from sarnav.scenarios.fields import choice, get, number, positive, table
from sarnav.scenarios.kind_base import FileKind
from sarnav.scenarios.registry import packaged
from sarnav.scenarios.vocabulary import (MAX_SPEED, doppler_prf_check, echo_block_check, make_radar, positive_up_to,
                                         radar_fields, read_altitude)

INTERPOLATIONS = ("nearest", "linear", "cubic", "upsample")
#: validation limits: flight altitude and target ground range [m], pulses in the aperture
MAX_ALTITUDE = 1.0e5
MAX_GROUND_RANGE = 1.0e5
MIN_PULSES, MAX_PULSES = 8, 65536


def default_config() -> dict:
    """The ``bpa-sensitivity`` study: ``defaults/bpa-sensitivity.toml`` (``[errors]``: the thesis' simulated errors,
    ``analysis.bpa_sensitivity.THESIS_SIM_ERRORS``)."""
    return packaged("bpa-sensitivity")


def parse(cfg: dict) -> BpaSensitivityParams:
    """Checked content of the study; ConfigError names the first bad field and its range."""
    r, e = table(cfg, "radar"), table(cfg, "errors")
    read_altitude(cfg, 0.0, MAX_ALTITUDE)
    positive_up_to("trajectory.speed", get(cfg, "trajectory", "speed"), MAX_SPEED, "m/s")
    duration = number(cfg, "trajectory", "duration", 0.5, 60.0, "s")
    positive_up_to("scene.target_ground_range", get(cfg, "scene", "target_ground_range"), MAX_GROUND_RANGE, "m")
    if r.get("preset") != "nav-paper-sim":
        raise ConfigError("radar.preset", f"must be 'nav-paper-sim' (the study's radar), got {r.get('preset')!r}")
    n_pulses = duration * positive(cfg, "radar", "prf_hz", "Hz")
    if not MIN_PULSES <= n_pulses <= MAX_PULSES:
        raise ConfigError("radar.prf_hz", f"trajectory.duration x radar.prf_hz must give {MIN_PULSES} to {MAX_PULSES} "
                          f"pulses, got {n_pulses:g}")
    number(cfg, "radar", "pulse_length_us", 0.01, 10.0, "us")
    number(cfg, "radar", "range_margin_m", 5.0, 500.0, "m")
    number(cfg, "image", "spacing", 0.01, 1.0, "m")
    number(cfg, "image", "margin", 0.5, 50.0, "m")
    choice(cfg, "image", "interpolation", INTERPOLATIONS)
    for name in e:
        if name not in THESIS_SIM_ERRORS:
            raise ConfigError(f"errors.{name}", f"unknown error; known: {', '.join(THESIS_SIM_ERRORS)}")
        require_finite(f"errors.{name}", e[name], -10.0, 10.0, THESIS_SIM_ERRORS[name][3])
    if not e:
        raise ConfigError("errors", "needs at least one injected error")
    return _physics(cfg)


def validate(cfg: dict) -> None:
    """Raise ConfigError naming the first bad field (:func:`parse`)."""
    parse(cfg)


def _physics(cfg: dict) -> BpaSensitivityParams:
    """What ``run`` would otherwise find out while simulating (``show`` refuses the same): the radar (RadarParams,
    the Doppler band at the study's speed: ``radar.prf_hz``), the echo block's size, and per injected error an
    estimated track whose closest approach to the target lies in the aperture and an image of bounded size."""
    geo = geometry(cfg)
    params = radar(cfg, geo)
    doppler_prf_check(params, geo.speed)
    echo_block_check(len(geo.times), params.n_range_samples)
    im = cfg["image"]
    settings = ImageSettings(float(im["spacing"]), float(im["margin"]), im["interpolation"])
    ref = image_pixels(settings.margin, settings.margin, settings.spacing) * len(geo.times)
    if ref > MAX_PIXEL_PULSES:
        raise ConfigError("image.spacing", f"{settings.spacing:g} m over image.margin = {settings.margin:g} m is "
                          f"{ref:.3g} pixel-pulses per image (at most {MAX_PIXEL_PULSES:.3g}): a larger spacing or a "
                          "smaller margin")
    for name, value in cfg["errors"].items():
        plan_case(name, float(value), geo, settings)
    return BpaSensitivityParams(geometry=geo, radar=params, errors=dict(cfg["errors"]), image=settings)


def geometry(cfg: dict):
    tr = cfg["trajectory"]
    return make_geometry(float(tr["speed"]), -float(tr["start_ned"][2]), float(cfg["scene"]["target_ground_range"]),
                         float(tr["duration"]), float(cfg["radar"]["prf_hz"]), start=tr["start_ned"])


def radar(cfg: dict, geo):
    """The nav-paper radar with the study's PRF and chirp; receive window R0 - margin - cT/4 .. R0 + margin + cT/4."""
    preset, fields = radar_fields(cfg)
    params = make_radar(preset, fields)
    r0 = geo.mid_aperture_range
    return make_radar(preset, fields, **params.receive_window((r0, r0), float(cfg["radar"]["range_margin_m"])))


def study(cfg: dict, names=None):
    """(results, reference image) of every error of ``cfg`` (or the named ones): ``analysis.bpa_sensitivity.run``."""
    return run(parse(cfg), names)


def run_sensitivity(cfg: dict, out_dir, figures: bool = True, overwrite: bool = False) -> Path:
    """Run the study, write ``sensitivity.csv`` and (``figures``) ``sensitivity.png`` into ``out_dir`` (claimed as
    ``montecarlo.outdir.OutputFolder``); return the CSV."""
    from sarnav.montecarlo.outdir import OutputFolder, identity
    from sarnav.report.sensitivity import plot_grid, write_csv

    out = Path(out_dir)
    prm = parse(cfg)
    with OutputFolder(out, identity(cfg), overwrite=overwrite):
        results, ref = run(prm)
        path = write_csv(results, out / "sensitivity.csv")
        if figures:
            plot_grid(results, ref, out / "sensitivity.png")
    return path


class BpaSensitivityKind(FileKind):
    """Registry entry for the study; ``sarnav run bpa-sensitivity`` runs :func:`run_sensitivity` (the deterministic
    study: ``sensitivity.csv`` and, unless ``--no-figures``, ``sensitivity.png``), not the Monte Carlo engine."""

    kind = "bpa-sensitivity"
    config, check, write = staticmethod(default_config), staticmethod(validate), staticmethod(run_sensitivity)
