"""The ``nav-source-focus`` kind: which navigation source focuses a back-projected Ku-band image (Sun 2022 §6.2-6.3,
Figs. 6.5-6.9; claims T27-T32). Configuration and wiring of ``sarnav.simulation.nav_focus`` (``FocusParams`` ->
``run_focus_records``); the records, ``focus.csv`` and ``figures/images.png`` in docs/particles.md
"nav-source-focus".
"""

from __future__ import annotations

import math
from pathlib import Path

from sarnav.analysis.sources import filter_nees_summary, source_rmse
from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import validate_campaign
from sarnav.montecarlo.record import RunRecord
from sarnav.radar.params import RadarParams
from sarnav.scenarios.fields import bounded_vector, get, integer, name_list, number, number_list
from sarnav.scenarios.multi_imu import MAX_PARTICLES, MIN_PARTICLES, SourceKind
from sarnav.scenarios.vocabulary import doppler_prf_check, make_radar, radar_fields
from sarnav.simulation.fusion_records import AXES
from sarnav.simulation.nav_focus import FOCUS_ATTRS, FOCUS_FILTERS, FOCUS_METRICS, FocusGeometry, FocusParams, \
    run_focus_records
from sarnav.simulation.nav_sources import NAV_SOURCES
from sarnav.trajectory.vibration import check_tones

__all__ = ["NavFocusKind", "FOCUS_FILTERS", "FocusParams"]

#: receive-window margin beyond the reflectors' slant ranges over the aperture [m]
RANGE_MARGIN = 3.0


def _reflectors(cfg):
    along = number_list(cfg, "scene", "along_track_m", -50.0, 50.0, "m")
    ground = number_list(cfg, "scene", "ground_range_m", 2.0, 500.0, "m")
    if len(ground) != len(along):
        raise ConfigError("scene.ground_range_m", f"must have one entry per scene.along_track_m ({len(along)}), "
                          f"got {len(ground)}")
    return tuple(zip(along, ground))


def _vibration(cfg) -> tuple:
    """``cart.vibration_hz`` and ``cart.vibration_m`` (one [north, east, down] per tone; both empty: none) as
    ((f, (aN, aE, aD)), ...), checked by ``trajectory.vibration.check_tones``."""
    return tuple((f, a) for f, a, _ in check_tones(get(cfg, "cart", "vibration_hz"), get(cfg, "cart", "vibration_m")))


def _sources(cfg):
    src = name_list(cfg, "navigation", "sources", NAV_SOURCES)
    if "truth" not in src:
        raise ConfigError("navigation.sources", "must include 'truth' (the reference image)")
    if not any(s in src for pair in FOCUS_FILTERS.values() for s in pair):
        raise ConfigError("navigation.sources", "must include a filter with a covariance: upf, kf-interp, spline-pf "
                          "or spline-kf")
    return tuple(src)


def _radar(cfg, reflectors, height, speed, n_pulses) -> RadarParams:
    """The configured radar with a receive window over the reflectors' slant ranges along the aperture."""
    preset, fields = radar_fields(cfg)
    first = make_radar(preset, fields)
    half = 0.5 * speed * n_pulses / first.prf
    # along-track separations: the aperture's ends, its centre and, for a reflector inside it, closest approach (0)
    ranges = [math.sqrt(g * g + height * height + d * d) for a, g in reflectors
              for d in (a - half, a + half, a) + ((0.0,) if a - half <= 0.0 <= a + half else ())]
    window = first.receive_window((min(ranges), max(ranges)), RANGE_MARGIN)
    if window["near_range"] <= 0.0:
        raise ConfigError("scene.ground_range_m", f"the nearest reflector ({min(ranges):.3g} m) is within the pulse "
                          f"half-extent + margin ({first.pulse_half_extent + RANGE_MARGIN:.3g} m) of the radar")
    return make_radar(preset, fields, **window)


def parse(cfg: dict) -> FocusParams:
    """Validate ``cfg`` and convert it to SI; ConfigError names the first bad field and its range."""
    runs, _ = validate_campaign(cfg)
    speed = number(cfg, "cart", "speed", 0.05, 50.0, "m/s")
    run_in = number(cfg, "cart", "run_in_s", 1.0, 600.0, "s")
    height = number(cfg, "cart", "antenna_height_m", 0.0, 100.0, "m")
    n_pulses = integer(cfg, "aperture", "n_pulses", 16, 30_000)
    reflectors = _reflectors(cfg)
    radar = _radar(cfg, reflectors, height, speed, n_pulses)
    doppler_prf_check(radar, speed)  # show refuses what the echo simulation would, as radar.prf_hz
    spacing = number(cfg, "image", "spacing_m", 1e-3, 1.0, "m")
    chip = number(cfg, "image", "chip_half_m", 0.05, 20.0, "m")
    if chip / spacing < 8 or chip / spacing > 500:
        raise ConfigError("image.chip_half_m", f"must be 8 to 500 pixels of image.spacing_m = {spacing} m, got {chip}")
    sig = bounded_vector(cfg, "navigation", "fix_sigma_m", 1e-3, 100.0, unit="m")
    corr = bounded_vector(cfg, "navigation", "fix_correlated_sigma_m", 0.0, 100.0, unit="m")
    tau = number(cfg, "navigation", "fix_correlation_time_s", 1.0, 1e6, "s")
    geo = FocusGeometry(radar=radar, speed=speed, run_in=run_in, n_pulses=n_pulses, reflectors=reflectors,
                        antenna_height=height, chip_half=chip, spacing=spacing, vibration=_vibration(cfg))
    return FocusParams(runs, geo, _sources(cfg), integer(cfg, "navigation", "n_particles", MIN_PARTICLES, MAX_PARTICLES),
                       integer(cfg, "navigation", "adis_particles", MIN_PARTICLES, MAX_PARTICLES), sig, corr, tau)


class NavFocusKind(SourceKind):
    """Which navigation source focuses a BPA image (module docstring)."""

    kind = scenario = "nav-source-focus"

    def parse(self, cfg: dict) -> FocusParams:
        return parse(cfg)

    def sources(self, prm) -> list[str]:
        return list(prm.sources)

    def extra_attrs(self, cfg: dict) -> dict:
        return dict(FOCUS_ATTRS)

    def extra_coords(self, cfg: dict) -> dict:
        prm = self.parse(cfg)
        pt = prm.geometry.pulse_times()
        return {"source": (list(prm.sources), {"units": "", "description": "navigation sources"}),
                "reflector": (list(range(len(prm.geometry.reflectors))), {"units": "", "description": "reflector "
                              "index (scene.along_track_m, scene.ground_range_m)"}),
                "metric": (list(FOCUS_METRICS), {"units": ["m", "1", "m", "1", "1"], "description": "focus measures "
                           "(units: metric_units; pslr_along_db in dB and entropy in nats, dimensionless)"}),
                "axis": (list(AXES), {"units": "", "description": "NED axes"}),
                "filter": (self.filters(prm), {"units": "", "description": "filters with a covariance"}),
                "pulse": (pt, {"units": "s", "description": "pulse times"})}

    def run_batch(self, prm: FocusParams, seeds, run_ids) -> list[RunRecord]:
        return run_focus_records(prm, seeds, run_ids)

    def summary_extras(self, results) -> dict:
        from sarnav.analysis.sources import focus_table

        out = source_rmse(results)
        out["filter_nees"] = filter_nees_summary(results)
        out["focus"] = {row["source"]: {k: v for k, v in row.items() if k != "source"} for row in focus_table(results)}
        return out

    def run_scenario(self, cfg: dict, out, figures: bool = True, **campaign_opts):
        """``sarnav run nav-source-focus``: the campaign, then ``focus.csv`` and (``figures``) the figures."""
        from sarnav.analysis.sources import focus_table
        from sarnav.montecarlo.campaign import run_campaign
        from sarnav.report.figures import write_campaign_figures
        from sarnav.report.source_figures import write_focus_csv

        res = run_campaign(cfg, out, kind=self, **campaign_opts)
        write_focus_csv(focus_table(res.dataset), Path(out) / "focus.csv")
        if figures:
            write_campaign_figures(res.dataset, out, kind=self)
        return res

    def figures(self, results, outdir) -> list[str]:
        """``images.png``: run 0's images of every source side by side (run 0 simulated again from its seed: the
        same numbers as the stored run)."""
        from sarnav.montecarlo.seeding import run_seeds
        from sarnav.report.source_figures import plot_focus_images
        from sarnav.simulation.nav_focus import run_scene_images
        from sarnav.tomlio import parse_toml

        cfg = parse_toml(results.attrs["scenario"])
        prm = self.parse(cfg)
        seed0 = run_seeds(int(cfg["campaign"]["seed"]), int(cfg["campaign"]["runs"]))[0]
        res, images, extent = run_scene_images(prm, seed0)
        return [plot_focus_images(images, extent, res.targets[:, :2], Path(outdir) / "images.png",
                                  title=f"{cfg['scenario']['name']}: run 0, BPA per navigation source")]
